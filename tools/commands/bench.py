"""``navbank bench``: speed benchmarks, each against a reference measured in the same run."""

from __future__ import annotations

NAME = "bench"
HELP = "speed benchmarks (ratios against references measured in the same process)"
DESCRIPTION = """Speed benchmarks. Each entry is measured together with a reference doing the same work
in the same process, and printed as ours, reference and the ratio reference/ours (higher is
better): the linear filter bank against a bank of FilterPy KalmanFilter objects (FilterPy is the
`bench` extra, pip install "navbank[bench]"; without it that entry is skipped with a note), and
the EKF bank stacked vs the same filters run one by one, on an InSight-like
stream. --json prints one JSON object per line (name, ours, reference, unit, ratio)."""


def add_arguments(p) -> None:
    p.add_argument("--json", action="store_true", help="one JSON object per line")
    p.add_argument("--quick", action="store_true", help="fewer repetitions (a rough figure in seconds)")


def run(args) -> int:
    from tools.bench import run_benchmarks

    run_benchmarks(json=args.json, quick=args.quick)
    return 0
