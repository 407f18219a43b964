"""``navbank bench --against REV``: a past revision's FSW core against the working tree's."""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys

import pytest

from tools.bench import run_against
from fsw.kernels.cache import source_stamp
from tools.bench.against import REPO, AgainstError, compare, revision_tree, seed_kernel_cache


def _git(*args: str) -> str:
    return subprocess.run(["git", *args], cwd=REPO, capture_output=True, text=True, check=True).stdout.strip()


def _has_git_history() -> bool:
    try:
        _git("rev-parse", "--verify", "HEAD^{commit}")
    except (OSError, subprocess.CalledProcessError):
        return False
    return True


needs_git = pytest.mark.skipif(not _has_git_history(), reason="not a git checkout")


@pytest.fixture(scope="module")
def shared_cache(tmp_path_factory):
    """One cache for the slow tests: HEAD's fsw is taken out and its kernels compiled (or copied) once."""
    return tmp_path_factory.mktemp("against-cache")


@needs_git
def test_a_revision_s_fsw_package_is_taken_out_of_git_once(tmp_path, monkeypatch):
    monkeypatch.setenv("NAVBANK_CACHE_DIR", str(tmp_path))
    commit, tree = revision_tree("HEAD")
    assert commit == _git("rev-parse", "HEAD") and tree == tmp_path / "against" / commit
    # the FSW alone: it imports nothing of sim, ground or tools
    assert sorted(p.name for p in tree.iterdir()) == ["fsw"]
    assert (tree / "fsw" / "core" / "fswcore.py").read_bytes() == _git_show(commit, "fsw/core/fswcore.py")
    marker = tree / "fsw" / "marker"
    marker.write_text("kept")
    assert revision_tree(commit[:10]) == (commit, tree) and marker.read_text() == "kept"  # not extracted again


def _git_show(commit: str, path: str) -> bytes:
    return subprocess.run(["git", "show", f"{commit}:{path}"], cwd=REPO, capture_output=True, check=True).stdout


@needs_git
def test_an_unknown_revision_is_one_clear_error(tmp_path, monkeypatch):
    monkeypatch.setenv("NAVBANK_CACHE_DIR", str(tmp_path))
    with pytest.raises(AgainstError, match="no-such-revision"):
        revision_tree("no-such-revision")
    done = subprocess.run([sys.executable, "-m", "tools.cli", "bench", "--against", "no-such-revision"], cwd=REPO,
                          capture_output=True, text=True, env={**os.environ, "NAVBANK_CACHE_DIR": str(tmp_path)})
    assert done.returncode == 2 and done.stderr.count("\n") == 1 and "no-such-revision" in done.stderr


@needs_git
@pytest.mark.slow
def test_the_same_code_flown_in_lock_step_gives_the_same_outputs_and_about_the_same_cpu(shared_cache, monkeypatch):
    # HEAD's fsw, taken out of git, against the working tree's: the same code wherever the
    # working tree's fsw is unchanged (as in CI's clean clone), so the same outputs
    monkeypatch.setenv("NAVBANK_CACHE_DIR", str(shared_cache))
    dirty = _git("status", "--porcelain", "--", "fsw")
    progress = io.StringIO()
    row = compare("HEAD", span_days=0.5, repeats=2, chunk=40, progress=progress)
    assert row["name"] == f"fsw-core-vs-{_git('rev-parse', 'HEAD')[:12]}"
    assert row["measurements"] > 100 and row["repeats"] == 2 and len(row["per_repeat_ratios"]) == 2
    assert row["ours"] > 0 and row["reference"] > 0
    assert row["ratio"] == pytest.approx(row["reference"] / row["ours"])
    assert row["ours"] == pytest.approx(sum(row["ours_us"]) / 2, abs=0.01)
    assert progress.getvalue().count("repeat") == 2
    if not dirty:
        assert row["outputs_identical"] is True
        # the same code: within the scatter of two cores timed in lock step on one processor
        assert 0.7 < row["ratio"] < 1.4
    # the kernels were the working tree's compiled ones wherever their sources are the same
    _, tree = revision_tree("HEAD")
    same_kernels = source_stamp(REPO / "fsw" / "kernels") == source_stamp(tree / "fsw" / "kernels")
    assert (row["kernels_copied"] > 0) is same_kernels


