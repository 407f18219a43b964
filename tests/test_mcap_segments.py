"""A recording in segments: what a restarted logger reads of the earlier ones, and their merge
into one complete file the plain mcap reader reads."""

from __future__ import annotations

from mcap.reader import make_reader

from fsw.interface import codec
from fsw.interface.messages import Measurement, RunStatus, Stamp
from ground.mcap_io.reader import is_complete
from ground.mcap_io.recorder import McapRecorder
from ground.mcap_io.segments import merge, recorded


def _measurement(i: int) -> Measurement:
    return Measurement(seq=i, t_s=6.0e8 + 60.0 * i, timestamp=Stamp(sec=1_700_000_000 + i, nsec=0), kind="range",
                       source="DSS-14", value=(1.5e8 + i,), sigma=(0.002,))


def _end(source: str) -> RunStatus:
    return RunStatus(t_s=6.0e8, timestamp=Stamp(sec=1_700_000_000, nsec=0), run_id="r", source=source,  # type: ignore[arg-type]
                     state="end-of-run", counts={"sim/measurements": 10})


def _write(path, seqs, *, status: RunStatus | None = None, cut: bool = False, attach: bool = True) -> None:
    with McapRecorder(path) as rec:
        if attach:
            rec.add_attachment("config.yaml", b"name: x\n", "application/yaml")
        for s in seqs:
            rec.write("sim/measurements", codec.to_json(_measurement(s)), 1_700_000_000_000_000_000 + s, None, s)
        rec.write("/_invalid/sim/measurements", b"{not json", 1_700_000_000_000_000_100, None, 0)
        if status is not None:
            rec.write(f"{status.source}/status", codec.to_json(status), 1_700_000_000_000_000_200, None, 1)
    if cut:  # a logger killed before its footer: the summary section and footer never written
        data = path.read_bytes()
        path.write_bytes(data[: len(data) * 3 // 4])
        assert not is_complete(path)


def test_earlier_segments_tell_what_is_recorded_and_which_ends_came(tmp_path):
    _write(tmp_path / "s0.mcap", range(0, 6), status=_end("sim"))
    _write(tmp_path / "s1.mcap", range(6, 8))
    got = recorded([tmp_path / "s0.mcap", tmp_path / "s1.mcap"])
    assert got.sequences == {"sim/measurements": list(range(8)), "sim/status": [1]}  # invalid payloads are not counted
    assert got.end_of_run["sim"] == _end("sim")


def test_merged_segments_read_with_the_plain_reader(tmp_path):
    _write(tmp_path / "s0.mcap", range(0, 6))
    _write(tmp_path / "s1.mcap", range(6, 10), status=_end("sim"))
    segments = merge([tmp_path / "s0.mcap", tmp_path / "s1.mcap"], tmp_path / "run.mcap")
    assert [(s.messages, s.complete) for s in segments] == [(7, True), (6, True)]
    assert segments[0].first_log_ns == 1_700_000_000_000_000_000 and segments[1].last_log_ns == 1_700_000_000_000_000_200
    with open(tmp_path / "run.mcap", "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None and summary.statistics.message_count == 13
        topics = {c.topic for c in summary.channels.values()}
        assert topics == {"/sim/measurements", "/_invalid/sim/measurements", "/sim/status"}  # one channel per topic
        seqs = [m.sequence for _, c, m in reader.iter_messages() if c.topic == "/sim/measurements"]
        assert seqs == list(range(10))
        assert [a.name for a in reader.iter_attachments()] == ["config.yaml"]  # once, not per segment
        listed = {m.name: m.metadata for m in reader.iter_metadata()}["navbank.segments"]
        assert listed == {"0": "s0.mcap: 7 messages", "1": "s1.mcap: 6 messages"}


def test_a_cut_short_segment_is_merged_up_to_its_last_complete_chunk(tmp_path):
    _write(tmp_path / "s0.mcap", range(0, 2000), cut=True)
    _write(tmp_path / "s1.mcap", range(2000, 2010))
    segments = merge([tmp_path / "s0.mcap", tmp_path / "s1.mcap"], tmp_path / "run.mcap")
    assert segments[0].complete is False and 0 < segments[0].messages < 2001
    assert is_complete(tmp_path / "run.mcap")
    with open(tmp_path / "run.mcap", "rb") as f:
        seqs = [m.sequence for _, c, m in make_reader(f).iter_messages() if c.topic == "/sim/measurements"]
    kept = len(seqs) - 10
    assert 0 < kept < 2000 and seqs == list(range(kept)) + list(range(2000, 2010))
    with open(tmp_path / "run.mcap", "rb") as f:
        listed = {m.name: m.metadata for m in make_reader(f).iter_metadata()}["navbank.segments"]
    assert listed["0"].endswith("(cut short)")
