"""FSW checkpoints: a core restored from one and fed the rest of the stream emits exactly what the
uninterrupted core emits; unusable files are refused with one line; writing is atomic."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import pickle

import pytest

from fsw.core import FswCore
from fsw.core import checkpoint as ck
from fsw.interface import auth, codec
from fsw.interface.messages import Measurement, RunStatus, Stamp
from sim.stream import SimRun, generate
from tools.scenario import ScenarioConfig, load_text_scenario, resolve


@pytest.fixture(scope="module")
def flown(short_e2e_yaml) -> tuple[ScenarioConfig, SimRun]:
    text = short_e2e_yaml.replace("fsw:\n", "fsw:\n  budget: {mode: work-units}\n", 1)
    cfg, seed = resolve(load_text_scenario(text), None)
    return cfg, generate(cfg.sim, seed=seed)


def _encoded(out: list) -> list[tuple[str, bytes]]:
    return [(topic, codec.to_json(msg)) for topic, msg in out]


@pytest.mark.parametrize("fraction", [0.0, 0.3, 0.7])
def test_a_resumed_core_emits_what_the_uninterrupted_one_emits(flown, tmp_path, fraction):
    cfg, run = flown
    ms: list[Measurement] = run.measurements
    k = int(fraction * len(ms))
    out: list = []
    core = FswCore(cfg.fsw, lambda t, m: out.append((t, m)), run_id="r")
    core.start()
    for meas in ms[:k]:
        core.ingest(meas)
    path = tmp_path / "fsw.ckpt"
    ck.write(path, ck.Checkpoint(core, core.taken, {"fsw/budget": 7}))
    at_checkpoint = len(out)

    resumed_out: list = []
    restored = ck.read(path, cfg.fsw, "r", lambda t, m: resumed_out.append((t, m)))
    assert restored.measurements_taken == k and restored.published == {"fsw/budget": 7}
    assert restored.producer_end is None
    for meas in ms[k:]:
        core.ingest(meas)
        restored.core.ingest(meas)
    core.finish()
    restored.core.finish()
    tail = _encoded(out[at_checkpoint:])
    assert len(tail) > 1000
    assert _encoded(resumed_out) == tail  # weights, anomaly, estimates, budget, status: byte for byte
    assert restored.core.status_counts() == core.status_counts()


def test_the_header_says_where_the_fsw_stood(flown, tmp_path):
    cfg, run = flown
    core = FswCore(cfg.fsw, lambda t, m: None, run_id="r")
    for meas in run.measurements[:100]:
        core.ingest(meas)
    end = RunStatus(t_s=1.0, timestamp=Stamp.from_unix(1.0), run_id="r", source="sim", state="end-of-run",
                    counts={"sim/measurements": 100})
    ck.write(tmp_path / "c", ck.Checkpoint(core, 100, {}, end))
    header = ck.read_header(tmp_path / "c")
    assert header.measurements_taken == 100 and header.t_s == core.t_last and header.producer_ended
    assert header.run_id == "r" and header.config_sha256 == ck.config_digest(cfg.fsw)
    assert ck.read(tmp_path / "c", cfg.fsw, "r", lambda t, m: None).producer_end == end


def test_an_unusable_checkpoint_is_refused_in_one_line(flown, tmp_path):
    cfg, run = flown
    core = FswCore(cfg.fsw, lambda t, m: None, run_id="r")
    path = tmp_path / "fsw.ckpt"
    ck.write(path, ck.Checkpoint(core, 0))
    data = path.read_bytes()
    header, payload = data.split(b"\n", 1)

    def refused(content: bytes | None, run_id: str = "r", config=cfg.fsw) -> str:
        target = tmp_path / "bad.ckpt"
        if content is not None:
            target.write_bytes(content)
        elif target.exists():
            target.unlink()
        with pytest.raises(ck.CheckpointError) as info:
            ck.read(target, config, run_id, lambda t, m: None)
        text = str(info.value)
        assert "\n" not in text and str(target) in text
        return text

    assert "of run 'r', not 'other'" in refused(data, run_id="other")
    other = dataclasses.replace(cfg.fsw, reorder_window=cfg.fsw.reorder_window + 1)
    assert "another FSW configuration" in refused(data, config=other)
    assert "truncated or damaged" in refused(data[:-10])
    assert "truncated or damaged" in refused(header + b"\n" + payload[:-1] + bytes([payload[-1] ^ 1]))
    newer = json.loads(header)
    newer["version"] = ck.VERSION + 1
    assert f"this FSW reads version {ck.VERSION}" in refused(json.dumps(newer).encode() + b"\n" + payload)
    assert "not a navbank FSW checkpoint" in refused(b"PK\x03\x04 something else entirely")
    assert "not a navbank FSW checkpoint" in refused(b"")
    assert "No such file" in refused(None)


def test_writing_is_atomic_a_failed_write_leaves_the_previous_checkpoint(flown, tmp_path, monkeypatch):
    cfg, run = flown
    core = FswCore(cfg.fsw, lambda t, m: None, run_id="r")
    path = tmp_path / "fsw.ckpt"
    ck.write(path, ck.Checkpoint(core, 0))
    before = path.read_bytes()
    for meas in run.measurements[:50]:
        core.ingest(meas)

    def full_disk(fd: int) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "fsync", full_disk)
    with pytest.raises(OSError):
        ck.write(path, ck.Checkpoint(core, 50))
    monkeypatch.undo()
    assert path.read_bytes() == before
    assert ck.read_header(path).measurements_taken == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fsw.ckpt", "fsw.ckpt.tmp"]
    ck.write(path, ck.Checkpoint(core, 50))  # the next one replaces both
    assert ck.read_header(path).measurements_taken == 50
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fsw.ckpt"]


def test_the_checkpoint_excludes_what_belongs_to_the_process(flown):
    cfg, _ = flown
    core = FswCore(cfg.fsw, lambda t, m: None, run_id="r")
    core.extra_counters = lambda: {"refused_topics": 3}
    state = core.__getstate__()
    assert state["_sink"] is None and state["extra_counters"] is None
    assert "_lock" not in core.executive.__getstate__()
    assert core._sink is not None and core.extra_counters is not None  # the live core keeps them


@pytest.mark.parametrize("every_measurements, every_s, steps, expected", [
    (3, 0.0, [(1, 10.0), (2, 20.0), (3, 30.0)], [False, False, True]),
    (0, 25.0, [(1, 10.0), (2, 20.0), (3, 30.0)], [False, False, True]),
    (10, 15.0, [(1, 10.0), (2, 20.0)], [False, True]),
    (0, 0.0, [(100, 1e9)], [False]),
])
def test_schedule_takes_whichever_limit_comes_first(every_measurements, every_s, steps, expected):
    schedule = ck.Schedule(every_measurements, every_s, 0, 5.0)
    assert [schedule.due(n, t) for n, t in steps] == expected


def test_a_bad_checkpoint_cadence_is_a_configuration_error(short_e2e_yaml):
    from fsw.interface.typed import DecodeError
    from fsw.interface.yamlconfig import ConfigError

    text = short_e2e_yaml.replace("fsw:\n", "fsw:\n  checkpoint: {every_measurements: -1}\n", 1)
    with pytest.raises((ConfigError, DecodeError, ValueError)) as info:
        load_text_scenario(text)
    assert "checkpoint.every_measurements" in str(info.value)



def test_navbank_fsw_refuses_an_unusable_checkpoint_in_one_line(tmp_path, short_e2e_yaml):
    import subprocess
    import sys

    (tmp_path / "s.yaml").write_text(short_e2e_yaml)
    (tmp_path / "bad.ckpt").write_bytes(b"garbage\n")
    proc = subprocess.run([sys.executable, "-m", "tools.cli", "fsw", "--scenario", str(tmp_path / "s.yaml"),
                           "--run-id", "r1", "--resume", str(tmp_path / "bad.ckpt"), "--quiet"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines()[-1] == f"navbank fsw: {tmp_path / 'bad.ckpt'}: not a navbank FSW checkpoint"
    assert "Traceback" not in proc.stderr


def test_with_the_run_key_only_a_signed_checkpoint_is_loaded(flown, tmp_path):
    """Unpickling runs code: a checkpoint whose payload was swapped — even with its length and
    SHA-256 fixed up to match — is refused before it is loaded when the run has a key."""
    cfg, run = flown
    key = auth.MessageAuthenticator(b"k" * 32)
    other = auth.MessageAuthenticator(b"o" * 32)
    core = FswCore(cfg.fsw, lambda t, m: None, run_id="r")
    for meas in run.measurements[:50]:
        core.ingest(meas)
    path = tmp_path / "fsw.ckpt"
    ck.write(path, ck.Checkpoint(core, 50, {}, None, ["n1", "n2"]), key.file_tag)
    restored = ck.read(path, cfg.fsw, "r", lambda t, m: None, key.file_tag)
    assert restored.accepted_nonces == ["n1", "n2"] and restored.measurements_taken == 50

    with pytest.raises(ck.CheckpointError, match="not signed with this run's key"):
        ck.read(path, cfg.fsw, "r", lambda t, m: None, other.file_tag)

    # a forger without the key: a different payload with a consistent length and hash
    header, _ = path.read_bytes().split(b"\n", 1)
    forged = pickle.dumps({"core": "x", "measurements_taken": 0, "published": {}, "producer_end": None})
    h = json.loads(header)
    h.update(payload_bytes=len(forged), payload_sha256=hashlib.sha256(forged).hexdigest())
    path.write_bytes(json.dumps(h).encode() + b"\n" + forged)
    with pytest.raises(ck.CheckpointError, match="not signed with this run's key"):
        ck.read(path, cfg.fsw, "r", lambda t, m: None, key.file_tag)

    # an unsigned checkpoint (written without credentials) is not accepted by a keyed FSW
    ck.write(path, ck.Checkpoint(core, 50))
    with pytest.raises(ck.CheckpointError, match="not signed"):
        ck.read(path, cfg.fsw, "r", lambda t, m: None, key.file_tag)


def test_served_nonces_survive_a_restart():
    guard = auth.NonceGuard(capacity=4)
    for n in ("a", "b", "c"):
        assert guard.first_use(n)
    again = auth.NonceGuard(capacity=4)
    again.restore(guard.snapshot())
    assert [again.first_use(n) for n in ("a", "b", "c", "d")] == [False, False, False, True]


def test_the_telemetry_not_yet_published_travels_with_the_checkpoint(flown, tmp_path):
    """The FSW process checkpoints what its outbox holds instead of publishing it first (a burst
    put just before the checkpoint could die unsent with the process): the restored list is the
    held messages, in order, byte for byte."""
    from fsw.transport import Outbox

    cfg, run = flown
    published: list = []
    box = Outbox(lambda t, m: published.append((t, m)), limit=100_000)
    core = FswCore(cfg.fsw, box.put, run_id="r")
    core.start()
    for meas in run.measurements[:300]:
        core.ingest(meas)
    held = box.held()
    assert len(held) > 100 and published == []
    ck.write(tmp_path / "c", ck.Checkpoint(core, core.taken, {"fsw/status": 1}, None, [], held))
    restored = ck.read(tmp_path / "c", cfg.fsw, "r", lambda t, m: None)
    assert _encoded(restored.unpublished) == _encoded(held) and restored.published == {"fsw/status": 1}


def test_the_config_digest_is_the_configurations_canonical_json_whichever_was_asked_last(flown):
    cfg, _ = flown
    other = dataclasses.replace(cfg.fsw, checkpoint=dataclasses.replace(
        cfg.fsw.checkpoint, every_measurements=cfg.fsw.checkpoint.every_measurements + 1))
    from fsw.interface import typed

    def independent(c) -> str:
        return hashlib.sha256(json.dumps(typed.encode(c), sort_keys=True, separators=(",", ":")).encode()).hexdigest()

    for c in (cfg.fsw, cfg.fsw, other, cfg.fsw, other, other):
        assert ck.config_digest(c) == independent(c)
    assert ck.config_digest(cfg.fsw) != ck.config_digest(other)
