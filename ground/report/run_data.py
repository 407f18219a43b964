"""The arrays a run report plots, extracted once from a run's ICD messages.

Input is any iterable of ``(topic, message)`` pairs — the in-process runner's list, or
:func:`ground.mcap_io.reader.read_messages` (its 4-tuples end with the message, so they work as
is). Topics may carry the MCAP leading slash. Messages that did not decode (raw bytes, plain
JSON) or arrive on unknown topics are counted in :attr:`RunData.skipped`, never fatal.

Hierarchical gating networks (Chaer et al. 1998) publish the top-level bank weights g_i in
``FilterWeights.groups`` next to the products g_i·g_j|i; :func:`hierarchical_history` splits them
back into both levels, with the bank membership from the run's configuration
(:func:`hierarchy_groups_from_config`) or, without one, from the weights themselves.

Every trace is sorted by epoch, because a complete MCAP file is read in receive-time order, not
in simulated-time order. Position and clock errors compare an Estimate with the Truth of the same
epoch (the FSW's hourly estimate grid is contained in the truth cadence), matched on ``t_s``
rounded to 1 ms, so no interpolation enters the error.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal, NamedTuple, overload

import numpy as np

from fsw.interface import messages as m, topics
from ground.report.nav_data import BPlaneTrace, ResidualTrace, bplane_traces, residual_traces

DAY_S = 86400.0
#: Epoch matching resolution between Estimate and Truth (seconds): t_s rounded to 1 ms.
MATCH_DECIMALS = 3
#: Name of the onboard clock phase state in Estimate.state_names (seconds).
CLOCK_PHASE_STATE = "clock_phase"
#: Largest |Σ_{j in bank i} w_j − g_i| for a bank membership to describe the recorded weights.
BANK_SUM_TOL = 1.0e-6


@dataclass
class WeightTrace:
    """One gating network's weights over time; ``weights[k, i]`` is NaN if filter i was absent."""

    network: str
    filters: tuple[str, ...]
    t_s: np.ndarray
    weights: np.ndarray
    batch: np.ndarray


@dataclass
class ErrorTrace:
    """|estimate − truth| of one estimate stream at matched epochs, with its 1-sigma."""

    label: str
    t_s: np.ndarray
    error: np.ndarray
    sigma: np.ndarray
    unmatched: int = 0  # estimates with no truth at their epoch


@dataclass
class AnomalyTrace:
    """The detector's reports: statistic, threshold and flag over time, and its declarations."""

    network: str
    t_s: np.ndarray
    statistic: np.ndarray
    threshold: np.ndarray
    flag: np.ndarray
    declarations: list[m.AnomalyReport] = field(default_factory=list)  # first report of each rise of the flag
    reports: list[m.AnomalyReport] = field(default_factory=list)  # all of them, by epoch


class HierarchicalHistory(NamedTuple):
    """Both levels of a hierarchical gating network over time (Chaer et al. 1998 eqs. 2-3)."""

    t_s: np.ndarray  # (K,) epochs of the weight updates, TDB s, ascending
    banks: tuple[str, ...]  # B bank names
    top: np.ndarray  # (K, B) top-level weights g_i; NaN where a message lacks the bank
    in_bank: dict[str, np.ndarray]  # bank -> (K, n_b) in-bank weights g_j|i = w_ij / g_i (NaN if g_i = 0 or j absent)
    members: dict[str, tuple[str, ...]]  # bank -> its filters, the columns of in_bank[bank]
    network: str
    groups_from: Literal["given", "inferred", "unknown"]  # where the membership came from; 'unknown': in_bank is empty


@dataclass
class BudgetTrace:
    """Frame executive telemetry."""

    mode: str
    t_s: np.ndarray
    utilisation: np.ndarray
    backlog: np.ndarray
    deferred: np.ndarray
    processed: np.ndarray
    overruns: int
    errors: int


