"""A configuration file cannot cost more than the YAML loader's limits: file size, nesting depth,
alias uses and nodes with aliases expanded. A file that breaches one is a one-line error with
exit code 2, found in a fraction of a second with bounded memory — also for the entry points
that read YAML other than `navbank validate`: replay's --config and --set, a run's attached
configuration, campaign files and detector calibrations."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from fsw.interface import yamlconfig
from fsw.interface.yamlconfig import MAX_ALIASES, MAX_BYTES, MAX_DEPTH, MAX_NODES, ConfigError, parse_yaml, read_config_text

ROOT = Path(__file__).resolve().parents[1]

# 342 bytes that expand to 9**9 (387 million) strings
BILLION_LAUGHS = """\
a: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]
b: &b [*a,*a,*a,*a,*a,*a,*a,*a,*a]
c: &c [*b,*b,*b,*b,*b,*b,*b,*b,*b]
d: &d [*c,*c,*c,*c,*c,*c,*c,*c,*c]
e: &e [*d,*d,*d,*d,*d,*d,*d,*d,*d]
f: &f [*e,*e,*e,*e,*e,*e,*e,*e,*e]
g: &g [*f,*f,*f,*f,*f,*f,*f,*f,*f]
h: &h [*g,*g,*g,*g,*g,*g,*g,*g,*g]
i: &i [*h,*h,*h,*h,*h,*h,*h,*h,*h]
"""
DEEP = "[" * 100_000 + "]" * 100_000 + "\n"


def _validate(path: Path) -> tuple[int, str, float, int]:
    """`navbank validate PATH` as a real process: exit code, stderr, wall time, peak RSS in KiB."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    err = path.with_suffix(".stderr")
    t0 = time.perf_counter()
    with open(err, "w") as ferr:
        proc = subprocess.Popen([sys.executable, "-m", "tools.cli", "validate", str(path)], stdout=subprocess.DEVNULL,
                                stderr=ferr, cwd=ROOT, env=env)
        # wait4 gives this child's own resource usage (its peak resident memory)
        _, status, usage = os.wait4(proc.pid, 0)
        proc.returncode = os.waitstatus_to_exitcode(status)
    return proc.returncode, err.read_text(), time.perf_counter() - t0, usage.ru_maxrss


@pytest.fixture(scope="module")
def baseline(tmp_path_factory) -> tuple[float, int]:
    """Wall time and peak memory of validating a small good file (interpreter start and imports)."""
    path = tmp_path_factory.mktemp("base") / "good.yaml"
    path.write_text((ROOT / "tools/scenarios/insight-approach.yaml").read_text())
    code, err, wall, rss = _validate(path)
    assert code == 0, err
    return wall, rss


@pytest.mark.parametrize("name,text,words", [
    ("billion-laughs", BILLION_LAUGHS, f"at most {MAX_NODES} nodes with aliases expanded"),
    ("deep", DEEP, f"nesting at most {MAX_DEPTH} deep"),
])
def test_bomb_is_one_line_exit_2_fast_and_small(tmp_path, baseline, name, text, words):
    path = tmp_path / f"{name}.yaml"
    path.write_text(text)
    code, err, wall, rss = _validate(path)
    base_wall, base_rss = baseline
    print(f"\n{name} ({path.stat().st_size} bytes): exit {code} in {wall:.2f} s (good file {base_wall:.2f} s), "
          f"peak {rss / 1024:.0f} MiB (good file {base_rss / 1024:.0f} MiB): {err.strip()[:120]}")
    assert code == 2
    assert len(err.strip().splitlines()) == 1, err
    assert "Traceback" not in err
    assert err.startswith(f"{path}:1: " if name == "deep" else f"{path}:") and words in err, err
    # what the file costs on top of starting the interpreter: well under a second, a few MiB
    assert wall - base_wall < 1.0
    assert rss - base_rss < 50 * 1024


@pytest.mark.parametrize("name,text,words", [
    ("billion-laughs", BILLION_LAUGHS, "nodes with aliases expanded"),
    ("deep", DEEP, "nesting at most"),
    ("recursive alias", "a: &a [1, *a]\n", "a recursive alias *a"),
    ("deep through aliases", "".join(f"l{i}: &l{i} [" + (f"*l{i - 1}" if i else "0") + "]\n" for i in range(MAX_DEPTH + 1)),
     f"nesting at most {MAX_DEPTH} deep with aliases expanded"),
    ("many aliases", "a: &a 1\nb: [" + ", ".join(["*a"] * (MAX_ALIASES + 1)) + "]\n", f"at most {MAX_ALIASES} aliases"),
    ("long flat list", "a: [" + ", ".join(["0"] * MAX_NODES) + "]\n", "nodes with aliases expanded"),
])
def test_parse_refuses_in_well_under_a_second(name, text, words):
    t0 = time.perf_counter()
    with pytest.raises(ConfigError) as err:
        parse_yaml(text, "f.yaml")
    elapsed = time.perf_counter() - t0
    print(f"\n{name}: refused in {elapsed * 1e3:.1f} ms: {str(err.value)[:120]}")
    assert words in str(err.value)
    assert "\n" not in str(err.value)
    # the flat list is composed up to the limit (PyYAML's pure-Python composer: ~1 s per 50 000 nodes)
    assert elapsed < (10.0 if name == "long flat list" else 1.0)


