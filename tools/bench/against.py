"""``navbank bench --against REV``: the working tree's FSW core against a past revision's, timed
in lock step, and whether their outputs are the same.

A change of a few per cent in the core's CPU per measurement cannot be told from two runs of
``navbank bench`` on a shared machine, whose speed may drift by tens of per cent from one minute
to the next (see :mod:`.steadiness`). So both cores fly the same stream at once: two worker
processes (:mod:`.against_worker`), one importing the working tree's ``fsw`` and one the
revision's, pinned to the same processor, take the measurements in alternating chunks (a chunk
on one side, then the same chunk on the other, the order swapped each chunk), and each side's
CPU is the sum of its chunks' thread CPU. A drift of the machine then falls on both sides alike.
Each side also hashes what its core emitted (every message but budget reports and statuses,
which hold CPU figures): equal digests say the change did not alter the outputs, and where they
differ the row says at which message the first difference is. The cores fly in budget mode
``work-units``, whose outputs do not depend on the host's speed (in mode ``cpu`` a frame defers a
stage the machine was too slow for, and what comes out then depends on when); the CPU meter
and the start-up warm-up, which only mode ``cpu`` runs, are outside the comparison.

The revision's ``fsw`` package alone is taken out of git (``git archive``): the FSW imports
nothing of ``sim``, ``ground`` or ``tools``. It is kept under the cache directory by commit, with
its compiled kernels beside it (in its own ``fsw/kernels/__pycache__``). Where the revision's
kernel sources are the working tree's to the byte (most changes leave them alone), those are
the working tree's compiled kernels, copied (:func:`seed_kernel_cache`): numba stamps each
kernel's cache with a digest of every kernel source (:mod:`fsw.kernels.cache`), not with paths or
times, so it loads them as its own. Otherwise the revision's kernels are compiled, once per
revision (a minute or two more the first time).

The row ``fsw-core-vs-<rev>``: ours the working tree's CPU µs per measurement, the reference the
revision's (each the mean over the repeats, which were flown side by side), ratio reference /
ours (> 1: the working tree is faster); its details list each repeat's ratio and whether the
outputs were identical. What to read a ratio against is the ratio of a tree against itself: with
``--against HEAD`` and nothing changed, four comparisons of the 45-day run gave repeat ratios
between 0.964 and 1.034 and means of five between 0.993 and 1.012, on a machine where each
side's own figure moved between 207 and 253 µs from one comparison to the next. Hence the goal
≥ 0.98: not slower than the revision beyond that scatter; a change worth less than about 2 % is
not resolved.
"""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import IO, Any

from tools.bench.rows import Goal, make_row

#: not slower than the revision beyond the method's own scatter (module docstring)
NOT_SLOWER = Goal("cost", ">=", 0.98)
#: measurements flown, untimed, by each side before the timed repeats
WARM_UP_MEASUREMENTS = 300
REPO = Path(__file__).resolve().parents[2]
WORKER = Path(__file__).resolve().parent / "against_worker.py"


class AgainstError(RuntimeError):
    """The revision cannot be compared (unknown to git, no git, a worker that failed)."""


def _git(*args: str) -> str:
    try:
        done = subprocess.run(["git", *args], cwd=REPO, capture_output=True, text=True, check=False)
    except OSError as exc:
        raise AgainstError(f"git is needed to compare against a revision: {exc}") from None
    if done.returncode != 0:
        raise AgainstError(f"git {' '.join(args)}: {done.stderr.strip() or 'failed'}")
    return done.stdout.strip()


def cache_root() -> Path:
    """Where extracted revisions are kept: ``against`` in navbank's cache directory."""
    from sim.trajectories.design_cache import cache_root as navbank_cache

    root = navbank_cache()
    if root is None:
        raise AgainstError("no cache directory to keep the revision in: set NAVBANK_CACHE_DIR")
    return root / "against"


def revision_tree(rev: str) -> tuple[str, Path]:
    """(full commit id, a directory holding that commit's ``fsw`` package), extracted once."""
    commit = _git("rev-parse", "--verify", "--quiet", f"{rev}^{{commit}}")
    target = cache_root() / commit
    if (target / "fsw" / "__init__.py").is_file():
        return commit, target
    target.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".{commit[:12]}-", dir=target.parent))
    try:
        archive = subprocess.run(["git", "archive", "--format=tar", commit, "fsw"], cwd=REPO, capture_output=True,
                                 check=False)
        if archive.returncode != 0:
            raise AgainstError(f"git archive {commit[:12]} fsw: {archive.stderr.decode(errors='replace').strip()}")
        subprocess.run(["tar", "-x", "-C", str(staging)], input=archive.stdout, check=True)
        try:
            staging.rename(target)  # another process may have made it meanwhile: either is fine
        except OSError:
            if not (target / "fsw" / "__init__.py").is_file():
                raise
    finally:
        if staging.exists():
            shutil.rmtree(staging, ignore_errors=True)
    return commit, target