@dataclass
class RunData:
    """Everything the run plots and the run summary need."""

    t0: float
    weights: dict[str, WeightTrace] = field(default_factory=dict)
    position: dict[str, ErrorTrace] = field(default_factory=dict)
    clock: dict[str, ErrorTrace] = field(default_factory=dict)
    anomaly: AnomalyTrace | None = None
    budget: BudgetTrace | None = None
    measurements: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)  # kind -> (t_s, source)
    faults: list[m.FaultEvent] = field(default_factory=list)
    run_id: str | None = None
    filters: tuple[str, ...] = ()  # bank order (from the weights, else the estimate topics)
    status: dict[str, m.RunStatus] = field(default_factory=dict)  # source -> last RunStatus
    hierarchy: dict[str, HierarchicalHistory] = field(default_factory=dict)  # networks that publish bank weights
    rqp: list[m.RqpReport] = field(default_factory=list)  # RQP parameter adaptations, in time order
    residuals: dict[tuple[str, str], ResidualTrace] = field(default_factory=dict)  # (kind, source) -> pre-fit residuals
    bplane: dict[str, BPlaneTrace] = field(default_factory=dict)  # estimate label -> B-plane history with truth
    skipped: int = 0

    @overload
    def day(self, t_s: float) -> float: ...

    @overload
    def day(self, t_s: np.ndarray) -> np.ndarray: ...

    def day(self, t_s: np.ndarray | float) -> np.ndarray | float:
        """Days since the start of the run."""
        return (np.asarray(t_s, dtype=float) - self.t0) / DAY_S

    @property
    def fault_starts(self) -> list[m.FaultEvent]:
        return [e for e in self.faults if e.event == "start"]

    @property
    def onset_s(self) -> float | None:
        """True epoch of the first injected fault."""
        starts = self.fault_starts
        return min(e.t_s for e in starts) if starts else None

    @property
    def first_declaration(self) -> m.AnomalyReport | None:
        return self.anomaly.declarations[0] if self.anomaly is not None and self.anomaly.declarations else None


def declared_epoch(report: m.AnomalyReport) -> float:
    """When the flag was raised (the report's own epoch if it does not say)."""
    return report.declared_s if report.declared_s is not None else report.t_s


def _sorted(msgs: list, key=lambda x: x.t_s) -> list:
    return sorted(msgs, key=key)


def group_by_topic(messages: Iterable[Any]) -> tuple[dict[str, list], int]:
    """ICD messages by topic (no leading slash); the count of items that are not ICD messages."""
    by: dict[str, list] = defaultdict(list)
    skipped = 0
    for item in messages:
        topic, msg = str(item[0]).strip("/"), item[-1]
        try:
            expected = topics.type_of_topic(topic)
        except KeyError:
            skipped += 1
            continue
        if not isinstance(msg, expected):
            skipped += 1
            continue
        by[topic].append(msg)
    return by, skipped


def _weights(network: str, msgs: list[m.FilterWeights]) -> WeightTrace:
    msgs = _sorted(msgs, key=lambda x: (x.t_s, x.batch))
    names: list[str] = []
    for w in msgs:
        names.extend(f for f in w.filters if f not in names)
    col = {n: i for i, n in enumerate(names)}
    W = np.full((len(msgs), len(names)), np.nan)
    for k, w in enumerate(msgs):
        W[k, [col[f] for f in w.filters]] = w.weights
    return WeightTrace(network=network, filters=tuple(names), t_s=np.array([w.t_s for w in msgs], dtype=float),
                       weights=W, batch=np.array([w.batch for w in msgs], dtype=int))


def _weights_messages(source: Iterable[Any]) -> dict[str, list[m.FilterWeights]]:
    """FilterWeights by network from bare messages or (topic, …, message) items."""
    by: dict[str, list[m.FilterWeights]] = defaultdict(list)
    for item in source:
        if isinstance(item, m.FilterWeights):
            by[item.network].append(item)
            continue
        if not isinstance(item, (tuple, list)) or len(item) < 2 or not isinstance(item[-1], m.FilterWeights):
            continue
        topic = str(item[0]).strip("/")
        if topic.startswith(topics.FSW_WEIGHTS + "/"):
            by[topic.split("/", 2)[2]].append(item[-1])
    return by


def _infer_groups(W: np.ndarray, top: np.ndarray, filters: Sequence[str], banks: Sequence[str]) -> dict[str, tuple[str, ...]] | None:
    """The bank membership A (0/1, one bank per filter) with W·A = G, if the weights fix it uniquely.

    W has full column rank only when the filters' weight histories are linearly independent;
    then the least-squares A is the only membership, and rounding it must reproduce G."""
    finite = np.all(np.isfinite(top), axis=1)
    W, G = np.nan_to_num(W[finite]), top[finite]
    if W.shape[0] < W.shape[1] or np.linalg.matrix_rank(W) < W.shape[1]:
        return None
    A = np.linalg.lstsq(W, G, rcond=None)[0]
    bank = np.argmax(A, axis=1)
    onehot = np.zeros_like(A)
    onehot[np.arange(len(filters)), bank] = 1.0
    if np.max(np.abs(A - onehot)) > 1e-3 or np.max(np.abs(W @ onehot - G)) > BANK_SUM_TOL:
        return None
    return {b: tuple(f for f, k in zip(filters, bank) if k == i) for i, b in enumerate(banks)}


