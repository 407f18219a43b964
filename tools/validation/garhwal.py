"""Garhwal, Halder & Sinha on navbank's launch-injection case: the plain EKF against the
state-residual adaptive EKF with the least-squares slope and with the fuzzy (Tanaka FLR) slope,
flown on the same measurement sets over many seeds, and the three as a bank under the
chi-square gating network (Lubey & Ely 2022). Each seed is the built-in ``leo-injection``
scenario flown by the flight software's own core through the in-process runner
(:func:`tools.inprocess.run_in_process`): the same bank (:class:`fsw.filters.orbit_bank.OrbitBank`),
gating networks and telemetry as ``navbank run --scenario leo-injection``; the series below are
read from its ICD telemetry (estimates with full covariance every second, residuals, weights)
against its Truth messages.

Per seed and filter: position/velocity error, NEES, the orbital elements (a, e, i, Ω, ω, θ) against
the truth's (the paper's Figs. 3–8), the pre-fit observation residuals (Figs. 9–12), the time to
converge (the first epoch after which the position error stays below ``TOL_POS_KM`` and the
velocity error below ``TOL_VEL_KM_S`` to the end of the arc) and the RMS errors over the second
half of the arc. Confidence intervals: 95 %, t-interval of the mean over seeds; the paired
differences of convergence time by a bootstrap over seeds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy import stats

from fsw.astro.constants import GM_EARTH
from fsw.interface import typed
from sim.scenarios.leo_injection import KIND_ORDER
from tools.campaign.plan import merge
from tools.inprocess import run_in_process
from tools.scenario import ScenarioConfig, load_scenario
from tools.validation.claims import Claim
from tools.validation.section import Section, claims_lines, figure_links, table

SCENARIO = "leo-injection"
NAMES = ("ekf", "lsq-adaptive", "fuzzy-adaptive")
ELEMENTS = ("a [km]", "e", "i [deg]", "Ω [deg]", "ω [deg]", "θ [deg]")
TOL_POS_KM = 0.1
TOL_VEL_KM_S = 5e-4
SEEDS = 50


def elements(z: np.ndarray) -> np.ndarray:
    """(…, 6) classical elements a [km], e, i, Ω, ω, θ [deg] of GCRS states (…, 6)."""
    r, v = z[..., 0:3], z[..., 3:6]
    h = np.cross(r, v)
    n = np.cross(np.array([0.0, 0.0, 1.0]), h)
    rn = np.linalg.norm(r, axis=-1)
    hn = np.linalg.norm(h, axis=-1)
    e_vec = np.cross(v, h) / GM_EARTH - r / rn[..., None]
    a = 1.0 / (2.0 / rn - np.sum(v * v, axis=-1) / GM_EARTH)
    inc = np.degrees(np.arccos(h[..., 2] / hn))
    raan = np.degrees(np.arctan2(n[..., 1], n[..., 0])) % 360.0
    argp = np.degrees(np.arctan2(np.einsum("...i,...i->...", np.cross(n, e_vec), h) / hn,
                                 np.einsum("...i,...i->...", n, e_vec))) % 360.0
    nu = np.degrees(np.arctan2(np.einsum("...i,...i->...", np.cross(e_vec, r), h) / hn,
                               np.einsum("...i,...i->...", e_vec, r))) % 360.0
    return np.stack([a, np.linalg.norm(e_vec, axis=-1), inc, raan, argp, nu], axis=-1)


@dataclass
class SeedResult:
    t: np.ndarray  # (K,) seconds since injection of each tracked epoch
    pos_err: np.ndarray  # (F, K) km
    vel_err: np.ndarray  # (F, K) km/s
    nees: np.ndarray  # (F, K)
    elements: np.ndarray  # (F, K, 6)
    truth_elements: np.ndarray  # (K, 6)
    residuals: np.ndarray  # (F, K, 4) pre-fit, first station, KIND_ORDER (NaN where not measured)
    weights: np.ndarray  # (B, F) chi-square network weights per batch
    weights_t: np.ndarray  # (B,) seconds since injection of each batch's last measurement
    lp_solves: int = 0
    lp_failures: int = 0
    lp_us: float = 0.0


def scenario(arc_s: float | None = None) -> ScenarioConfig:
    """The built-in leo-injection scenario with every filter's full covariance in its estimates
    (for NEES) and optionally a shorter arc."""
    data = typed.encode(load_scenario(SCENARIO))
    merge(data, {"fsw.telemetry.full_covariance": True})
    if arc_s is not None:
        merge(data, {"sim.leo.arc_s": float(arc_s)})
    cfg = typed.decode(ScenarioConfig, data)
    if tuple(f.name for f in cfg.fsw.bank.filters) != NAMES:
        raise ValueError(f"the {SCENARIO} scenario's filters are not {NAMES}")
    return cfg


def run_seed(cfg: ScenarioConfig, seed: int) -> SeedResult:
    """Fly one seed in process and read its telemetry back into time series."""
    res = run_in_process(cfg, seed)
    truth = res.topic("sim/truth")
    t0 = truth[0].t_s
    z_true = np.array([[*m.position_km, *m.velocity_km_s] for m in truth])
    k_of = {round(m.t_s - t0): k for k, m in enumerate(truth)}
    ests = {n: {round(e.t_s - t0): e for e in res.topic("fsw/estimate/" + n)} for n in NAMES}
    # epochs with a truth and an estimate from every filter, after the first measurement
    first = min(m.t_s for m in res.topic("fsw/residuals")[0].samples) - t0 if res.topic("fsw/residuals") else 0.0
    ks = sorted(k for k in k_of if k >= first and all(k in ests[n] for n in NAMES))
    F, K = len(NAMES), len(ks)
    pe, ve, ne = np.empty((F, K)), np.empty((F, K)), np.empty((F, K))
    el = np.empty((F, K, 6))
    for f, n in enumerate(NAMES):
        for j, k in enumerate(ks):
            e = ests[n][k]
            x = np.array(e.state)
            err = x - z_true[k_of[k]]
            pe[f, j] = np.linalg.norm(err[0:3])
            ve[f, j] = np.linalg.norm(err[3:6])
            P = np.array(e.covariance)
            ne[f, j] = float(err @ np.linalg.solve(P, err))
            el[f, j] = elements(x)
    tel = elements(z_true[[k_of[k] for k in ks]])
    resid = np.full((F, K, 4), np.nan)
    col = {k: j for j, k in enumerate(ks)}
    station = cfg.sim.leo.stations[0] if cfg.sim.leo is not None else ""
    for msg in res.topic("fsw/residuals"):
        for smp in msg.samples:
            c = col.get(round(smp.t_s - t0))
            if c is not None and smp.source == station:
                resid[:, c, KIND_ORDER.index(smp.kind)] = [r[0] for r in smp.residual]
    wmsgs = res.topic("fsw/weights/chi2")
    weights = np.array([w.weights for w in wmsgs])
    weights_t = np.array([w.t_s - t0 for w in wmsgs])
    counts = res.topic("fsw/status")[-1].counts
    return SeedResult(t=np.array(ks, dtype=float), pos_err=pe, vel_err=ve, nees=ne, elements=el,
                      truth_elements=tel, residuals=resid, weights=weights, weights_t=weights_t,
                      lp_solves=int(counts.get("adaptive_lp_solves", 0)),
                      lp_failures=int(counts.get("adaptive_lp_failures", 0)),
                      lp_us=float(counts.get("adaptive_lp_us", 0)))


def convergence_time(t: np.ndarray, pos_err: np.ndarray, vel_err: np.ndarray) -> float:
    """First epoch after which both errors stay within tolerance to the end; NaN if never."""
    bad = (pos_err >= TOL_POS_KM) | (vel_err >= TOL_VEL_KM_S)
    if bad[-1]:
        return math.nan
    idx = np.flatnonzero(bad)
    return float(t[0] if idx.size == 0 else t[idx[-1] + 1])


def mean_ci(x: np.ndarray, level: float = 0.95) -> tuple[float, float, float]:
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    if x.size < 2:
        return (float(x.mean()) if x.size else math.nan, math.nan, math.nan)
    m = float(x.mean())
    half = float(stats.t.ppf(0.5 + level / 2, x.size - 1) * x.std(ddof=1) / math.sqrt(x.size))
    return m, m - half, m + half


def bootstrap_ci(x: np.ndarray, level: float = 0.95, n: int = 4000, seed: int = 0) -> tuple[float, float, float]:
    """Mean and percentile-bootstrap interval over seeds (paired differences)."""
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)]
    rng = np.random.default_rng(seed)
    boots = rng.choice(x, (n, x.size)).mean(axis=1)
    return float(x.mean()), float(np.quantile(boots, 0.5 - level / 2)), float(np.quantile(boots, 0.5 + level / 2))


@dataclass
class GarhwalResults:
    config: ScenarioConfig
    seeds: list[int]
    runs: list[SeedResult] = field(default_factory=list)

    def conv(self) -> np.ndarray:
        """(S, F) convergence times [s]."""
        return np.array([[convergence_time(r.t, r.pos_err[f], r.vel_err[f]) for f in range(len(NAMES))]
                         for r in self.runs])

    def late_rms(self) -> tuple[np.ndarray, np.ndarray]:
        """(S, F) RMS position [km] and velocity [km/s] error over the second half of each arc."""
        pos, vel = [], []
        for r in self.runs:
            late = r.t >= r.t[-1] / 2
            pos.append(np.sqrt(np.mean(r.pos_err[:, late] ** 2, axis=1)))
            vel.append(np.sqrt(np.mean(r.vel_err[:, late] ** 2, axis=1)))
        return np.array(pos), np.array(vel)

    def late_nees(self) -> np.ndarray:
        """(S, F) mean NEES over the second half of each arc (6 for a consistent filter)."""
        return np.array([np.mean(r.nees[:, r.t >= r.t[-1] / 2], axis=1) for r in self.runs])

    def weights(self) -> np.ndarray:
        """(S, B, F) chi-square weights (arcs cut to the shortest)."""
        b = min(r.weights.shape[0] for r in self.runs)
        return np.array([r.weights[:b] for r in self.runs])


def run_garhwal(seeds: int = SEEDS, config: ScenarioConfig | None = None, first_seed: int = 1) -> GarhwalResults:
    cfg = config or scenario()
    out = GarhwalResults(cfg, list(range(first_seed, first_seed + seeds)))
    for s in out.seeds:
        out.runs.append(run_seed(cfg, s))
    return out


def _common_grid(r: GarhwalResults) -> np.ndarray:
    k = min(x.t.size for x in r.runs)
    return r.runs[0].t[:k]


def plot_elements(r: GarhwalResults, path: Path) -> Path:
    """Element errors against time, median and 10–90 % band over seeds (Figs. 3–8 analogue)."""
    from ground.report.figure import new_figure, save

    t = _common_grid(r)
    k = t.size
    fig, axes = new_figure(3, 2, size=(10.0, 8.0))
    for e, ax in enumerate(np.ravel(axes)):
        for f, name in enumerate(NAMES):
            d = np.array([x.elements[f, :k, e] - x.truth_elements[:k, e] for x in r.runs])
            if e >= 3:
                d = (d + 180.0) % 360.0 - 180.0
            ax.plot(t, np.median(d, axis=0), label=name)
            ax.fill_between(t, np.quantile(d, 0.1, axis=0), np.quantile(d, 0.9, axis=0), alpha=0.2)
        ax.set_title(f"error in {ELEMENTS[e]}", fontsize=9)
        ax.set_xlabel("time since injection [s]", fontsize=8)
        ax.set_xlim(0.0, min(t[-1], 120.0))
    np.ravel(axes)[0].legend(fontsize=7)
    return save(fig, path)


def plot_residuals(r: GarhwalResults, path: Path) -> Path:
    """Pre-fit residuals against time, RMS over seeds (Figs. 9–12 analogue)."""
    from ground.report.figure import new_figure, save

    t = _common_grid(r)
    k = t.size
    units = (("range [m]", 1e3), ("range rate [m/s]", 1e3), ("azimuth [deg]", math.degrees(1.0)),
             ("elevation [deg]", math.degrees(1.0)))
    fig, axes = new_figure(2, 2, size=(10.0, 6.0))
    for c, ax in enumerate(np.ravel(axes)):
        for f, name in enumerate(NAMES):
            d = np.array([x.residuals[f, :k, c] for x in r.runs]) * units[c][1]
            ax.semilogy(t, np.sqrt(np.nanmean(d * d, axis=0)), label=name)
        ax.set_title(f"RMS pre-fit residual, {units[c][0]}", fontsize=9)
        ax.set_xlabel("time since injection [s]", fontsize=8)
    np.ravel(axes)[0].legend(fontsize=7)
    return save(fig, path)


def plot_errors_and_weights(r: GarhwalResults, path: Path) -> Path:
    """Position error (median over seeds), mean NEES and the chi-square network's mean weights."""
    from ground.report.figure import new_figure, save

    t = _common_grid(r)
    k = t.size
    fig, axes = new_figure(1, 3, size=(12.0, 3.8))
    for f, name in enumerate(NAMES):
        axes[0].semilogy(t, np.median([x.pos_err[f, :k] for x in r.runs], axis=0) * 1e3, label=name)
        axes[1].semilogy(t, np.mean([x.nees[f, :k] for x in r.runs], axis=0), label=name)
    axes[0].axhline(TOL_POS_KM * 1e3, color="k", lw=0.6, ls="--")
    axes[0].set_title("median position error [m]", fontsize=9)
    axes[1].axhline(6.0, color="k", lw=0.6, ls="--")
    axes[1].set_title("mean NEES (6 if consistent)", fontsize=9)
    W = r.weights()
    tb = r.runs[0].weights_t[: W.shape[1]]
    for f, name in enumerate(NAMES):
        axes[2].plot(tb, W[:, :, f].mean(axis=0), label=name)
    axes[2].set_title("chi-square network: mean weight", fontsize=9)
    for ax in axes:
        ax.set_xlabel("time since injection [s]", fontsize=8)
    axes[0].legend(fontsize=7)
    return save(fig, path)


