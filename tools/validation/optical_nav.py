"""How well the optical-only filter navigates, nominal and under a constant centroid bias.

Flies the ``insight-approach`` simulation and an optical-only EKF (the ``optical`` filter of the
nominal bank, Lubey & Ely 2022 §4.2) over its optical measurements, and reports once a day:

* the filter's root-trace position sigma (RTPC);
* its position error across the line of sight to Mars (the component a rotation of every line
  of sight about Mars would move), and that plane's root-trace sigma;
* the mean normalised innovation square chi2/m of the day's images (1 for residuals as the
  filter expects them), so one can see whether the residuals reveal a bias.

:func:`optical_nav_section` runs the experiment for ``navbank validation-report`` (the section
"Beyond the papers: the optical navigation camera and a constant centroid bias").
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, Callable

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


#: Camera set-ups compared: the previous camera (roll about ICRF north, Mars system only, a fixed
#: 5 urad attitude-knowledge error), the default one, and the default with a random roll.
CAMERAS: dict[str, dict[str, Any]] = {
    "previous: north roll, Mars system, fixed knowledge": dict(beacons=(), roll="north", attitude_from="fixed"),
    "default: sun-keeping roll, stars, beacons": {},
    "random roll, stars, beacons": dict(roll="random"),
}
FAULTS: tuple[str | None, ...] = (None, "optical-bias-medium", "optical-bias-large")
PREVIOUS, DEFAULT, RANDOM = CAMERAS

Results = dict[tuple[str, str | None, int], list[DayRow]]


def run_experiment(seeds: tuple[int, ...] = (1, 2, 3), days: int = 30) -> Results:
    """Every camera × fault × seed (about 5 s a run)."""
    return {(cam, fault, seed): measure(fault, seed, days, **CAMERAS[cam])[0]
            for cam in CAMERAS for fault in FAULTS for seed in seeds}


def _seed_mean(results: Results, cam: str, fault: str | None, value: Callable[[list[DayRow]], float]) -> float:
    vals = [value(rows) for (c, f, _), rows in results.items() if c == cam and f == fault]
    return float(np.mean(vals))


def _after_day1(rows: list[DayRow], field: str) -> float:
    vals = [v for v in (getattr(r, field) for r in rows[1:]) if not np.isnan(v)]
    return float(np.mean(vals)) if vals else float("nan")


def optical_nav_section(results: Results | None = None) -> Any:
    """The report section (``results``: :func:`run_experiment`'s, run here when not given)."""
    from tools.validation.claims import Claim
    from tools.validation.section import Section, claims_lines, table

    res = results if results is not None else run_experiment()
    seeds = sorted({k[2] for k in res})
    days = len(next(iter(res.values())))
    label = {None: "nominal", "optical-bias-medium": "medium bias", "optical-bias-large": "large bias"}
    s = Section("Beyond the papers: the optical navigation camera and a constant centroid bias")
    s.lines += [
        "Scenario `insight-approach`; an optical-only EKF (the bank's `optical` filter) flies the simulator's "
        f"optical images of days 1–{days}; the optical biases of Lubey & Ely 2022 Table 2 (medium 2 px / 3 px, "
        "large 20 px / 30 px, sample / line) are present from the first image. Three camera set-ups "
        "(`sim.optical` keys in brackets): the previous camera (`roll: north`, `beacons: []`, "
        "`attitude_from: fixed`), the default one (`roll: sun`, star-field attitude, ten asteroid beacons imaged "
        "every 2 h) and the default with `roll: random`. Cross-LOS: the position error across the line of "
        "sight to Mars, against 3× the root-trace sigma of that plane; χ²/m: mean normalised innovation "
        f"square per image component over days 2–{days} (1 when the residuals are as the filter expects). "
        f"Means over seeds {', '.join(map(str, seeds))}, computed by `navbank validation-report` in process "
        "(`tools/validation/optical_nav.py`).",
        "",
    ]
    rows = []
    for cam in CAMERAS:
        for fault in FAULTS:
            def rtpc(day: int) -> str:
                return f"{_seed_mean(res, cam, fault, lambda r: r[day - 1].rtpc_km):.0f}"

            def cross(day: int) -> str:
                e = _seed_mean(res, cam, fault, lambda r: r[day - 1].cross_error_km)
                sg = _seed_mean(res, cam, fault, lambda r: 3.0 * r[day - 1].cross_sigma_km)
                return f"{e:.0f} ({sg:.0f})"

            ms = _seed_mean(res, cam, fault, lambda r: _after_day1(r, "chi2_mars_system"))
            bc = _seed_mean(res, cam, fault, lambda r: _after_day1(r, "chi2_beacons"))
            rows.append([cam, label[fault], " / ".join(rtpc(d) for d in (1, 10, 20, days)),
                         cross(2), cross(days), f"{ms:.2f}", "—" if np.isnan(bc) else f"{bc:.1f}"])
    s.lines += table(["camera", "case", f"RTPC km, day 1 / 10 / 20 / {days}", "cross-LOS km day 2 (3σ)",
                      f"cross-LOS km day {days} (3σ)", "χ²/m Mars system", "χ²/m beacons"], rows)

    def worst_ratio(cam: str, fault: str | None) -> float:
        return max(r.cross_error_km / (3.0 * r.cross_sigma_km) for (c, f, _), rr in res.items()
                   if c == cam and f == fault for r in rr[1:])

    def least_ratio(cam: str, fault: str | None) -> float:
        return min(r.cross_error_km / (3.0 * r.cross_sigma_km) for (c, f, _), rr in res.items()
                   if c == cam and f == fault for r in rr[1:])

    rtpc_max = max(r.rtpc_km for (c, f, _), rr in res.items() if c == DEFAULT and f is None for r in rr)
    rtpc_min = min(r.rtpc_km for (c, f, _), rr in res.items() if c == DEFAULT and f is None for r in rr)
    prev_chi2 = max(_after_day1(rr, "chi2_per_dof") for (c, f, _), rr in res.items()
                    if c == PREVIOUS and f == "optical-bias-medium")
    bcn_nom = max(_after_day1(rr, "chi2_beacons") for (c, f, _), rr in res.items() if c == DEFAULT and f is None)
    bcn_med = min(r.chi2_beacons for (c, f, _), rr in res.items() if c == DEFAULT and f == "optical-bias-medium"
                  for r in rr[1:])
    s.claims = [
        Claim("optical-rtpc", f"Lubey & Ely 2022 §4.2: optical-only 1σ position uncertainty 10–50 km over days 1–{days}",
              10.0 <= rtpc_min and rtpc_max <= 50.0,
              f"default camera, nominal: RTPC {rtpc_min:.0f}–{rtpc_max:.0f} km"),
        Claim("optical-bias-absorbed", "previous camera: a medium optical bias is absorbed silently "
              "(cross-LOS error beyond 3σ, χ²/m below 1.5 after day 1)",
              least_ratio(PREVIOUS, "optical-bias-medium") > 1.0 and prev_chi2 < 1.5,
              f"cross-LOS error ≥ {least_ratio(PREVIOUS, 'optical-bias-medium'):.0f}× its 3σ, "
              f"largest seed χ²/m {prev_chi2:.2f}"),
        Claim("optical-bias-revealed", "default camera: the beacon residuals reveal a medium optical bias "
              "(daily beacon χ²/m above 10 from day 2; nominal below 2)",
              bcn_med > 10.0 and bcn_nom < 2.0,
              f"smallest daily beacon χ²/m {bcn_med:.1f} biased, largest seed mean {bcn_nom:.2f} nominal"),
        Claim("optical-bias-bounded", "default camera: under a medium optical bias the cross-LOS error stays "
              "within 3σ", worst_ratio(DEFAULT, "optical-bias-medium") <= 1.0,
              f"cross-LOS error up to {worst_ratio(DEFAULT, 'optical-bias-medium'):.0f}× its 3σ"),
    ]
    s.lines += ["", *claims_lines(s.claims)]
    return s