def seed_kernel_cache(compiled: str | None, tree: Path) -> int:
    """Copy the compiled kernels in directory ``compiled`` (the working tree's, as its worker
    reported) into the revision at ``tree``'s own kernel cache, if the two trees' kernel sources
    are the same bytes and the revision has no compiled kernels yet; returns the files copied.

    numba then finds, under the same file names, an index stamped with the same digest of the
    kernel sources and loads the machine code instead of compiling it; anything it cannot use it
    compiles anew, as for an empty cache."""
    from fsw.kernels.cache import source_stamp

    source, target = (Path(compiled) if compiled else None), tree / "fsw" / "kernels" / "__pycache__"
    if source is None or not source.is_dir() or any(target.glob("*.nbi")):
        return 0
    if source_stamp(REPO / "fsw" / "kernels") != source_stamp(tree / "fsw" / "kernels"):
        return 0
    target.mkdir(parents=True, exist_ok=True)
    copied = 0
    # data files first: an index is only of use once the files it names are there
    for pattern in ("*.nbc", "*.nbi"):
        for path in sorted(source.glob(pattern)):
            staged = target / f".{path.name}.tmp"
            shutil.copyfile(path, staged)
            os.replace(staged, target / path.name)
            copied += 1
    return copied


class _Side:
    """A worker process running the ``fsw`` of the tree at ``root`` (with ``own_cache``, numba
    keeps its compiled kernels inside that tree whatever ``NUMBA_CACHE_DIR`` says)."""

    def __init__(self, name: str, root: Path, own_cache: bool = False):
        self.name = name
        env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(root), *filter(None, [os.environ.get("PYTHONPATH")])])}
        if own_cache:
            env.pop("NUMBA_CACHE_DIR", None)
        self.proc = subprocess.Popen([sys.executable, str(WORKER)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     env=env, text=True, cwd=str(root))

    def ask(self, **request: Any) -> dict[str, Any]:
        assert self.proc.stdin is not None and self.proc.stdout is not None
        try:
            self.proc.stdin.write(json.dumps(request) + "\n")
            self.proc.stdin.flush()
            line = self.proc.stdout.readline()
        except OSError as exc:
            raise AgainstError(f"the {self.name} side's worker failed: {exc}") from None
        if not line:
            raise AgainstError(f"the {self.name} side's worker ended (exit code {self.proc.wait()}); its error is above")
        answer = json.loads(line)
        if "error" in answer:
            raise AgainstError(f"the {self.name} side's worker: {answer['error']}")
        return answer

    def close(self) -> None:
        try:
            if self.proc.poll() is None:  # a quit gets no reply
                assert self.proc.stdin is not None
                self.proc.stdin.write(json.dumps({"quit": True}) + "\n")
                self.proc.stdin.close()
            self.proc.wait(timeout=30)
        except Exception:
            self.proc.kill()
            self.proc.wait()


def first_difference(outputs: list[tuple[str, str]]) -> str | None:
    """Where the first of these recorded outputs (label, file of ``topic NUL json`` lines) that
    differs from the first one parts from it, in words; None if none differs."""
    (label0, path0), rest = outputs[0], outputs[1:]
    base = Path(path0).read_bytes().splitlines()
    for label, path in rest:
        other = Path(path).read_bytes().splitlines()
        for k, (a, b) in enumerate(zip(base, other)):
            if a != b:
                topic, ours = a.split(b"\0", 1)
                theirs = b.split(b"\0", 1)[-1]
                return (f"{label} parts from {label0} at message {k + 1} ({topic.decode(errors='replace')}): "
                        f"{ours[:300].decode(errors='replace')} | {theirs[:300].decode(errors='replace')}")
        if len(base) != len(other):
            return f"{label} emitted {len(other)} messages, {label0} {len(base)}"
    return None


def _stream_files(directory: Path, span_days: float | None, seed: int) -> tuple[Path, Path, int]:
    """The default scenario's FSW configuration and measurements, as files a worker reads."""
    from fsw.interface import codec, typed
    from fsw.interface import messages as m
    from sim.stream import generate
    from tools.bench.core import scenario
    from tools.scenario import resolve

    resolved, seed = resolve(scenario(span_days), seed)
    run = generate(resolved.sim, seed=seed)
    config_file, stream_file = directory / "fsw-config.json", directory / "measurements.jsonl"
    # work units: outputs that do not depend on how fast the host was (module docstring)
    fsw = dataclasses.replace(resolved.fsw, budget=dataclasses.replace(resolved.fsw.budget, mode="work-units"))
    config_file.write_text(json.dumps(typed.encode(fsw)), encoding="utf-8")
    measurements = [msg for _, msg in run.iter_messages() if isinstance(msg, m.Measurement)]
    stream_file.write_bytes(b"\n".join(codec.to_json(msg) for msg in measurements) + b"\n")
    return config_file, stream_file, len(measurements)


def compare(rev: str, span_days: float | None = None, repeats: int = 3, chunk: int = 250, seed: int = 1,
            progress: IO[str] | None = None) -> dict[str, Any]:
    """The ``fsw-core-vs-<rev>`` row (module docstring)."""
    commit, tree = revision_tree(rev)
    with tempfile.TemporaryDirectory(prefix="navbank-against-") as tmp:
        config_file, stream_file, n = _stream_files(Path(tmp), span_days, seed)
        sides: dict[str, _Side] = {}

        def ready(key: str, side: _Side) -> dict[str, Any]:
            """The side loaded and warmed up; its answer to the first start."""
            sides[key] = side
            got = side.ask(load=str(config_file), stream=str(stream_file))["measurements"]
            if got != n:
                raise AgainstError(f"the {side.name} side read {got} of {n} measurements")
            # untimed: what a process pays once (compiled kernels loaded, or compiled the first
            # time a revision is compared; tables built), not per measurement
            started = side.ask(start=True)
            side.ask(run=[0, min(n, WARM_UP_MEASUREMENTS)])
            side.ask(finish=True)
            return started

        try:
            # the working tree's kernels are loaded before the revision's process starts (importing
            # the FSW loads some of them): where the sources are the same, the revision takes them
            seeded = seed_kernel_cache(ready("ours", _Side("working tree", REPO)).get("kernel_cache"), tree)
            ready("reference", _Side(commit[:12], tree, own_cache=True))
            cpu: dict[str, list[float]] = {"ours": [], "reference": []}
            # each side's distinct output digests, with the file of the first repeat that gave each
            digests: dict[str, dict[str, str]] = {"ours": {}, "reference": {}}
            for rep in range(repeats):
                total = {key: side.ask(start=True)["cpu_s"] for key, side in sides.items()}
                order = ["ours", "reference"] if rep % 2 == 0 else ["reference", "ours"]
                for start in range(0, n, chunk):
                    for key in order:
                        total[key] += sides[key].ask(run=[start, min(start + chunk, n)])["cpu_s"]
                    order.reverse()
                for key, side in sides.items():
                    # the next unused name: the files of the outputs already seen stay as they were
                    kept = str(Path(tmp) / f"{key}-{len(digests[key])}.out")
                    end = side.ask(finish=True, keep=kept)
                    total[key] += end["cpu_s"]
                    digests[key].setdefault(end["digest"], kept)
                    cpu[key].append(total[key] / max(n, 1) * 1e6)
                if progress is not None:
                    print(f"bench --against {commit[:12]}: repeat {rep + 1}/{repeats}: ours {cpu['ours'][-1]:.1f}, "
                          f"reference {cpu['reference'][-1]:.1f} us/measurement", file=progress, flush=True)
            identical = len(digests["ours"]) == len(digests["reference"]) == 1 and digests["ours"].keys() == digests[
                "reference"].keys()
            difference = None if identical else first_difference(
                [(f"{key} repeat {i + 1}", path) for key in ("ours", "reference")
                 for i, path in enumerate(digests[key].values())])
        finally:
            for side in sides.values():
                side.close()
    return make_row(f"fsw-core-vs-{commit[:12]}", statistics.fmean(cpu["ours"]), statistics.fmean(cpu["reference"]),
                    "us CPU/measurement", NOT_SLOWER,
                    f"{commit[:12]}'s core CPU / the working tree's on the same stream, in lock step (> 1: the working "
                    "tree is faster; a tree against itself: 0.99-1.01)",
                    revision=commit, outputs_identical=identical, first_difference=difference,
                    per_repeat_ratios=[round(r / o, 4) for o, r in zip(cpu["ours"], cpu["reference"])],
                    ours_us=[round(v, 2) for v in cpu["ours"]], reference_us=[round(v, 2) for v in cpu["reference"]],
                    measurements=n, chunk=chunk, repeats=repeats, span_days=span_days,
                    kernels_copied=seeded)


__all__ = ["AgainstError", "compare", "revision_tree", "seed_kernel_cache"]