def _fmt_ci(m: float, lo: float, hi: float, scale: float = 1.0, digits: int = 1) -> str:
    return f"{m * scale:.{digits}f} [{lo * scale:.{digits}f}, {hi * scale:.{digits}f}]"


def paired_difference(r: GarhwalResults, a: str, b: str) -> tuple[int, tuple[float, float, float], tuple[int, int, int]]:
    """Convergence time of ``a`` minus ``b`` over the seeds where both converge: (seeds, mean and
    bootstrap CI, (a faster, equal, slower) counts)."""
    conv = r.conv()
    i, j = NAMES.index(a), NAMES.index(b)
    both = np.isfinite(conv[:, i]) & np.isfinite(conv[:, j])
    d = conv[both, i] - conv[both, j]
    return int(both.sum()), bootstrap_ci(d), (int((d < 0).sum()), int((d == 0).sum()), int((d > 0).sum()))


def claims(r: GarhwalResults) -> list[Claim]:
    n, (m, lo, hi), (fast, eq, slow) = paired_difference(r, "fuzzy-adaptive", "lsq-adaptive")
    out = [Claim(
        "garhwal-fuzzy-faster",
        "the fuzzy-slope adaptive EKF converges faster than the least-squares-slope one (Figs. 3–6)",
        hi < 0.0,
        f"convergence time fuzzy − least squares over {n} seeds where both converge: mean {m:+.1f} s, "
        f"95 % bootstrap CI [{lo:+.1f}, {hi:+.1f}] s; fuzzy faster in {fast}, equal in {eq}, slower in {slow}")]
    worst = -math.inf
    parts = []
    for name in ("lsq-adaptive", "fuzzy-adaptive"):
        n, (m, lo, hi), _ = paired_difference(r, name, "ekf")
        worst = max(worst, hi)
        parts.append(f"{name} − ekf {m:+.1f} s [{lo:+.1f}, {hi:+.1f}]")
    out.append(Claim(
        "garhwal-adaptive-faster-than-plain",
        "state-noise adaptation (either slope) converges faster than the plain EKF (the paper's premise)",
        worst < 0.0, "convergence time, mean and 95 % bootstrap CI over seeds: " + "; ".join(parts)))
    return out