def test_limits_leave_the_built_in_files_alone():
    """Anchors and aliases stay usable: the Pathfinder scenario shares blocks between filters."""
    for path in sorted((ROOT / "tools").rglob("*.yaml")):
        parse_yaml(path.read_text(), str(path))
    data, _ = parse_yaml("a: &a {x: 1}\nb: *a\nc: [*a, *a]\n")
    assert data == {"a": {"x": 1}, "b": {"x": 1}, "c": [{"x": 1}, {"x": 1}]}


def test_nesting_up_to_the_limit_is_accepted():
    data, _ = parse_yaml("[" * MAX_DEPTH + "]" * MAX_DEPTH)
    for _ in range(MAX_DEPTH - 1):
        data = data[0]
    assert data == []
    with pytest.raises(ConfigError, match="nesting"):
        parse_yaml("[" * (MAX_DEPTH + 1) + "]" * (MAX_DEPTH + 1))


def test_file_size_checked_before_reading(tmp_path, monkeypatch):
    big = tmp_path / "big.yaml"
    with open(big, "wb") as f:
        f.truncate(MAX_BYTES + 1)  # sparse: costs no disk
    with pytest.raises(ConfigError) as err:
        read_config_text(big)
    assert str(err.value) == f"{big}: <top level>: expected a file of at most {MAX_BYTES} bytes (4 MiB), got {MAX_BYTES + 1} bytes"
    # a stream whose size is not known in advance is read to one byte past the limit only
    fifo_like = tmp_path / "fifo.yaml"
    fifo_like.write_bytes(b"#" * (MAX_BYTES + 10))
    monkeypatch.setattr(yamlconfig.stat, "S_ISREG", lambda mode: False)
    with pytest.raises(ConfigError, match="got more"):
        read_config_text(fifo_like)


def test_text_size_checked_before_parsing():
    with pytest.raises(ConfigError, match=f"at most {MAX_BYTES} bytes"):
        parse_yaml("#" * (MAX_BYTES + 1), "attached")


def test_replay_config_and_set_go_through_the_limits(tmp_path):
    from ground.replay.fsw_config import load_fsw_config, parse_override

    recorded = "fsw:\n  gating:\n    - {network: chi2}\n"
    bomb = tmp_path / "bomb.yaml"
    bomb.write_text(BILLION_LAUGHS)
    with pytest.raises(ConfigError, match="nodes with aliases expanded"):
        load_fsw_config(recorded, "run.mcap:config.yaml", replacement=bomb)
    with pytest.raises(ConfigError, match="nodes with aliases expanded"):  # the attached config itself
        load_fsw_config(BILLION_LAUGHS, "run.mcap:config.yaml")
    with pytest.raises(ValueError, match="nesting at most"):
        parse_override("fsw.x=" + "[" * 1000 + "]" * 1000)
    assert parse_override("fsw.gating[0].sigma_w=0.1") == (["gating", 0, "sigma_w"], 0.1)


def test_report_reads_a_hostile_attached_config_as_no_config():
    from ground.report.run_data import hierarchy_groups_from_config

    t0 = time.perf_counter()
    assert hierarchy_groups_from_config(BILLION_LAUGHS) == {}
    assert hierarchy_groups_from_config(DEEP) == {}
    assert time.perf_counter() - t0 < 1.0


def test_campaign_and_detector_files_go_through_the_limits(tmp_path):
    from tools.campaign.spec import load_campaign
    from tools.scenario import load_scenario

    bomb = tmp_path / "bomb.yaml"
    bomb.write_text(BILLION_LAUGHS)
    with pytest.raises(ConfigError, match="nodes with aliases expanded"):
        load_campaign(str(bomb))
    with pytest.raises(ConfigError, match="nodes with aliases expanded"):
        load_scenario(str(bomb))
    from fsw.fdir.config import DetectorConfig
    from fsw.interface.yamlconfig import load_file

    with pytest.raises(ConfigError, match="nodes with aliases expanded"):
        load_file(DetectorConfig, bomb)


def test_hostile_config_attached_to_an_mcap(tmp_path):
    """A recorded run's attached configuration is read within the limits: `navbank replay
    --rerun` refuses it in one line with exit 2; `navbank report` reports without it."""
    from ground.mcap_io.recorder import McapRecorder

    mcap = tmp_path / "hostile.mcap"
    with McapRecorder(mcap) as rec:
        rec.add_attachment("config.yaml", BILLION_LAUGHS.encode(), "application/yaml")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "tools.cli", "replay", str(mcap), "--rerun"], capture_output=True,
                          text=True, timeout=120, cwd=tmp_path, env=env)
    print(f"\nreplay --rerun of a hostile attachment: exit {proc.returncode} in {time.perf_counter() - t0:.2f} s")
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [proc.stderr.strip()]
    assert proc.stderr.startswith(f"{mcap}:config.yaml:") and "nodes with aliases expanded" in proc.stderr
    pytest.importorskip("matplotlib")
    proc = subprocess.run([sys.executable, "-m", "tools.cli", "report", str(mcap), "--out", str(tmp_path / "rep")],
                          capture_output=True, text=True, timeout=120, cwd=tmp_path, env=env)
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr
