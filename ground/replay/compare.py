"""Compare re-run FSW telemetry with the recorded telemetry, topic by topic and field by field.

Messages of a topic are paired in publication order (the recording is ordered by the publisher
sequence number the logger stored). Each message is flattened to ``field -> value`` leaves:
numbers and booleans (a flag counts as 0/1) give an absolute difference and a relative one,
|a − b| / max(|a|, |b|) (a number agrees within a tolerance T and a relative tolerance ρ when
|a − b| ≤ T or |a − b| ≤ ρ max(|a|, |b|)); strings and nulls
(an anomaly class, an absent onset time) give a mismatch when unequal; lists of different
lengths or a value present on one side only give a structural mismatch. List indices are folded
into the field name (``weights``, ``state``, ``sigma``), mapping keys are kept
(``counts.processed``, ``evidence.radio``), so the table has one row per meaningful field.

Status messages are the exception to "present on one side only is a mismatch": the FSW process
adds transport counters to its statuses (malformed telecommands, refused topics, transport
gaps), which an in-process re-run does not have; such keys are listed, not compared. The same
holds for the counters in the replies to ``status`` telecommands in the command records. A
status's authentication tag (``auth``) is the transport's too — a fresh nonce for every status
of an authenticated run, none in a re-run — and is left out of the comparison.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any

from fsw.astro.time import TimeError, tdb_to_utc_iso
from fsw.interface import codec, topics

_INDEX = re.compile(r"\[\d+\]")
STATUS_TOPICS = {topics.mcap_topic(topics.FSW_STATUS)}
COMMAND_TOPICS = {topics.mcap_topic(topics.FSW_COMMANDS)}


@dataclass
class FieldDiff:
    """Worst difference of one field of one topic."""

    max_abs: float = 0.0
    max_rel: float = 0.0  # largest |a − b| / max(|a|, |b|)
    outside: int = 0  # numeric leaves outside both the tolerance and the relative tolerance
    compared: int = 0  # leaves compared
    mismatches: int = 0  # unequal strings/nulls, shape differences, one-sided values
    worst_index: int = -1  # message index of max_abs (or of the first mismatch)
    worst_t_s: float | None = None
    example: str = ""  # first mismatch, e.g. "'none' vs 'optical-measurement'"
    worst_rel_index: int = -1  # message index of max_rel
    worst_rel_t_s: float | None = None


@dataclass
class TopicDiff:
    topic: str
    recorded: int
    rerun: int
    compared: bool = True  # False: counts only (e.g. budget reports in CPU mode)
    note: str = ""
    fields: dict[str, FieldDiff] = field(default_factory=dict)
    one_sided: set[str] = field(default_factory=set)  # status keys present on one side only
    rtol: float = 0.0  # the relative tolerance ``outside`` was counted with (0: none)

    @property
    def max_abs(self) -> float:
        return max((f.max_abs for f in self.fields.values()), default=0.0)

    @property
    def max_rel(self) -> float:
        return max((f.max_rel for f in self.fields.values()), default=0.0)

    @property
    def mismatches(self) -> int:
        return sum(f.mismatches for f in self.fields.values())

    def worst_field(self) -> str:
        if not self.fields:
            return ""
        name, f = max(self.fields.items(), key=lambda kv: (kv[1].mismatches > 0, kv[1].max_abs))
        return name if (f.max_abs > 0 or f.mismatches) else ""

    def identical(self, tolerance: float) -> bool:
        """Same counts, no mismatch, every number within ``tolerance`` — or, when the topic was
        compared with a relative tolerance, within either of the two (counted leaf by leaf)."""
        if not self.compared:
            return True
        if self.recorded != self.rerun or self.mismatches:
            return False
        if self.rtol > 0.0:
            return all(f.outside == 0 for f in self.fields.values())
        return self.max_abs <= tolerance


@dataclass
class Comparison:
    topics: dict[str, TopicDiff]
    tolerance: float
    rtol: float = 0.0

    @property
    def identical(self) -> bool:
        return all(t.identical(self.tolerance) for t in self.topics.values())

    def largest(self, n: int = 10) -> list[tuple[str, str, FieldDiff]]:
        """The ``n`` worst (topic, field, diff), mismatches first, then by absolute difference."""
        rows = [(t.topic, name, f) for t in self.topics.values() if t.compared for name, f in t.fields.items()
                if f.mismatches or f.max_abs > 0]
        if self.rtol > 0.0:
            rows.sort(key=lambda r: (r[2].mismatches > 0, r[2].outside > 0, r[2].max_rel), reverse=True)
        else:
            rows.sort(key=lambda r: (r[2].mismatches > 0, r[2].max_abs), reverse=True)
        return rows[:n]

    def to_dict(self) -> dict:
        return {
            "identical": self.identical,
            "tolerance": self.tolerance,
            "rtol": self.rtol,
            "topics": {
                name: {
                    "recorded": t.recorded, "rerun": t.rerun, "compared": t.compared, "note": t.note,
                    "max_abs": t.max_abs, "max_rel": t.max_rel, "mismatches": t.mismatches,
                    "one_sided": sorted(t.one_sided),
                    "fields": {k: {"max_abs": f.max_abs, "max_rel": f.max_rel, "outside": f.outside,
                                   "compared": f.compared, "mismatches": f.mismatches,
                                   "worst_index": f.worst_index, "worst_t_s": f.worst_t_s, "example": f.example,
                                   "worst_rel_index": f.worst_rel_index, "worst_rel_t_s": f.worst_rel_t_s}
                               for k, f in sorted(t.fields.items())},
                }
                for name, t in sorted(self.topics.items())
            },
        }


def flatten(data: Any, prefix: str = "", out: dict[str, Any] | None = None) -> dict[str, Any]:
    """JSON-like data as ``path -> leaf`` (``a.b[2].c``); empty lists/maps are leaves."""
    out = {} if out is None else out
    if isinstance(data, dict) and data:
        for k, v in data.items():
            flatten(v, f"{prefix}.{k}" if prefix else str(k), out)
    elif isinstance(data, (list, tuple)) and data:
        for i, v in enumerate(data):
            flatten(v, f"{prefix}[{i}]", out)
    else:
        out[prefix] = list(data) if isinstance(data, tuple) else data
    return out


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, str)


def _leaf_diff(a: Any, b: Any) -> float | None:
    """|a − b| for numbers/booleans, None when the pair is categorical."""
    if _is_number(a) and _is_number(b):
        d = abs(float(a) - float(b))
        return d if math.isfinite(d) else math.inf
    return None


def _without_tag(topic: str, data: Any) -> Any:
    if topic in STATUS_TOPICS and isinstance(data, dict) and "auth" in data:
        return {k: v for k, v in data.items() if k != "auth"}
    return data


def compare_messages(topic: str, recorded: list[Any], rerun: list[Any], *, compared: bool = True,
                     note: str = "", tolerance: float = 0.0, rtol: float = 0.0) -> TopicDiff:
    """Pairwise comparison of two message lists of one topic (ICD messages or JSON dicts);
    ``tolerance`` and ``rtol`` decide which numbers count as ``outside``."""
    td = TopicDiff(topic, len(recorded), len(rerun), compared=compared, note=note, rtol=rtol)
    if not compared:
        return td
    counters = "counts." if topic in STATUS_TOPICS else "reply.status." if topic in COMMAND_TOPICS else None
    for i, (ra, rb) in enumerate(zip(recorded, rerun)):
        da = flatten(_without_tag(topic, ra if isinstance(ra, dict) else codec.to_dict(ra)))
        db = flatten(_without_tag(topic, rb if isinstance(rb, dict) else codec.to_dict(rb)))
        t_s = da.get("t_s") if _is_number(da.get("t_s")) else None
        # the recorded message's field order, then what only the re-run has: a set's order would
        # change with the string hash seed from one process to the next, and with it which of two
        # fields of equal difference a report names as the worst
        for path in [*da, *(p for p in db if p not in da)]:
            name = _INDEX.sub("", path)
            if path not in da or path not in db:
                if counters is not None and name.startswith(counters):
                    td.one_sided.add(f"{name[len(counters):]} (only {'recorded' if path in da else 're-run'})")
                    continue
                fd = td.fields.setdefault(name, FieldDiff())
                fd.mismatches += 1
                if not fd.example:
                    fd.worst_index, fd.worst_t_s = i, t_s
                    fd.example = f"{path} only in {'recorded' if path in da else 're-run'}"
                continue
            a, b = da[path], db[path]
            fd = td.fields.setdefault(name, FieldDiff())
            fd.compared += 1
            d = _leaf_diff(a, b)
            if d is None:
                if a != b:
                    fd.mismatches += 1
                    if not fd.example:
                        fd.example = f"{_shown(name, a)} vs {_shown(name, b)}"[:100]
                        if fd.max_abs == 0.0:
                            fd.worst_index, fd.worst_t_s = i, t_s
            else:
                scale = max(abs(float(a)), abs(float(b)))
                rel = d / scale if d > 0.0 else 0.0
                if d > tolerance and not d <= rtol * scale:
                    fd.outside += 1
                if rel > fd.max_rel:
                    fd.max_rel = rel
                    fd.worst_rel_index, fd.worst_rel_t_s = i, t_s
                if d > fd.max_abs:
                    fd.max_abs = d
                    if not fd.mismatches:
                        fd.worst_index, fd.worst_t_s = i, t_s
    return td


#: Fields that hold an epoch (TDB seconds past J2000): examples show them as UTC dates.
EPOCH_FIELDS = frozenset({"t_s", "onset_s", "declared_s"})


def _shown(name: str, value: Any) -> str:
    if name.rsplit(".", 1)[-1] in EPOCH_FIELDS and _is_number(value):
        try:
            return tdb_to_utc_iso(float(value), 0)
        except (TimeError, ValueError):
            pass
    return repr(value)


def compare_runs(recorded: dict[str, list[Any]], rerun: dict[str, list[Any]], *, tolerance: float = 0.0,
                 rtol: float = 0.0, counts_only: dict[str, str] | None = None) -> Comparison:
    """Compare every topic of either side; ``counts_only`` maps topics to the reason they are not compared."""
    counts_only = counts_only or {}
    out = {}
    for topic in sorted(recorded.keys() | rerun.keys()):
        reason = counts_only.get(topic)
        out[topic] = compare_messages(topic, recorded.get(topic, []), rerun.get(topic, []),
                                      compared=reason is None, note=reason or "", tolerance=tolerance, rtol=rtol)
    return Comparison(out, tolerance, rtol)
