"""Output paths are proven writable before anything starts — a directory that cannot be created
or written is one line naming the option, the path and the errno, exit code 2 — and a disk that
fills up during a run is named with its file and errno, never "(no output)" or a traceback."""

from __future__ import annotations

import errno
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tools.launcher import last_words

ROOT = Path(__file__).resolve().parents[1]

SHORT = """\
name: short
sim:
  trajectory: {span_days: 2.0}
fsw:
  budget: {mode: work-units}
  gating:
    - {network: chi2, batch_size: 200}
"""


def _navbank(*argv: str, cwd: Path, timeout: float = 120) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "tools.cli", *argv], capture_output=True, text=True, timeout=timeout,
                          cwd=cwd, env=env)


def _one_line(proc: subprocess.CompletedProcess) -> str:
    lines = proc.stderr.strip().splitlines()
    assert "Traceback" not in proc.stderr, proc.stderr
    assert len(lines) == 1, proc.stderr
    return lines[0]


@pytest.fixture
def tmpfs(tmp_path):
    """``tmpfs(size, readonly=False)``: a fresh tmpfs mounted under tmp_path (unmounted after)."""
    mounted: list[Path] = []

    def mount(size: str = "64k", readonly: bool = False) -> Path:
        d = tmp_path / f"mnt{len(mounted)}"
        d.mkdir()
        opts = f"size={size}" + (",ro" if readonly else "")
        proc = subprocess.run(["mount", "-t", "tmpfs", "-o", opts, "tmpfs", str(d)], capture_output=True, text=True)
        if proc.returncode != 0:
            pytest.skip(f"cannot mount a tmpfs here (needs root with CAP_SYS_ADMIN): {proc.stderr.strip()}")
        mounted.append(d)
        return d

    yield mount
    for d in mounted:
        subprocess.run(["umount", "-l", str(d)], capture_output=True)


@pytest.fixture
def work(tmp_path) -> Path:
    """A working directory with the short scenario, an empty .mcap and a regular file to path through."""
    (tmp_path / "short.yaml").write_text(SHORT)
    (tmp_path / "empty.mcap").write_bytes(b"")
    (tmp_path / "afile").write_text("a regular file, not a directory\n")
    return tmp_path


# command (as `navbank ...` signs its errors), arguments before the output, the output option
CASES = [
    ("run", ["run", "--scenario", "short.yaml", "--quiet"], "--out", "afile/out"),
    ("sim", ["sim", "--scenario", "short.yaml"], "--out", "afile/s.jsonl"),
    ("ground log", ["ground", "log", "--run-id", "r1"], "--out", "afile/r.mcap"),
    ("campaign", ["campaign", "optical-bias"], "--out", "afile/c"),
    ("report", ["report", "empty.mcap"], "--out", "afile/rep"),
    ("validation-report", ["validation-report", "--campaigns", "."], "--out", "afile/docs"),
    ("replay", ["replay", "empty.mcap", "--rerun"], "--json", "afile/diff.json"),
    ("calibrate", ["calibrate", "--scenario", "short.yaml", "--seeds", "1"], "--out-dir", "afile/cal"),
    ("consistency", ["consistency", "--scenario", "short.yaml", "--seeds", "1"], "--out", "afile/c.json"),
    ("false-alarms", ["false-alarms", "--scenario", "short.yaml", "--seeds", "1"], "--out", "afile/f.json"),
]


@pytest.mark.parametrize("name,argv,option,path", CASES, ids=[c[0] for c in CASES])
def test_output_through_a_regular_file_is_one_line_exit_2(work, name, argv, option, path):
    before = sorted(p.name for p in work.iterdir())
    t0 = time.monotonic()
    proc = _navbank(*argv, option, path, cwd=work)
    assert proc.returncode == 2, proc.stderr
    assert _one_line(proc) == f"navbank {name}: {option} {path}: cannot write: [Errno {errno.ENOTDIR}] Not a directory"
    assert sorted(p.name for p in work.iterdir()) == before  # nothing was started, nothing written
    print(f"\n{name}: refused in {time.monotonic() - t0:.2f} s")


def test_output_is_a_directory(work):
    (work / "adir").mkdir()
    proc = _navbank("sim", "--scenario", "short.yaml", "--out", "adir", cwd=work)
    assert proc.returncode == 2
    # the suffix check comes first; a directory named like a file is refused by the write check
    (work / "d.jsonl").mkdir()
    proc = _navbank("sim", "--scenario", "short.yaml", "--out", "d.jsonl", cwd=work)
    assert proc.returncode == 2
    assert _one_line(proc) == f"navbank sim: --out d.jsonl: cannot write: [Errno {errno.EISDIR}] Is a directory"


