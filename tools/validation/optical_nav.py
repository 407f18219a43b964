"""How well the optical-only filter navigates, nominal and under a constant centroid bias.

Flies the ``insight-approach`` simulation and an optical-only EKF (the ``optical`` filter of the
nominal bank, Lubey & Ely 2022 §4.2) over its optical measurements, and reports once a day:

* the filter's root-trace position sigma (RTPC);
* its position error across the line of sight to Mars (the component a rotation of every line
  of sight about Mars would move), and that plane's root-trace sigma;
* the mean normalised innovation square chi2/m of the day's images (1 for residuals as the
  filter expects them), so one can see whether the residuals reveal a bias.

Used for the optical-navigation section of ``docs/validation.md``::

    python -m tools.validation.optical_nav --fault optical-bias-medium --days 30
"""

from __future__ import annotations

import argparse
import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from fsw.filters.bank import FilterBank
from fsw.filters.config import BankConfig
from fsw.filters.errors import MeasurementRejected
from sim.faults.presets import preset
from fsw.astro.asteroids import NAMES as BEACONS
from sim.stream import SimRun, generate
from tools.scenario import load_scenario, resolve

DAY_S = 86400.0


@dataclass(frozen=True)
class DayRow:
    day: int
    images: int
    rtpc_km: float
    cross_error_km: float
    cross_sigma_km: float
    along_error_km: float
    chi2_per_dof: float
    chi2_mars_system: float
    chi2_beacons: float
    mean_residual_px: tuple[float, float]


def measure(fault: str | None, seed: int = 1, days: int = 30, **camera: Any) -> tuple[list[DayRow], dict[str, int]]:
    """Daily rows of the optical-only filter over ``days`` days of the approach; ``camera``
    replaces fields of the simulator's optical configuration."""
    cfg = load_scenario("insight-approach")
    faults = () if fault is None else preset(fault, onset_day=0.0)
    optical_cfg = dataclasses.replace(cfg.sim.optical, **camera)
    cfg = dataclasses.replace(cfg, sim=dataclasses.replace(cfg.sim, faults=tuple(faults), optical=optical_cfg))
    cfg, seed = resolve(cfg, seed)
    run = generate(cfg.sim, seed=seed)
    optical = next(f for f in cfg.fsw.bank.filters if f.name == "optical")
    init = cfg.fsw.initial_state
    assert init is not None
    bank = FilterBank(BankConfig(filters=(optical,)), init.t_s, init.position_km, init.velocity_km_s)
    t0 = run.t_start
    rows: list[DayRow] = []
    counts: dict[str, int] = {}
    chi2: list[tuple[bool, float]] = []
    res: list[np.ndarray] = []
    next_day = 1
    for meas in run.measurements:
        while meas.t_s >= t0 + next_day * DAY_S and next_day <= days:
            rows.append(_row(bank, run, t0 + next_day * DAY_S, next_day, chi2, res))
            chi2, res = [], []
            next_day += 1
        if next_day > days:
            break
        if meas.kind != "optical":
            continue
        counts[meas.source] = counts.get(meas.source, 0) + 1
        try:
            rec = bank.process(meas)
        except MeasurementRejected:
            counts["rejected"] = counts.get("rejected", 0) + 1
            continue
        chi2.append((meas.source in BEACONS, float(rec.chi2[0]) / 2.0))
        res.append(rec.residual[0])
    return rows, counts


def _mean(values: list[float]) -> float:
    return float(np.mean(values)) if values else float("nan")


def _row(bank: FilterBank, run: SimRun, t: float, day: int, chi2: list[tuple[bool, float]],
         res: list[np.ndarray]) -> DayRow:
    bank.propagate_to(t)
    x = bank.x("optical")
    P = bank.P("optical")[:3, :3]
    truth = run.state_at(np.array([t]))[0]
    err = x[:3] - truth[:3]
    u = truth[:3] / np.linalg.norm(truth[:3])  # Mars-centred: the line of sight is -u
    proj = np.eye(3) - np.outer(u, u)
    cross = proj @ err
    mr = np.mean(res, axis=0) if res else np.zeros(2)
    return DayRow(day=day, images=len(chi2), rtpc_km=float(np.sqrt(np.trace(P))),
                  cross_error_km=float(np.linalg.norm(cross)),
                  cross_sigma_km=float(np.sqrt(np.trace(proj @ P @ proj))),
                  along_error_km=float(err @ u),
                  chi2_per_dof=_mean([c for _, c in chi2]),
                  chi2_mars_system=_mean([c for b, c in chi2 if not b]),
                  chi2_beacons=_mean([c for b, c in chi2 if b]),
                  mean_residual_px=(float(mr[0]), float(mr[1])))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fault", default=None, help="fault preset (e.g. optical-bias-medium); none by default")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--days", type=int, default=30)
    ap.add_argument("--roll", choices=("north", "sun", "random"), default=None, help="camera roll profile (scenario's by default)")
    ap.add_argument("--no-beacons", action="store_true", help="image Mars, Phobos and Deimos only")
    args = ap.parse_args()
    camera: dict[str, Any] = {}
    if args.roll is not None:
        camera["roll"] = args.roll
    if args.no_beacons:
        camera["beacons"] = ()
    rows, counts = measure(args.fault, args.seed, args.days, **camera)
    print(f"fault={args.fault} seed={args.seed} camera={camera} images={counts}")
    print("day images rtpc_km cross_err_km cross_sigma_km ratio along_err_km chi2/m(all mars-system beacons) mean_res_px")
    for r in rows:
        print(f"{r.day:3d} {r.images:5d} {r.rtpc_km:9.1f} {r.cross_error_km:10.1f} {r.cross_sigma_km:10.1f} "
              f"{r.cross_error_km / r.cross_sigma_km:7.2f} {r.along_error_km:10.1f} {r.chi2_per_dof:8.2f} "
              f"{r.chi2_mars_system:8.2f} {r.chi2_beacons:8.2f} {r.mean_residual_px[0]:7.2f} {r.mean_residual_px[1]:7.2f}")


if __name__ == "__main__":
    main()
