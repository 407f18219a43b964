"""``navbank bench`` output: one JSON object per line with the fields the CLI documents."""

from __future__ import annotations

import io
import json
import sys

import pytest

from tools.bench import run_benchmarks


def test_quick_benchmarks_print_json_lines():
    buf = io.StringIO()
    results = run_benchmarks(json=True, quick=True, out=buf)
    lines = [json.loads(line) for line in buf.getvalue().splitlines()]
    assert [r["name"] for r in lines] == ["linear-bank", "ekf-bank-3", "ekf-bank-6", "icd-decode"]
    for r in lines:
        assert {"name", "ours", "reference", "unit", "ratio"} <= set(r)
        assert r["ours"] > 0 and r["reference"] > 0
        assert r["ratio"] == pytest.approx(r["reference"] / r["ours"])
    assert lines == json.loads(json.dumps(results))
    assert lines[0]["filters"] == 6 and lines[0]["states"] == 15 and lines[0]["measurement_dim"] == 2
    # stacking the filters must beat running them one by one by a wide margin
    assert lines[0]["ratio"] > 2.0
    # strict decoding is compiled: within a few times json.loads, which checks nothing (the reference
    # decoder alone was ~12x slower than json.loads)
    assert lines[3]["messages"] > 0 and lines[3]["messages_per_s"] > 100_000 / 4 and lines[3]["ratio"] > 0.25


def test_text_output_has_one_line_per_benchmark():
    buf = io.StringIO()
    run_benchmarks(json=False, quick=True, out=buf)
    text = buf.getvalue().splitlines()
    assert len(text) == 4 and text[0].startswith("linear-bank") and "ratio" in text[0]


def test_without_filterpy_the_linear_entry_is_skipped_with_one_line(monkeypatch, capsys):
    # an entry of None in sys.modules makes `import filterpy...` raise ImportError, as when it
    # is not installed
    monkeypatch.setitem(sys.modules, "filterpy", None)
    monkeypatch.setitem(sys.modules, "filterpy.kalman", None)
    buf = io.StringIO()
    results = run_benchmarks(json=True, quick=True, out=buf)
    assert [r["name"] for r in results] == ["ekf-bank-3", "ekf-bank-6", "icd-decode"]
    assert [json.loads(line)["name"] for line in buf.getvalue().splitlines()] == ["ekf-bank-3", "ekf-bank-6", "icd-decode"]
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "skipped" in err[0] and "FilterPy" in err[0]
