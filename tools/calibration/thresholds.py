"""Calibration of the anomaly detector on nominal runs, to a target false-alarm rate.

Procedure (``navbank calibrate`` runs the nominal campaign and calls :func:`calibrate`;
``python -m tools.calibration nominal.npz --network chi2 --target-fa 0.01 --out detector.yaml``
calibrates from weight histories already at hand):

1. Drop the first ``warmup`` batches of every nominal run (the gating network's start transient).
2. Learn the nominal band of the network's weights: per-filter mean and the covariance of the
   pooled nominal weight vectors (``statistic.py``; non-uniform nominals such as Magill's are
   learned, not assumed).
3. Compute D for every nominal batch, cut runs into segments if the rate is per segment (e.g. a
   day's worth of batches), and compute each unit's *critical value* c: the largest threshold at
   which the k-of-n rule would declare on it (``persistence.py``). A unit false-alarms at threshold
   h exactly when c > h, so the false-alarm probability is P(c > h).
4. Choose h. With R units and target alpha, the j-th largest critical value, j = floor(alpha (R+1)),
   has expected exceedance probability j/(R+1) <= alpha for a fresh nominal unit (order statistics
   of i.i.d. samples: E[1 − F(c_(R+1−j))] = j/(R+1)), so h = that value ("empirical"). When R is
   too small for j >= 1, a Gumbel law is fitted to the critical values (they are maxima over
   windows) and h is its upper alpha quantile ("gumbel"); this extrapolates and says so.
5. Report the achieved in-sample rate #(c > h)/R with its Clopper–Pearson interval;
   :func:`evaluate_false_alarms` runs the real detector over held-out nominal runs for an
   out-of-sample check. The held-out count X on M fresh units is not binomial around alpha: the
   threshold is itself random, and its true exceedance probability is Beta(j, R + 1 − j), so X is
   beta-binomial (exact for i.i.d. continuous critical values);
   :func:`false_alarm_prediction_interval` gives that interval.
6. Hysteresis and onset look-back: clear_threshold is the ``clear_quantile`` of the per-batch
   nominal D (so, with probability q per batch, D falls below it once weights are nominal again:
   clearing takes (1 − q^m)/((1 − q) q^m) batches on average for hold m), capped at
   ``max_clear_ratio`` × threshold so the hysteresis band never vanishes (k-of-n persistence can
   put the declaration threshold close to high per-batch quantiles). The CUSUM reference is the
   ``onset_quantile`` of the per-batch nominal D, capped at clear_threshold.

Hanlon & Maybeck 2000 §III: false alarms grow as the detectable signal shrinks, and should be measured
statistically — hence a calibrated threshold with a confidence interval rather than a fixed
probability threshold.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Literal, Sequence

import numpy as np
from scipy import stats

from fsw.fdir.config import DetectorConfig, Statistic
from fsw.fdir.detector import AnomalyDetector
from fsw.fdir.families import FilterFamily
from fsw.fdir.persistence import critical_value
from fsw.fdir.statistic import NominalBand
from fsw.interface.typed import spec
from ground.report.intervals import clopper_pearson

MIN_UNITS_FOR_TAIL_FIT = 10


class CalibrationError(ValueError):
    """Nominal histories that cannot produce a detector configuration (too few, inconsistent)."""


@dataclass(frozen=True)
class CalibrationReport:
    """What the calibration chose and how well the false-alarm target is met on its data."""

    network: str = spec(doc="Gating network calibrated")
    units: int = spec(doc="Number of nominal units (runs or segments) behind the threshold", ge=0)
    batches: int = spec(doc="Number of nominal batches evaluated (after warm-up)", ge=0)
    method: Literal["empirical", "gumbel"] = spec(doc="How the threshold was chosen")
    rank: int = spec(doc="Empirical method: the threshold is the rank-th largest critical value (0 for gumbel)", ge=0)
    threshold: float = spec(doc="Declaration threshold on D")
    clear_threshold: float = spec(doc="Clear threshold on D")
    onset_reference: float = spec(doc="CUSUM reference for the onset look-back")
    target_fa: float = spec(doc="Target false-alarm probability per unit")
    expected_fa: float = spec(doc="Expected false-alarm probability for a fresh nominal unit")
    false_alarms: int = spec(doc="Units of the calibration set that would declare at threshold", ge=0)
    fa_rate: float = spec(doc="false_alarms / units")
    fa_ci: tuple[float, float] = spec(doc="Clopper-Pearson interval on the per-unit false-alarm rate")
    confidence_level: float = spec(doc="Level of fa_ci")
    batch_exceedance: float = spec(doc="Fraction of nominal batches with D > threshold")
    nominal_std: tuple[float, ...] = spec(doc="Per-filter standard deviation of nominal weights")


@dataclass(frozen=True)
class FalseAlarmEstimate:
    """Observed false alarms of a configured detector on nominal units."""

    false_alarms: int
    units: int
    rate: float
    ci: tuple[float, float]


def _as_runs(histories: Sequence[np.ndarray], n_filters: int, warmup: int) -> list[np.ndarray]:
    runs = []
    for r, h in enumerate(histories):
        w = np.asarray(h, dtype=float)
        if w.ndim != 2 or w.shape[1] != n_filters:
            raise CalibrationError(f"run {r}: weights must have shape (batches, {n_filters}), got {w.shape}")
        if not np.all(np.isfinite(w)):
            raise CalibrationError(f"run {r}: weights contain NaN or infinity")
        if w.shape[0] > warmup:
            runs.append(w[warmup:])
    if not runs:
        raise CalibrationError("no nominal batches left after warm-up")
    return runs


def _units(stat_runs: list[np.ndarray], segment_batches: int | None) -> list[np.ndarray]:
    if segment_batches is None:
        return stat_runs
    units = []
    for d in stat_runs:
        for start in range(0, d.size - segment_batches + 1, segment_batches):
            units.append(d[start : start + segment_batches])
    if not units:
        raise CalibrationError(f"no run is as long as one segment of {segment_batches} batches")
    return units


def _threshold(crit: np.ndarray, target_fa: float) -> tuple[float, str, int]:
    r = crit.size
    j = int(np.floor(target_fa * (r + 1)))
    if j >= 1:
        ranked = np.sort(crit)[::-1]
        return float(ranked[j - 1]), "empirical", j
    finite = crit[np.isfinite(crit)]
    if finite.size < MIN_UNITS_FOR_TAIL_FIT:
        raise CalibrationError(
            f"{r} nominal units cannot support a false-alarm target of {target_fa:g} "
            f"(need about {int(np.ceil(1 / target_fa))} for an empirical quantile, "
            f"or at least {MIN_UNITS_FOR_TAIL_FIT} for a tail fit)"
        )
    loc, scale = stats.gumbel_r.fit(finite)
    return float(stats.gumbel_r.isf(target_fa, loc, scale)), "gumbel", 0


def calibrate(
    histories: Sequence[np.ndarray],
    target_fa: float,
    *,
    network: str,
    filters: Sequence[str],
    statistic: Statistic = "mahalanobis",
    persistence: tuple[int, int] = (3, 5),
    hold: int = 5,
    warmup: int = 0,
    segment_batches: int | None = None,
    spread_floor: float = 1.0e-3,
    clear_quantile: float = 0.90,
    max_clear_ratio: float = 0.90,
    onset_quantile: float = 0.90,
    confidence_level: float = 0.95,
    min_margin: float = 0.02,
    min_margin_z: float = 2.0,
) -> tuple[DetectorConfig, CalibrationReport]:
    """Detector configuration whose false-alarm probability per run (or per segment of
    ``segment_batches`` batches) on nominal data is ``target_fa``; see the module docstring.

    ``histories``: one array per nominal run, shape (batches, N), columns in ``filters`` order.
    """
    if not 0.0 < target_fa < 1.0:
        raise CalibrationError("target_fa must lie in (0, 1)")
    k, n = persistence
    if not 1 <= k <= n:
        raise CalibrationError("persistence (k, n) needs 1 <= k <= n")
    if not 0.0 < onset_quantile < 1.0 or not 0.0 < clear_quantile < 1.0:
        raise CalibrationError("clear_quantile and onset_quantile must lie in (0, 1)")
    if not 0.0 < max_clear_ratio < 1.0:
        raise CalibrationError("max_clear_ratio must lie in (0, 1)")
    names = tuple(filters)
    runs = _as_runs(histories, len(names), warmup)
    pooled = np.concatenate(runs)
    if pooled.shape[0] < len(names) + 1:
        raise CalibrationError("too few nominal batches to estimate the weights' covariance")
    band = NominalBand.from_samples(pooled, spread_floor, statistic)
    stat_runs = [band.deviation(w) for w in runs]
    units = _units(stat_runs, segment_batches)
    crit = np.array([critical_value(d, k, n) for d in units])
    threshold, method, rank = _threshold(crit, target_fa)
    expected = rank / (crit.size + 1) if method == "empirical" else target_fa
    all_d = np.concatenate(stat_runs)
    if not threshold > 0.0:
        raise CalibrationError("nominal weights show no spread: the threshold would be zero")
    clear = min(float(np.quantile(all_d, clear_quantile)), max_clear_ratio * threshold)
    onset_ref = min(float(np.quantile(all_d, onset_quantile)), clear)
    raw_cov = band.cov - spread_floor**2 * np.eye(len(names))
    config = DetectorConfig(
        network=network,
        filters=names,
        nominal_mean=tuple(float(x) for x in band.mean),
        nominal_cov=tuple(tuple(float(x) for x in row) for row in 0.5 * (raw_cov + raw_cov.T)),
        threshold=threshold,
        clear_threshold=clear,
        onset_reference=onset_ref,
        statistic=statistic,
        spread_floor=spread_floor,
        persistence_k=k,
        persistence_n=n,
        hold=hold,
        warmup=warmup,
        target_fa=target_fa,
        segment_batches=segment_batches,
        min_margin=min_margin,
        min_margin_z=min_margin_z,
    )
    fa = int(np.sum(crit > threshold))
    report = CalibrationReport(
        network=network,
        units=int(crit.size),
        batches=int(all_d.size),
        method=method,  # type: ignore[arg-type]
        rank=rank,
        threshold=threshold,
        clear_threshold=clear,
        onset_reference=onset_ref,
        target_fa=target_fa,
        expected_fa=float(expected),
        false_alarms=fa,
        fa_rate=fa / crit.size,
        fa_ci=clopper_pearson(fa, int(crit.size), confidence_level),
        confidence_level=confidence_level,
        batch_exceedance=float(np.mean(all_d > threshold)),
        nominal_std=tuple(float(s) for s in np.sqrt(np.clip(np.diag(raw_cov), 0.0, None))),
    )
    return config, report


def false_alarm_prediction_interval(report: CalibrationReport, units: int, level: float = 0.95) -> tuple[int, int]:
    """Central interval for the number of false alarms on ``units`` fresh nominal units.

    Empirical thresholds: beta-binomial(units, j, R + 1 − j), which carries the calibration's own
    sampling error (step 5 of the procedure). Gumbel thresholds: binomial(units, target), which
    ignores the uncertainty of the tail fit.
    """
    if units <= 0:
        raise ValueError("units must be positive")
    tail = (1.0 - level) / 2.0
    if report.method == "empirical":
        dist = stats.betabinom(units, report.rank, report.units + 1 - report.rank)
    else:
        dist = stats.binom(units, report.expected_fa)
    return int(dist.ppf(tail)), int(dist.isf(tail))


def evaluate_false_alarms(
    config: DetectorConfig,
    histories: Sequence[np.ndarray],
    families: Sequence[FilterFamily] | None = None,
    confidence_level: float = 0.95,
) -> FalseAlarmEstimate:
    """Run the detector over nominal runs (split into segments like the calibration) and count the
    units on which it declared at least once; with the Clopper–Pearson interval."""
    fams = families or [FilterFamily(name=f, families=("unspecified",)) for f in config.filters]
    units: list[np.ndarray] = []
    for h in histories:
        w = np.asarray(h, dtype=float)
        if config.segment_batches is None:
            units.append(w)
        else:
            body = w[config.warmup :]
            seg = config.segment_batches
            units.extend(body[s : s + seg] for s in range(0, body.shape[0] - seg + 1, seg))
    if not units:
        raise CalibrationError("no nominal units to evaluate")
    # segments are cut after the run's warm-up, so the per-segment detectors need none
    unit_config = config if config.segment_batches is None else replace(config, warmup=0)
    alarms = 0
    for unit in units:
        det = AnomalyDetector(unit_config, fams)
        for i, w in enumerate(unit):
            if det.update(float(i), w, config.filters).flag:
                alarms += 1
                break
    return FalseAlarmEstimate(alarms, len(units), alarms / len(units), clopper_pearson(alarms, len(units), confidence_level))


@dataclass(frozen=True)
class HoldoutCheck:
    """A calibrated detector run over held-out nominal runs, against the calibration's prediction."""

    units: int = spec(doc="Held-out nominal units (runs or segments)", ge=0)
    false_alarms: int = spec(doc="Units on which the detector declared", ge=0)
    rate: float = spec(doc="false_alarms / units")
    ci: tuple[float, float] = spec(doc="Clopper-Pearson interval on the per-unit rate")
    predicted: tuple[int, int] = spec(doc="Central prediction interval for false_alarms (false_alarm_prediction_interval)")
    level: float = spec(doc="Level of ci and predicted")
    inside: bool = spec(doc="false_alarms lies inside predicted")


def holdout_check(config: DetectorConfig, report: CalibrationReport, histories: Sequence[np.ndarray],
                  families: Sequence[FilterFamily] | None = None, level: float = 0.95) -> HoldoutCheck:
    """Step 5 out of sample: the real detector (:func:`evaluate_false_alarms`) on runs the
    calibration never saw, and whether its false-alarm count lies in the interval the calibration
    predicts for that many fresh units (:func:`false_alarm_prediction_interval`)."""
    est = evaluate_false_alarms(config, histories, families, level)
    lo, hi = false_alarm_prediction_interval(report, est.units, level)
    return HoldoutCheck(units=est.units, false_alarms=est.false_alarms, rate=est.rate, ci=est.ci,
                        predicted=(lo, hi), level=level, inside=lo <= est.false_alarms <= hi)