@needs_git
@pytest.mark.slow
def test_the_command_prints_the_comparison_and_the_steadiness_rows(shared_cache, monkeypatch):
    monkeypatch.setenv("NAVBANK_CACHE_DIR", str(shared_cache))
    monkeypatch.setattr("tools.bench.QUICK_SPAN_DAYS", 0.25)
    buf = io.StringIO()
    rows = run_against("HEAD", json=True, quick=True, out=buf)
    lines = [json.loads(line) for line in buf.getvalue().splitlines()]
    assert [r["name"] for r in lines] == [rows[0]["name"], "machine-steadiness"]
    assert lines[0]["name"].startswith("fsw-core-vs-") and "outputs_identical" in lines[0]
    assert list(lines[1]["probe_ms"]) == ["against", "end"]


def _tree_with_the_working_kernels(root):
    kernels = root / "fsw" / "kernels"
    kernels.mkdir(parents=True)
    for source in (REPO / "fsw" / "kernels").glob("*.py"):
        (kernels / source.name).write_bytes(source.read_bytes())
    return kernels


def test_compiled_kernels_are_copied_only_into_a_revision_with_the_same_kernel_sources_and_none_of_its_own(tmp_path):
    compiled = tmp_path / "compiled"
    compiled.mkdir()
    for name in ("leg.fly_leg-10.py311.nbi", "leg.fly_leg-10.py311.1.nbc", "leg.cpython-311.pyc"):
        (compiled / name).write_bytes(name.encode())
    same = _tree_with_the_working_kernels(tmp_path / "same")
    assert seed_kernel_cache(str(compiled), same.parents[1]) == 2
    cached = same / "__pycache__"
    # numba's files, as they were, and nothing else (the bytecode is Python's, of other sources)
    assert sorted(p.name for p in cached.iterdir()) == ["leg.fly_leg-10.py311.1.nbc", "leg.fly_leg-10.py311.nbi"]
    assert (cached / "leg.fly_leg-10.py311.nbi").read_bytes() == b"leg.fly_leg-10.py311.nbi"
    # the revision's own compiled kernels are never overwritten
    (cached / "leg.fly_leg-10.py311.nbi").write_bytes(b"its own")
    assert seed_kernel_cache(str(compiled), same.parents[1]) == 0
    assert (cached / "leg.fly_leg-10.py311.nbi").read_bytes() == b"its own"
    # a revision whose kernels differ by one byte compiles its own
    other = _tree_with_the_working_kernels(tmp_path / "other")
    with open(other / "joseph_update.py", "ab") as f:
        f.write(b"\n")
    assert seed_kernel_cache(str(compiled), other.parents[1]) == 0 and not (other / "__pycache__").exists()
    # nothing to copy from
    fresh = _tree_with_the_working_kernels(tmp_path / "fresh")
    assert seed_kernel_cache(None, fresh.parents[1]) == 0
    assert seed_kernel_cache(str(tmp_path / "missing"), fresh.parents[1]) == 0


def test_the_first_difference_of_two_outputs_is_named_by_message_and_topic(tmp_path):
    from tools.bench.against import first_difference

    a, b, c = tmp_path / "a", tmp_path / "b", tmp_path / "c"
    a.write_bytes(b"fsw/estimate/radio\0{\"x\":1}\nfsw/weights/chi2\0{\"w\":[0.5,0.5]}\n")
    b.write_bytes(b"fsw/estimate/radio\0{\"x\":1}\nfsw/weights/chi2\0{\"w\":[0.4,0.6]}\n")
    c.write_bytes(b"fsw/estimate/radio\0{\"x\":1}\n")
    assert first_difference([("ours repeat 1", str(a)), ("ours repeat 2", str(a))]) is None
    said = first_difference([("ours repeat 1", str(a)), ("reference repeat 1", str(b))])
    assert said is not None and "reference repeat 1 parts from ours repeat 1 at message 2 (fsw/weights/chi2)" in said
    assert "[0.5,0.5]" in said and "[0.4,0.6]" in said
    assert first_difference([("ours repeat 1", str(a)), ("reference repeat 1", str(c))]) == (
        "reference repeat 1 emitted 1 messages, ours repeat 1 2")