def hierarchical_history(messages_or_weights: Iterable[Any], groups: Mapping[str, Sequence[str]] | None = None, *,
                         network: str | None = None) -> HierarchicalHistory:
    """Top-level and in-bank weights of a hierarchical gating network over time (Chaer et al. 1998 eqs. 2-3).

    ``messages_or_weights``: FilterWeights messages, or ``(topic, …, message)`` items as
    :func:`extract` takes (other items are ignored). Only messages with non-empty ``groups`` count;
    ``network`` picks one when several networks publish them.

    The weight a hierarchical network publishes for filter j of bank i is w_ij = g_i·g_j|i, and
    ``groups[bank]`` of the message is g_i, so the in-bank weight is g_j|i = w_ij / g_i. ``groups``
    (bank -> filter names, e.g. ``fsw.gating[i].groups`` of the run's configuration) says which
    filters make up each bank; it must name the recorded banks and reproduce them:
    |Σ_{j in i} w_ij − g_i| ≤ :data:`BANK_SUM_TOL`. Without it (or when empty) the membership is
    inferred from the weights when they determine it uniquely, else ``in_bank`` is left empty
    (``groups_from == 'unknown'``) and only the top level is known.

    Raises ValueError without hierarchical messages, when several networks qualify and
    ``network`` is None, or when ``groups`` does not describe the recorded weights.
    """
    by = {net: ms for net, ms in _weights_messages(messages_or_weights).items() if any(w.groups for w in ms)}
    if network is None:
        if len(by) != 1:
            raise ValueError("no hierarchical gating weights (FilterWeights with groups)" if not by
                             else f"weights of several hierarchical networks {sorted(by)}: say which network")
        network = next(iter(by))
    if network not in by:
        raise ValueError(f"no hierarchical gating weights of network {network!r}")
    msgs = sorted((w for w in by[network] if w.groups), key=lambda x: (x.t_s, x.batch))
    trace = _weights(network, msgs)
    filters, W = trace.filters, trace.weights
    banks = list(dict.fromkeys(b for w in msgs for b in w.groups))
    given = {str(b): tuple(str(f) for f in fs) for b, fs in (groups or {}).items()}
    if given:
        if set(given) != set(banks):
            raise ValueError(f"banks {sorted(given)} do not match the recorded banks {sorted(banks)}")
        banks = list(given)
        listed = [f for fs in given.values() for f in fs]
        if len(set(listed)) != len(listed):
            raise ValueError("a filter is listed in more than one bank")
        unknown = sorted(set(listed) - set(filters))
        if unknown:
            raise ValueError(f"filters {unknown} of the banks never appear in the weights")
    top = np.array([[w.groups.get(b, np.nan) for b in banks] for w in msgs], dtype=float).reshape(len(msgs), len(banks))
    col = {f: i for i, f in enumerate(filters)}
    source: Literal["given", "inferred", "unknown"]
    if given:
        sums = np.stack([np.nansum(W[:, [col[f] for f in given[b]]], axis=1) for b in banks], axis=1)
        err = np.nanmax(np.abs(sums - top), initial=0.0)
        if err > BANK_SUM_TOL:
            raise ValueError(f"the banks do not reproduce the recorded bank weights (|Σ w − g| up to {err:.3g})")
        members, source = given, "given"
    else:
        inferred = _infer_groups(W, top, filters, banks)
        members, source = (inferred, "inferred") if inferred is not None else ({}, "unknown")
    in_bank: dict[str, np.ndarray] = {}
    for i, b in enumerate(banks):
        if b not in members:
            continue
        g = top[:, [i]]
        with np.errstate(invalid="ignore", divide="ignore"):
            in_bank[b] = np.where(g > 0, W[:, [col[f] for f in members[b]]] / g, np.nan)
    return HierarchicalHistory(t_s=trace.t_s, banks=tuple(banks), top=top, in_bank=in_bank,
                               members={b: members[b] for b in banks if b in members}, network=network,
                               groups_from=source)


