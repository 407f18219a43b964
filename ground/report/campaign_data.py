"""A campaign directory read for reporting: ``runs.jsonl`` rows grouped into cases.

Each row of ``runs.jsonl`` is one run: ``id``, ``cell``, ``seed``, ``status``, ``detector``
(``{network, calibrated}``) and the run's summary (the dictionary ``navbank run`` writes to
``summary.json``: ``fault``, ``anomaly``, ``gating.<network>.mean_weights``, ...), either nested
under ``summary`` or merged into the row; rows are flattened to the merged form on reading. A
re-run appends a new row for the same id: the last row of each id wins. ``cell`` is
``{scenario, fault, variant}`` or its text key ``"scenario / fault / variant"``. Rows whose status
is not a success, or that lack the summary, are counted as failed and left out of every
statistic. Runs whose detector was not calibrated cannot declare anything; they are left out of
the detection statistics and the confusion matrix (their weights still count).

Scoring (per run, from its summary's ``anomaly`` block):

* detected — an anomaly was declared at or after the true onset (a declaration before the onset
  is a false alarm, even in a faulted run);
* diagnosed class — the declared class, ``none`` if nothing was declared;
* latency — declaration epoch minus true onset.

Monitors: a run whose variant evaluated several detectors (``detector.monitors`` and the summary's
``monitors.<network>`` blocks, same keys as ``anomaly``) is scored once per detector, as if each
were its own variant labelled ``<variant> / <network>`` (:func:`detector_rows`); the detection
statistics and confusion matrices therefore come out per network, while the weights are read
from the runs once.

Detection probabilities carry exact (Clopper–Pearson) intervals, the same as the campaign's own
``summary.json`` (:func:`ground.report.intervals.clopper_pearson`).
"""

from __future__ import annotations

import json
import warnings
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ground.report.intervals import clopper_pearson
from ground.report.run_weights import RunWeights
from fsw.interface.messages import ANOMALY_CLASSES

RUNS_FILE = "runs.jsonl"
OK_STATUSES = frozenset({"ok", "done", "complete", "completed", "success", "succeeded", "cached", "reused"})
SIZES = ("small", "medium", "large")


class CampaignReadError(ValueError):
    """A campaign directory without a readable runs.jsonl."""


@dataclass
class Campaign:
    path: Path
    rows: list[dict]  # successful runs
    failed: list[dict] = field(default_factory=list)
    bad_lines: int = 0  # lines of runs.jsonl that were not JSON objects


def load_campaign(path: str | Path) -> Campaign:
    """Read ``runs.jsonl`` from a campaign directory."""
    path = Path(path)
    runs = path / RUNS_FILE
    if not runs.is_file():
        raise CampaignReadError(f"{path}: no {RUNS_FILE} (not a campaign directory)")
    latest: dict[str, dict] = {}
    bad = 0
    with runs.open(encoding="utf-8") as f:
        for k, line in enumerate(f):
            line = line.strip()
            if not line:
                continue
            try:
                row = json.loads(line)
            except ValueError:
                bad += 1  # a line cut short by a campaign still being written
                continue
            if not isinstance(row, dict):
                bad += 1
                continue
            row = flatten(row)
            latest.pop(str(row.get("id", f"#{k}")), None)  # keep file order of the latest rows
            latest[str(row.get("id", f"#{k}"))] = row
    rows = [r for r in latest.values() if is_ok(r)]
    failed = [r for r in latest.values() if not is_ok(r)]
    return Campaign(path=path, rows=rows, failed=failed, bad_lines=bad)


def flatten(row: dict) -> dict:
    """A row with its nested ``summary`` merged in (the row's own keys win)."""
    summary = row.get("summary")
    if isinstance(summary, dict):
        return {**summary, **{k: v for k, v in row.items() if k != "summary"}}
    return row