def garhwal_section(r: GarhwalResults, figures: list[Path], doc_dir: Path) -> Section:
    cfg = r.config.sim.leo
    assert cfg is not None
    f0 = r.config.fsw.bank.filters[0]
    chi2 = next(g for g in r.config.fsw.gating if g.network == "chi2")
    s = Section("Garhwal et al.: fuzzy against least-squares state-noise adaptation, launch-injection case")
    conv = r.conv()
    pos, vel = r.late_rms()
    nees = r.late_nees()
    n = len(r.runs)
    s.lines += [
        "The comparison of Garhwal, Halder & Sinha on navbank's own launch-injection case "
        "(`sim.scenarios.leo_injection`; the paper's PSLV-C1 data are not public): a ~505 km sun-synchronous "
        f"injection (i = {cfg.inclination_deg:g}°) modelled on PSLV-C40, tracked from "
        f"{', '.join(cfg.stations)} at {cfg.rate_hz:g} Hz in range, range rate, azimuth and elevation "
        f"(σ = {cfg.sigma_range_km * 1e3:g} m, {cfg.sigma_range_rate_km_s * 1e5:g} cm/s, "
        f"{cfg.sigma_azimuth_deg:g}°, {cfg.sigma_elevation_deg:g}°) above a {cfg.elevation_mask_deg:g}° mask over a "
        f"{cfg.arc_s:g} s arc; injection dispersion {cfg.dispersion_pos_km:g} km / {cfg.dispersion_vel_km_s * 1e3:g} m/s "
        f"per axis, a-priori σ {f0.position_sigma_km:g} km / {f0.velocity_sigma_km_s * 1e3:g} m/s about the planned state "
        "(a poor a-priori). Truth: "
        "J2–J4 and drag; the filters: two-body + J2, no drag (`fsw.filters.orbit_bank`, sequential updates). Three "
        "EKFs fly the same measurements: `ekf` (no process noise), `lsq-adaptive` and `fuzzy-adaptive` (eq. 1 with "
        "λ = 10, the first 10 epochs without adaptation, h = 0, no big-M bound). Each seed is the built-in "
        "`leo-injection` scenario flown by the flight software's core in process (`tools.inprocess`), read back "
        "from its telemetry. "
        f"{n} seeds. Convergence: the first epoch after which the position error stays below "
        f"{TOL_POS_KM * 1e3:g} m and the velocity error below {TOL_VEL_KM_S * 1e3:g} m/s to the end of the arc. "
        "Intervals: 95 % (t-interval of the mean over seeds; paired differences by bootstrap).",
        "",
        f"Computed by `navbank validation-report` itself (`tools.validation.garhwal.run_garhwal`, {n} seeds).",
        "",
    ]
    rows = []
    for f, name in enumerate(NAMES):
        c = conv[:, f]
        rows.append([
            name, f"{int(np.isfinite(c).sum())}/{n}", _fmt_ci(*mean_ci(c)),
            _fmt_ci(*mean_ci(pos[:, f]), scale=1e3), _fmt_ci(*mean_ci(vel[:, f]), scale=1e3, digits=3),
            _fmt_ci(*mean_ci(nees[:, f]), digits=2)])
    s.lines += table(["filter", "converged", "time to converge [s]", "RMS position error, 2nd half [m]",
                      "RMS velocity error, 2nd half [m/s]", "mean NEES, 2nd half (6 if consistent)"], rows)
    lp = sum(x.lp_solves for x in r.runs)
    lp_fail = sum(x.lp_failures for x in r.runs)
    lp_us = sum(x.lp_us for x in r.runs) / max(lp, 1)
    W = r.weights()
    early, late = W[:, : max(1, W.shape[1] // 4)].mean(axis=(0, 1)), W[:, -max(1, W.shape[1] // 4):].mean(axis=(0, 1))
    s.lines += [
        "",
        f"FLR linear programs: {lp} solved, {lp_fail} failed (fell back to the least-squares slope), "
        f"{lp_us:.0f} µs each on the host.",
        "",
        f"The three as a bank under the chi-square gating network (batch {chi2.params.batch_size} measurements, "
        f"σ_W {chi2.params.sigma_w:g}): mean weight "
        "over the first quarter of the arc " + ", ".join(f"{nm} {w:.3f}" for nm, w in zip(NAMES, early))
        + "; over the last quarter " + ", ".join(f"{nm} {w:.3f}" for nm, w in zip(NAMES, late)) + ".",
        "",
    ]
    pair_rows = []
    for a, b in (("fuzzy-adaptive", "lsq-adaptive"), ("lsq-adaptive", "ekf"), ("fuzzy-adaptive", "ekf")):
        k, (m, lo, hi), (fast, eq, slow) = paired_difference(r, a, b)
        pair_rows.append([f"{a} − {b}", str(k), _fmt_ci(m, lo, hi), f"{fast} / {eq} / {slow}"])
    s.lines += ["Paired differences of the time to converge (same seeds, same measurements):", ""]
    s.lines += table(["difference", "seeds", "mean [s], 95 % bootstrap CI", "first faster / equal / slower"],
                     pair_rows) + [""]
    s.claims = claims(r)
    s.lines += claims_lines(s.claims) + [""] + figure_links(figures, doc_dir)
    f_l = pair_rows[0][2]
    nees_mean = [mean_ci(nees[:, f])[0] for f in range(len(NAMES))]
    pref = NAMES[int(np.argmax(W[:, W.shape[1] // 4: 3 * W.shape[1] // 4].mean(axis=(0, 1))))] if W.shape[1] >= 4 \
        else NAMES[int(np.argmax(late))]
    s.discussion = (
        "**Discussion.** On this case the fuzzy slope does "
        + ("" if s.claims[0].holds else "not ")
        + f"converge faster than the least-squares slope (fuzzy − least squares {f_l} s). Both adaptive filters "
        "converge later than the plain EKF and end with larger errors: eq. 1 adds process noise from the state "
        "corrections themselves, which are large while the poor a-priori is being corrected, so it keeps the "
        "covariance open after the measurements have pinned the state down (mean NEES over the second half "
        + ", ".join(f"{n} {v:.2f}" for n, v in zip(NAMES, nees_mean))
        + " against 6 for a consistent filter: the adaptive filters are over-conservative). The paper's PSLV-C1 "
        "filter may have had more model error for the adaptation to absorb; here the filters' two-body + J2 model "
        "misses only J3, J4 and drag, metres over the arc. The chi-square network, which scores each filter's "
        "normalised innovations, gives the over-conservative adaptive filters slightly more weight than the plain "
        f"EKF (mid-arc it prefers {pref}); the plain EKF's smaller but honest covariance costs it chi-square — "
        "the over-inflated-uncertainty weakness Lubey & Ely 2022 name, seen on a new case."
    )
    return s


def build_section(fig_dir: Path, doc_dir: Path, seeds: int = SEEDS) -> Section:
    r = run_garhwal(seeds)
    figs = [plot_elements(r, fig_dir / "garhwal-elements.png"), plot_residuals(r, fig_dir / "garhwal-residuals.png"),
            plot_errors_and_weights(r, fig_dir / "garhwal-errors-weights.png")]
    return garhwal_section(r, figs, doc_dir)