def hierarchy_groups_from_config(config: str | Mapping[str, Any] | None) -> dict[str, dict[str, tuple[str, ...]]]:
    """Bank membership of every hierarchical network in a scenario configuration (``config.yaml``
    text or its parsed mapping): network -> bank -> filters, from ``fsw.gating[i].groups``.
    Networks without banks and anything unreadable are left out (the weights then speak for
    themselves), so a damaged or foreign file never stops a report."""
    if isinstance(config, str):
        # the text may come from a recorded MCAP: hostile input, parsed within the loader's limits
        from fsw.interface.yamlconfig import ConfigError, parse_yaml

        try:
            config = parse_yaml(config, "config.yaml")[0]
        except ConfigError:
            return {}
    fsw = config.get("fsw") if isinstance(config, Mapping) else None
    gating = fsw.get("gating") if isinstance(fsw, Mapping) else None
    out: dict[str, dict[str, tuple[str, ...]]] = {}
    for entry in gating if isinstance(gating, list) else []:
        if not isinstance(entry, Mapping) or not isinstance(entry.get("groups"), Mapping):
            continue
        groups = entry["groups"]
        if groups and all(isinstance(fs, list) and all(isinstance(f, str) for f in fs) for fs in groups.values()):
            out[str(entry.get("network"))] = {str(b): tuple(fs) for b, fs in groups.items()}
    return out


def hierarchy_means(h: HierarchicalHistory, split_s: float | None) -> dict[str, Any]:
    """Mean top-level and in-bank weights over the updates before ``split_s`` (e.g. the first fault
    onset) and from it on; the whole run under 'all'. A span without updates gives NaN."""
    spans = {"all": np.ones(h.t_s.shape, dtype=bool)}
    if split_s is not None:
        spans |= {"before": h.t_s < split_s, "after": h.t_s >= split_s}

    def mean(x: np.ndarray) -> float:
        x = x[np.isfinite(x)]
        return float(np.mean(x)) if x.size else float("nan")

    out: dict[str, Any] = {"split_s": split_s, "updates": {k: int(sel.sum()) for k, sel in spans.items()}}
    for k, sel in spans.items():
        out[f"top_{k}"] = {b: mean(h.top[sel, i]) for i, b in enumerate(h.banks)}
        out[f"in_bank_{k}"] = {b: {f: mean(h.in_bank[b][sel, j]) for j, f in enumerate(h.members[b])} for b in h.in_bank}
    return out


def _key(t_s: float) -> float:
    return round(float(t_s), MATCH_DECIMALS)


def _position_error(label: str, ests: list[m.Estimate], truth: dict[float, m.Truth]) -> ErrorTrace:
    t, err, sig = [], [], []
    unmatched = 0
    for e in ests:
        tr = truth.get(_key(e.t_s))
        if tr is None:
            unmatched += 1
            continue
        t.append(e.t_s)
        err.append(np.linalg.norm(np.subtract(e.position_km, tr.position_km)))
        sig.append(e.position_sigma_km)
    return ErrorTrace(label, np.array(t, dtype=float), np.array(err, dtype=float), np.array(sig, dtype=float), unmatched)


def _clock_error(label: str, ests: list[m.Estimate], truth: dict[float, m.Truth]) -> ErrorTrace | None:
    """Estimated clock phase minus the true one, for the estimates that carry a clock phase state
    (a 'best' stream switches between filters, so the state may come and go)."""
    t, err, sig = [], [], []
    unmatched = 0
    carried = False
    for e in ests:
        if CLOCK_PHASE_STATE not in e.state_names:
            continue
        carried = True
        tr = truth.get(_key(e.t_s))
        if tr is None:
            unmatched += 1
            continue
        i = e.state_names.index(CLOCK_PHASE_STATE)
        t.append(e.t_s)
        err.append(e.state[i] - tr.clock_phase_s)
        sig.append(e.sigma[i])
    if not carried:
        return None
    return ErrorTrace(label, np.array(t, dtype=float), np.array(err, dtype=float), np.array(sig, dtype=float), unmatched)


def _anomaly(reports: list[m.AnomalyReport]) -> AnomalyTrace:
    reports = _sorted(reports)
    decl: list[m.AnomalyReport] = []
    was = False
    for r in reports:
        if r.flag and not was:
            decl.append(r)
        was = r.flag
    return AnomalyTrace(
        network=next((r.network for r in reversed(reports) if r.network), ""),
        t_s=np.array([r.t_s for r in reports], dtype=float),
        statistic=np.array([r.statistic for r in reports], dtype=float),
        threshold=np.array([r.threshold for r in reports], dtype=float),
        flag=np.array([r.flag for r in reports], dtype=bool),
        declarations=decl,
        reports=reports,
    )