def calibrated(row: dict) -> bool:
    """The run's detector could declare (rows that do not say are taken as calibrated)."""
    det = row.get("detector")
    return not isinstance(det, dict) or bool(det.get("calibrated", True))


def is_ok(row: dict) -> bool:
    status = row.get("status")
    ok_status = status is None or str(status).lower() in OK_STATUSES
    return ok_status and isinstance(row.get("anomaly"), dict)


def cell_parts(row: dict) -> dict[str, str]:
    """``{scenario, fault, variant}`` of a row (missing parts from the summary, else '')."""
    cell = row.get("cell")
    parts: dict[str, str] = {}
    if isinstance(cell, dict):
        parts = {k: str(cell.get(k, "")) for k in ("scenario", "fault", "variant")}
    elif isinstance(cell, str):
        pieces = [p.strip() for p in cell.split(" / ")]
        if len(pieces) == 3:
            parts = dict(zip(("scenario", "fault", "variant"), pieces))
        else:
            parts = {"scenario": "", "fault": cell, "variant": ""}
    parts.setdefault("scenario", str(row.get("scenario", "")))
    if not parts.get("fault"):
        fault = row.get("fault") or {}
        parts["fault"] = str(fault.get("preset") or fault.get("class") or "none")
    parts.setdefault("variant", "")
    return parts


def detector_rows(rows: list[dict]) -> list[dict]:
    """Every row once per detector it carries: unchanged without monitors; else one row for the
    onboard detector and one per monitor, with the cell's variant relabelled
    ``<variant> / <network>`` and ``anomaly`` that detector's block. A monitor that could not be
    evaluated (``{"error": ...}``) is left out. Rows already split are returned as they are."""
    out: list[dict] = []
    for r in rows:
        found = r.get("detector")
        det = found if isinstance(found, dict) else {}
        nets = list(det.get("monitors") or [])
        if not nets or "base_variant" in r:
            out.append(r)
            continue
        parts = cell_parts(r)
        onboard = det.get("network")
        monitors = r.get("monitors") or {}
        base = {k: v for k, v in r.items() if k != "monitors"}
        views = [(onboard, r.get("anomaly"), {k: v for k, v in det.items() if k != "monitors"}, "")]
        views += [(net, monitors.get(net), {"network": net, "calibrated": True},
                   " (replayed)" if net == onboard else "") for net in nets]
        for net, anomaly, detector, mark in views:
            if not isinstance(anomaly, dict) or "error" in anomaly:
                continue
            out.append({**base, "cell": {**parts, "variant": f"{parts['variant']} / {net}{mark}"},
                        "anomaly": anomaly, "detector": detector, "base_variant": parts["variant"],
                        "detector_network": net})
    return out


def detector_of(row: dict) -> str:
    found = row.get("detector")
    det = found if isinstance(found, dict) else {}
    return str(row.get("detector_network") or det.get("network") or (row.get("anomaly") or {}).get("network") or "")


def case_of(row: dict) -> str:
    return cell_parts(row)["fault"]


def variant_of(row: dict) -> str:
    return cell_parts(row)["variant"]


def split_size(case: str) -> tuple[str, str | None]:
    """``optical-bias-medium`` → (``optical-bias``, ``medium``), and a label written the other way
    round, ``medium bias - optical`` → (``bias - optical``, ``medium``); cases without a size →
    (case, None)."""
    for size in SIZES:
        if case.endswith("-" + size):
            return case[: -len(size) - 1], size
        if case.startswith(size + " "):
            return case[len(size) + 1:], size
    return case, None


def true_class(row: dict) -> str:
    a = row.get("anomaly") or {}
    return str(a.get("true_class") or row.get("fault_class") or (row.get("fault") or {}).get("class") or "none")


def is_faulted(row: dict) -> bool:
    return true_class(row) != "none"


def detected(row: dict) -> bool:
    a = row["anomaly"]
    return bool(a.get("declared")) and not bool(a.get("false_alarm"))


