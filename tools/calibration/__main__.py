"""``python -m tools.calibration RUNS.npz --network NET --out detector.yaml``: calibrate the
anomaly detector from nominal weight histories already at hand (``navbank calibrate`` flies the
nominal runs itself)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Sequence

import numpy as np

from fsw.fdir.config import config_to_yaml
from fsw.interface.yamlconfig import dump_yaml
from tools.calibration.thresholds import CalibrationError, calibrate


def _load_runs(path: Path) -> tuple[list[np.ndarray], tuple[str, ...]]:
    with np.load(path, allow_pickle=False) as data:
        if "filters" not in data:
            raise CalibrationError(f"{path}: missing array 'filters' (filter names)")
        names = tuple(str(s) for s in data["filters"])
        if "weights" in data:
            stacked = data["weights"]
            if stacked.ndim != 3:
                raise CalibrationError(f"{path}: 'weights' must have shape (runs, batches, filters)")
            return [stacked[i] for i in range(stacked.shape[0])], names
        keys = sorted(k for k in data.files if k.startswith("run_"))
        if not keys:
            raise CalibrationError(f"{path}: no 'weights' array and no 'run_*' arrays")
        return [data[k] for k in keys], names


def main(argv: Sequence[str] | None = None) -> int:
    """Command line: calibrate a detector from an .npz of nominal weight histories."""
    parser = argparse.ArgumentParser(
        prog="python -m tools.calibration",
        description="Calibrate the anomaly detector's threshold to a target false-alarm rate "
        "on nominal weight histories (.npz with 'filters' and 'weights' (runs, batches, N) "
        "or one 'run_*' array (batches, N) per run).",
    )
    parser.add_argument("runs", type=Path)
    parser.add_argument("--network", required=True)
    parser.add_argument("--target-fa", type=float, default=0.01)
    parser.add_argument("--statistic", choices=("mahalanobis", "max-z"), default="mahalanobis")
    parser.add_argument("--persistence", type=int, nargs=2, metavar=("K", "N"), default=(3, 5))
    parser.add_argument("--hold", type=int, default=5)
    parser.add_argument("--warmup", type=int, default=0)
    parser.add_argument("--segment-batches", type=int, default=None)
    parser.add_argument("--spread-floor", type=float, default=1.0e-3)
    parser.add_argument("--out", type=Path, required=True, help="detector configuration (YAML)")
    parser.add_argument("--report", type=Path, default=None, help="calibration report (YAML)")
    args = parser.parse_args(argv)
    try:
        runs, names = _load_runs(args.runs)
        config, report = calibrate(
            runs, args.target_fa, network=args.network, filters=names, statistic=args.statistic,
            persistence=tuple(args.persistence), hold=args.hold, warmup=args.warmup,
            segment_batches=args.segment_batches, spread_floor=args.spread_floor,
        )
    except (CalibrationError, OSError, ValueError) as exc:
        print(f"calibration failed: {exc}", file=sys.stderr)
        return 2
    args.out.write_text(config_to_yaml(config))
    report_text = dump_yaml(report, drop_defaults=False)
    if args.report is not None:
        args.report.write_text(report_text)
    print(report_text, end="")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