def _budget(reports: list[m.BudgetReport]) -> BudgetTrace:
    reports = _sorted(reports, key=lambda b: (b.t_s, b.frame))
    return BudgetTrace(
        mode=reports[-1].mode,
        t_s=np.array([b.t_s for b in reports], dtype=float),
        utilisation=np.array([b.utilisation for b in reports], dtype=float),
        backlog=np.array([b.backlog for b in reports], dtype=int),
        deferred=np.array([b.deferred for b in reports], dtype=int),
        processed=np.array([b.processed for b in reports], dtype=int),
        overruns=max(b.overruns for b in reports),
        errors=max(b.errors for b in reports),
    )


def _start_epoch(by: dict[str, list]) -> float:
    starts = [s.t_s for s in by.get(topics.SIM_STATUS, []) if s.state == "start"]
    if starts:
        return float(min(starts))
    for topic in (topics.SIM_TRUTH, topics.SIM_MEASUREMENTS):
        if by.get(topic):
            return float(min(x.t_s for x in by[topic]))
    epochs = [x.t_s for msgs in by.values() for x in msgs if hasattr(x, "t_s")]
    return float(min(epochs)) if epochs else 0.0


def extract(messages: Iterable[Any], *, t0: float | None = None,
            groups: Mapping[str, Mapping[str, Sequence[str]]] | None = None) -> RunData:
    """The arrays of a run; ``t0`` (TDB s) is day 0 of the plots (default: the simulator's start).

    ``groups``: network -> bank -> filters of the hierarchical networks (see
    :func:`hierarchy_groups_from_config`); a membership that does not fit the recorded weights
    is set aside for the one the weights imply."""
    by, skipped = group_by_topic(messages)
    data = RunData(t0=_start_epoch(by) if t0 is None else float(t0), skipped=skipped)
    for topic, msgs in sorted(by.items()):
        if topic.startswith(topics.FSW_WEIGHTS + "/"):
            trace = _weights(topic.split("/", 2)[2], msgs)
            data.weights[trace.network] = trace
            if any(w.groups for w in msgs):
                pairs = [(topic, w) for w in msgs]
                given = (groups or {}).get(trace.network)
                try:
                    data.hierarchy[trace.network] = hierarchical_history(pairs, given, network=trace.network)
                except ValueError:
                    data.hierarchy[trace.network] = hierarchical_history(pairs, None, network=trace.network)
    truth: dict[float, m.Truth] = {_key(t.t_s): t for t in by.get(topics.SIM_TRUTH, [])}
    estimate_labels = []
    for topic, msgs in by.items():
        if not topic.startswith(topics.FSW_ESTIMATE + "/"):
            continue
        label = topic.split("/", 2)[2]
        estimate_labels.append(label)
        ests = _sorted(msgs)
        if truth:
            data.position[label] = _position_error(label, ests, truth)
            clock = _clock_error(label, ests, truth)
            if clock is not None:
                data.clock[label] = clock
    if by.get(topics.FSW_ANOMALY):
        data.anomaly = _anomaly(by[topics.FSW_ANOMALY])
    data.residuals = residual_traces(by.get(topics.FSW_RESIDUALS, []))
    data.bplane = bplane_traces({t.split("/", 2)[2]: msgs for t, msgs in by.items() if t.startswith(topics.FSW_BPLANE + "/")},
                                by.get(topics.SIM_TRUTH, []))
    if by.get(topics.FSW_BUDGET):
        data.budget = _budget(by[topics.FSW_BUDGET])
    kinds: dict[str, list[m.Measurement]] = defaultdict(list)
    for meas in by.get(topics.SIM_MEASUREMENTS, []):
        kinds[meas.kind].append(meas)
    for kind in m.MEASUREMENT_KINDS:
        if kinds.get(kind):
            ms = _sorted(kinds[kind])
            data.measurements[kind] = (np.array([x.t_s for x in ms], dtype=float), np.array([x.source for x in ms], dtype=object))
    data.faults = _sorted(by.get(topics.SIM_FAULTS, []))
    data.rqp = _sorted(by.get(topics.FSW_RQP, []))
    for topic in (topics.SIM_STATUS, topics.FSW_STATUS, topics.GROUND_STATUS):
        for s in _sorted(by.get(topic, [])):
            data.status[s.source] = s
            data.run_id = data.run_id or s.run_id
    filters: list[str] = []
    for trace in data.weights.values():
        filters.extend(f for f in trace.filters if f not in filters)
    filters.extend(sorted(lb for lb in estimate_labels if lb not in filters and lb not in ("combined", "best")))
    data.filters = tuple(filters)
    return data