def test_unwritable_proc_path(work):
    proc = _navbank("run", "--scenario", "short.yaml", "--out", "/proc/navbank-out", "--quiet", cwd=work)
    assert proc.returncode == 2
    assert _one_line(proc).startswith("navbank run: --out /proc/navbank-out: cannot write: [Errno ")


def test_read_only_file_system(work, tmpfs):
    ro = tmpfs(readonly=True)
    out = ro / "x"
    for argv, option in ((["run", "--scenario", "short.yaml", "--quiet"], "--out"),
                         (["ground", "log", "--run-id", "r1"], "--out")):
        target = out if argv[0] == "run" else ro / "r.mcap"
        proc = _navbank(*argv, option, str(target), cwd=work)
        assert proc.returncode == 2
        assert _one_line(proc) == (f"navbank {'run' if argv[0] == 'run' else 'ground log'}: {option} {target}: "
                                   f"cannot write: [Errno {errno.EROFS}] Read-only file system")


def test_full_disk_before_starting(work, tmpfs):
    full = tmpfs("64k")
    with open(full / "filler", "wb", buffering=0) as f:  # fill it to the last block
        with pytest.raises(OSError) as exc:
            while True:
                f.write(b"\0" * 4096)
        assert exc.value.errno == errno.ENOSPC
    proc = _navbank("run", "--scenario", "short.yaml", "--out", str(full / "r"), "--quiet", cwd=work)
    assert proc.returncode == 2
    assert _one_line(proc) == f"navbank run: --out {full / 'r'}: cannot write: [Errno {errno.ENOSPC}] No space left on device"


def test_disk_full_during_a_run_names_the_file_and_errno(work, tmpfs):
    """64 kB take the configuration and the first chunks of run.mcap, then the logger's writes
    fail: the launcher reports the logger's own error line, not '(no output)'."""
    full = tmpfs("64k")
    t0 = time.monotonic()
    proc = _navbank("run", "--scenario", "short.yaml", "--out", str(full / "r"), "--quiet", cwd=work, timeout=300)
    print(f"\ndisk full during the run: exit {proc.returncode} after {time.monotonic() - t0:.1f} s")
    assert proc.returncode == 1
    err = proc.stderr.strip().splitlines()
    assert "Traceback" not in proc.stderr
    assert err[0].startswith("navbank run ")  # the start line
    assert len(err) == 2, proc.stderr
    mcap = full / "r" / "run.mcap"
    assert err[1].startswith(f"navbank run: the ground process exited with code 1 (navbank ground log: {mcap}: "
                             f"cannot write: [Errno {errno.ENOSPC}] No space left on device)"), err[1]
    assert "no output" not in err[1]


def test_disk_full_while_the_simulator_writes(work, tmpfs):
    full = tmpfs("64k")
    path = full / "s.jsonl"
    proc = _navbank("sim", "--scenario", "short.yaml", "--out", str(path), cwd=work)
    assert proc.returncode == 1
    lines = proc.stderr.strip().splitlines()
    assert "Traceback" not in proc.stderr
    assert lines[-1] == f"navbank sim: {path}: cannot write: [Errno {errno.ENOSPC}] No space left on device"


def test_last_words_prefer_the_error_line():
    zenoh_close = "2026-01-01T00:00:00Z WARN zenoh::net::runtime: closing session"
    assert last_words(["sim: 10 measurements", "navbank ground log: x.mcap: cannot write: [Errno 28] No space left on device",
                       zenoh_close]) == "navbank ground log: x.mcap: cannot write: [Errno 28] No space left on device"
    assert last_words(["navbank ground log: 5 messages -> x.mcap", "Traceback (most recent call last):",
                       '  File "x.py", line 1, in <module>', "    f()", "OSError: [Errno 5] Input/output error"]) \
        == "OSError: [Errno 5] Input/output error"
    assert last_words(["something", ""]) == "something"
    assert last_words([]) == "no output"


def test_disk_full_during_a_campaign_names_the_file_and_errno(work, tmpfs):
    """8 kB take the campaign's own files but not its first result row (or weights)."""
    (work / "c.yaml").write_text("name: full\nseeds: {count: 1, base: 1}\nmatrix:\n"
                                 "  - scenarios: [short.yaml]\n    faults: [none]\n")
    full = tmpfs("8k")
    out = full / "o"
    proc = _navbank("campaign", "c.yaml", "--workers", "1", "--out", str(out), "--quiet", cwd=work, timeout=300)
    assert proc.returncode == 1, proc.stderr
    assert "Traceback" not in proc.stderr
    last = proc.stderr.strip().splitlines()[-1]
    assert last.startswith(f"navbank campaign: {out}/"), last
    assert last.endswith(f"[Errno {errno.ENOSPC}] No space left on device"), last