def false_alarm(row: dict) -> bool:
    a = row["anomaly"]
    return bool(a.get("declared")) and (bool(a.get("false_alarm")) or not is_faulted(row))


def diagnosed_class(row: dict) -> str:
    a = row["anomaly"]
    return str(a.get("class") or "unknown") if a.get("declared") else "none"


def latency_h(row: dict) -> float | None:
    a = row["anomaly"]
    lat = a.get("latency_s")
    return None if lat is None or not detected(row) else float(lat) / 3600.0


def interval(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    """Exact binomial interval for k successes in n trials (``(nan, nan)`` for n = 0)."""
    if n <= 0:
        return float("nan"), float("nan")
    return clopper_pearson(k, n, level)


@dataclass
class CaseStats:
    """Detection statistics of one fault case (in one network variant)."""

    case: str
    variant: str
    true_class: str
    n: int
    detections: int
    false_alarms: int
    correct_class: int
    latencies_h: list[float]
    show_variant: bool = False  # the campaign has more than one network variant
    detector: str = ""  # the gating network the detector watched
    base_variant: str = ""  # the campaign's variant (without the detector part for monitors)

    @property
    def faulted(self) -> bool:
        return self.true_class != "none"

    @property
    def rate(self) -> float:
        """Detection probability (faulted case) or false-alarm rate (nominal case)."""
        k = self.detections if self.faulted else self.false_alarms
        return k / self.n if self.n else float("nan")

    @property
    def interval(self) -> tuple[float, float]:
        return interval(self.detections if self.faulted else self.false_alarms, self.n)

    @property
    def label(self) -> str:
        return f"{self.case} [{self.variant}]" if self.variant and self.show_variant else self.case


def reading_order(keys: Iterable[str]) -> list[str]:
    """Cases in a reading order: nominal first, then by family and size small → large."""
    def key(c: str) -> tuple:
        fam, size = split_size(c)
        nominal = c in ("none", "no bias", "nominal") or c.startswith("no ")
        return (not nominal, fam, SIZES.index(size) if size else -1, c)

    return sorted(set(keys), key=key)


def cases(rows: list[dict]) -> list[str]:
    return reading_order(case_of(r) for r in rows)


def variants(rows: list[dict]) -> list[str]:
    seen: list[str] = []
    for r in rows:
        v = variant_of(r)
        if v not in seen:
            seen.append(v)
    return seen


def case_stats(rows: list[dict]) -> list[CaseStats]:
    """Detection statistics per (variant, fault case), over runs with a calibrated detector
    (each monitored network its own variant, :func:`detector_rows`)."""
    rows = [r for r in detector_rows(rows) if calibrated(r)]
    out = []
    several = len(variants(rows)) > 1
    for var in variants(rows):
        vrows = [r for r in rows if variant_of(r) == var]
        for case in cases(vrows):
            rs = [r for r in vrows if case_of(r) == case]
            tc = true_class(rs[0])
            out.append(CaseStats(
                case=case, variant=var, true_class=tc, n=len(rs),
                detections=sum(detected(r) for r in rs),
                false_alarms=sum(false_alarm(r) for r in rs),
                correct_class=sum(detected(r) and diagnosed_class(r) == true_class(r) for r in rs),
                latencies_h=[lat for r in rs if (lat := latency_h(r)) is not None],
                show_variant=several, detector=detector_of(rs[0]),
                base_variant=str(rs[0].get("base_variant", var)),
            ))
    return out


def detector_variants(rows: list[dict]) -> list[str]:
    """The variants as scored: one per detector (see :func:`detector_rows`)."""
    return variants([r for r in detector_rows(rows) if calibrated(r)])


def confusion(rows: list[dict], variant: str | None = None) -> tuple[tuple[str, ...], np.ndarray]:
    """Counts of (injected class, diagnosed class) over runs with a calibrated detector — of one
    scored variant (:func:`detector_variants`) if given; rows injected, columns diagnosed."""
    rows = [r for r in detector_rows(rows) if calibrated(r) and (variant is None or variant_of(r) == variant)]
    classes = list(ANOMALY_CLASSES)
    for r in rows:
        for c in (true_class(r), diagnosed_class(r)):
            if c not in classes:
                classes.append(c)
    idx = {c: i for i, c in enumerate(classes)}
    mat = np.zeros((len(classes), len(classes)), dtype=int)
    for r in rows:
        mat[idx[true_class(r)], idx[diagnosed_class(r)]] += 1
    return tuple(classes), mat


def networks(rows: list[dict]) -> list[str]:
    seen: list[str] = []
    for r in rows:
        for net in (r.get("gating") or {}):
            if net not in seen:
                seen.append(net)
    return seen


@dataclass
class MeanWeights:
    """Mean weight per filter per case for one network: ``mean[c, f]`` over the case's runs,
    ``std`` their spread, ``n`` the runs that had the network."""

    network: str
    variant: str
    cases: list[str]
    filters: list[str]
    mean: np.ndarray
    std: np.ndarray
    n: np.ndarray


def mean_weights(rows: list[dict], network: str, variant: str = "", which: str = "mean_weights") -> MeanWeights | None:
    """Mean of each run's ``gating.<network>.<which>`` per case (``which``: ``mean_weights`` —
    full arc, as Lubey & Ely 2022 Tables 3/4 — or ``mean_weights_after_onset``, falling back to the full
    arc for nominal runs, which have no onset)."""
    rs = [r for r in rows if variant_of(r) == variant and network in (r.get("gating") or {})]
    if not rs:
        return None
    case_list = cases(rs)
    filters: list[str] = []
    per_case: dict[str, list[dict[str, float]]] = {c: [] for c in case_list}
    for r in rs:
        g = r["gating"][network]
        w = g.get(which) or (g.get("mean_weights") if not is_faulted(r) else None)
        if not w:
            continue
        filters.extend(f for f in w if f not in filters)
        per_case[case_of(r)].append(w)
    if not filters:
        return None
    case_list = [c for c in case_list if per_case[c]]
    mean = np.full((len(case_list), len(filters)), np.nan)
    std = np.full_like(mean, np.nan)
    n = np.zeros(len(case_list), dtype=int)
    for i, c in enumerate(case_list):
        W = np.array([[w.get(f, np.nan) for f in filters] for w in per_case[c]], dtype=float)
        n[i] = len(W)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # a filter absent from every run of a case
            mean[i] = np.nanmean(W, axis=0)
            std[i] = np.nanstd(W, axis=0) if len(W) > 1 else 0.0
    return MeanWeights(network, variant, case_list, filters, mean, std, n)


WEIGHTS_DIR = "weights"
DAY_S = 86400.0


def kept_networks(camp: Campaign) -> list[str]:
    """Networks whose weight histories the campaign kept (``weights/<network>/<run id>.npz``)."""
    wdir = camp.path / WEIGHTS_DIR
    if not wdir.is_dir():
        return []
    return sorted(p.name for p in wdir.iterdir() if p.is_dir() and any(p.glob("*.npz")))


def load_history(camp: Campaign, network: str, run_id: str) -> RunWeights | None:
    """One run's stored weight history of ``network`` (None when absent or unreadable)."""
    path = camp.path / WEIGHTS_DIR / network / f"{run_id}.npz"
    if not path.is_file():
        return None
    try:
        return RunWeights.load(path)
    except (OSError, ValueError, KeyError):  # not a history (another writer's file, a cut copy)
        return None


def start_epoch(row: dict) -> float | None:
    """The run's scenario start epoch: the summary's ``t0``, else from the true onset and its day."""
    if row.get("t0") is not None:
        return float(row["t0"])
    a = row.get("anomaly") or {}
    if a.get("onset_true") is not None and a.get("onset_true_day") is not None:
        return float(a["onset_true"]) - float(a["onset_true_day"]) * DAY_S
    return None


@dataclass
class WeightHistory:
    """Weights vs day since scenario start of one network, per fault case, over seeds: each run's
    batch weights held until its next batch and sampled on a common grid; ``median``, ``p10``,
    ``p90`` are ``[case, time, filter]``; ``onset_day`` the median true onset per case (NaN when
    nominal); ``n`` the runs per case. ``origin`` names day 0: the scenario start, or — for rows
    that do not record it (summaries without ``t0`` and without a fault onset) — the first batch."""

    network: str
    scenario: str
    variant: str
    cases: list[str]
    filters: list[str]
    days: np.ndarray
    median: np.ndarray
    p10: np.ndarray
    p90: np.ndarray
    onset_day: np.ndarray
    n: np.ndarray
    origin: str = "scenario start"


def weight_history(camp: Campaign, network: str, scenario: str, variant: str = "", points: int = 400) -> WeightHistory | None:
    """The kept weight histories of ``network`` for one scenario and variant (None when no run of
    them kept one)."""
    rows = [r for r in camp.rows if cell_parts(r)["scenario"] == scenario and variant_of(r) == variant]
    runs: dict[str, list[tuple[np.ndarray, np.ndarray, list[str]]]] = {}
    onsets: dict[str, list[float]] = {}
    histories = [(r, h) for r in rows if (h := load_history(camp, network, str(r.get("id")))) is not None
                 and h.weights.size > 0]
    if not histories:
        return None
    # runs of one scenario share its start epoch: a row that does not record it borrows another's
    t0_common = next((t for r, _ in histories if (t := start_epoch(r)) is not None), None)
    origin = "scenario start"
    if t0_common is None:
        t0_common = min(float(h.t_s[0]) for _, h in histories)
        origin = "first gating batch"
    for r, h in histories:
        t0 = start_epoch(r)
        t0 = t0 if t0 is not None else t0_common
        case = case_of(r)
        runs.setdefault(case, []).append(((h.t_s - t0) / DAY_S, h.weights, list(h.filters)))
        od = (r.get("anomaly") or {}).get("onset_true_day")
        if od is not None:
            onsets.setdefault(case, []).append(float(od))
    filters: list[str] = []
    for hs in runs.values():
        for _, _, names in hs:
            filters.extend(f for f in names if f not in filters)
    end = max(float(d[-1]) for hs in runs.values() for d, _, _ in hs)
    days = np.linspace(0.0, end, points)
    case_list = [c for c in reading_order(runs)]
    shape = (len(case_list), points, len(filters))
    med, lo, hi = np.full(shape, np.nan), np.full(shape, np.nan), np.full(shape, np.nan)
    for ci, case in enumerate(case_list):
        stack = np.full((len(runs[case]), points, len(filters)), np.nan)
        for k, (d, w, names) in enumerate(runs[case]):
            idx = np.searchsorted(d, days, side="right") - 1  # the latest batch at each grid epoch
            valid = idx >= 0
            cols = [names.index(f) if f in names else None for f in filters]
            for fi, col in enumerate(cols):
                if col is not None:
                    stack[k, valid, fi] = w[idx[valid], col]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # grid epochs before any run's first batch
            med[ci], lo[ci], hi[ci] = np.nanpercentile(stack, [50.0, 10.0, 90.0], axis=0)
    onset = np.array([float(np.median(onsets[c])) if onsets.get(c) else np.nan for c in case_list])
    n = np.array([len(runs[c]) for c in case_list])
    return WeightHistory(network, scenario, variant, case_list, filters, days, med, lo, hi, onset, n, origin)


def scenarios(rows: list[dict]) -> list[str]:
    seen: list[str] = []
    for r in rows:
        s = cell_parts(r)["scenario"]
        if s not in seen:
            seen.append(s)
    return seen
