"""``navbank report``: input detection, output paths, exit codes (no matplotlib: exit 2 with a hint)."""

from __future__ import annotations

import argparse
import os
import sys

import pytest

from fsw.interface import messages as m, topics
from ground.mcap_io import McapRecorder
from tools.commands import report as cmd

T0 = 600_000_000.0
S = m.Stamp(sec=1_700_000_000, nsec=0)


def _run(argv: list[str]) -> int:
    p = argparse.ArgumentParser()
    cmd.add_arguments(p)
    return cmd.run(p.parse_args(argv))


def _write_mcap(path, n_weights: int = 400) -> None:
    with McapRecorder(path, chunk_size=2048) as rec:
        rec.write_message(topics.SIM_STATUS, m.RunStatus(t_s=T0, timestamp=S, run_id="cli", source="sim", state="start"), 1)
        for k in range(n_weights):
            w = 0.3 + 0.3 * k / n_weights
            rec.write_message(f"{topics.FSW_WEIGHTS}/chi2", m.FilterWeights(
                t_s=T0 + 600.0 * k, timestamp=S, network="chi2", batch=k, filters=("radio", "optical"),
                weights=(w, 1.0 - w)), 2 + k)


def test_loose_mcap_file_reports_beside_it(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    mcap = tmp_path / "flight.mcap"
    _write_mcap(mcap)
    assert _run([str(mcap)]) == 0
    out = capsys.readouterr().out.split()
    assert out == [str(tmp_path / "flight-report" / "weights_chi2.png"), str(tmp_path / "flight-report" / "report.md")]
    assert all(os.path.getsize(p) > 0 for p in out)


def test_cut_short_mcap_still_reports(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    mcap = tmp_path / "run.mcap"
    _write_mcap(mcap)
    data = mcap.read_bytes()
    cut = tmp_path / "cut" / "run.mcap"
    cut.parent.mkdir()
    cut.write_bytes(data[: len(data) * 2 // 3])  # no footer, last chunk torn
    assert _run([str(cut.parent), "--out", str(tmp_path / "out")]) == 0
    assert (tmp_path / "out" / "weights_chi2.png").is_file()
    md = (tmp_path / "out" / "report.md").read_text()
    assert "Numbers from the recorded messages" in md


def test_bad_inputs_exit_2(tmp_path, capsys):
    assert _run([str(tmp_path / "missing")]) == 2
    assert _run([str(tmp_path)]) == 2  # an empty directory is neither a run nor a campaign
    (tmp_path / "notes.txt").write_text("x")
    assert _run([str(tmp_path / "notes.txt")]) == 2
    err = capsys.readouterr().err
    assert err.count("navbank report:") == 3 and "Traceback" not in err


def test_without_matplotlib_exit_2_with_install_hint(tmp_path, capsys, monkeypatch):
    mcap = tmp_path / "run.mcap"
    _write_mcap(mcap, n_weights=3)
    for name in ("matplotlib", "matplotlib.figure", "matplotlib.backends.backend_agg"):
        monkeypatch.setitem(sys.modules, name, None)  # import now raises ImportError
    assert _run([str(tmp_path)]) == 2
    assert "pip install 'navbank[plots]'" in capsys.readouterr().err
    assert not (tmp_path / "report").exists()
