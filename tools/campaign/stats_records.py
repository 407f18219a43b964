"""The campaign statistics as declared records: what ``stats.compute`` returns and the campaign's
``summary.json`` holds (the JSON form, key order included, is the one campaigns have always
written; :mod:`tools.campaign.report` renders it as Markdown)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

from fsw.interface import typed
from fsw.interface.typed import spec
from ground.report.json_record import JsonRecord

NOMINAL = "none"


@dataclass(frozen=True)
class Binomial(JsonRecord):
    """k successes in n trials, the rate and its Clopper–Pearson interval (None when n = 0)."""

    k: int = spec(doc="successes")
    n: int = spec(doc="trials")
    rate: float | None = spec(doc="k / n")
    ci: tuple[float, ...] | None = spec(doc="interval [low, high]", shape=(2,))


@dataclass(frozen=True)
class PoissonRate(JsonRecord):
    """k events over an exposure in days, the rate and its exact (Garwood) interval."""

    k: int = spec(doc="events")
    exposure_days: float = spec(doc="exposure", unit="d")
    per_day: float | None = spec(doc="k / exposure", unit="1/d")
    ci: tuple[float, ...] | None = spec(doc="interval [low, high]", unit="1/d", shape=(2,))


@dataclass(frozen=True)
class Spread(JsonRecord):
    """Values over runs: count, mean, median, extremes (and the total, for wall time)."""

    _omit_when_none: ClassVar[frozenset[str]] = frozenset({"total"})

    n: int = spec(doc="values")
    mean: float = spec(doc="mean")
    median: float = spec(doc="median")
    max: float = spec(doc="largest")
    min: float = spec(doc="smallest")
    total: float | None = spec(None, doc="sum")


@dataclass(frozen=True)
class Latency(JsonRecord):
    """Detection latencies in hours."""

    n: int = spec(doc="detections")
    median_h: float = spec(doc="median", unit="h")
    p90_h: float = spec(doc="90th percentile", unit="h")
    mean_h: float = spec(doc="mean", unit="h")
    min_h: float = spec(doc="smallest", unit="h")
    max_h: float = spec(doc="largest", unit="h")


@dataclass(frozen=True)
class FalseAlarms(JsonRecord):
    _omit_when_none: ClassVar[frozenset[str]] = frozenset({"note"})

    per_run: Binomial = spec(doc="runs with a false alarm / runs")
    per_day: PoissonRate | None = spec(doc="false alarms per day of exposure (nominal cases)")
    note: str | None = spec(None, doc="what counts as a false alarm here")


@dataclass(frozen=True)
class CellRuns(JsonRecord):
    planned: int | None = spec(doc="runs in the plan (None without a plan)")
    ok: int = spec(doc="successful runs")
    failed: int = spec(doc="failed runs")
    missing: int | None = spec(doc="planned runs without a row")


@dataclass(frozen=True)
class FailedRun(JsonRecord):
    id: str = spec(doc="run id")
    seed: int | None = spec(doc="seed")
    type: str | None = spec(doc="exception class")
    message: str | None = spec(doc="exception message")


@dataclass(frozen=True)
class CellDetector(JsonRecord):
    """The detector a cell's runs flew (empty for a planned cell whose plan does not say)."""

    _omit_when_none: ClassVar[frozenset[str]] = frozenset({"network", "calibrated"})

    network: str | None = spec(None, doc="gating network of the detector")
    calibrated: bool | None = spec(None, doc="the detector had a calibration")

    @property
    def can_declare(self) -> bool:
        return self.calibrated is not False


@dataclass(frozen=True)
class CellBudget(JsonRecord):
    max_utilisation: float | None = spec(doc="largest utilisation over the runs", unit="1")
    overruns_total: int = spec(doc="overruns summed over the runs")
    runs_with_overruns: int = spec(doc="runs with any overrun")
    final_backlog_max: int | None = spec(doc="largest final backlog")
    max_backlog: int | None = spec(doc="largest backlog")


@dataclass(frozen=True)
class NetworkWeights(JsonRecord):
    """A gating network's weights in a cell, per filter, averaged over its runs."""

    _omit_when_none: ClassVar[frozenset[str]] = frozenset({"mean", "after_onset", "final"})

    filters: tuple[str, ...] = spec(doc="filters, in the first run's order")
    n: int = spec(doc="runs that had the network")
    mean: dict[str, float] | None = spec(None, doc="mean of the runs' full-arc means")
    after_onset: dict[str, float] | None = spec(None, doc="mean of the runs' after-onset means")
    final: dict[str, float] | None = spec(None, doc="mean of the runs' final weights")


@dataclass(frozen=True)
class CellStats(JsonRecord):
    """The statistics of one cell (or, with monitors, of one detector of a cell)."""

    key: str = spec(doc="'scenario / fault / variant'")
    scenario: str = spec(doc="scenario name")
    fault: str = spec(doc="fault case")
    variant: str = spec(doc="variant (with monitors: '<variant> / <network>')")
    base_variant: str | None = spec(None, doc="the campaign's variant of a detector cell")
    monitor: bool | None = spec(None, doc="the detector is a monitor replayed on the runs")
    fault_class: str = spec(NOMINAL, doc="injected class")
    detector: CellDetector = spec(default_factory=CellDetector, doc="the detector")
    runs: CellRuns | None = spec(None, doc="run counts")
    failed: tuple[FailedRun, ...] = spec((), doc="the failed runs")
    seeds: tuple[int, ...] = spec((), doc="seeds of the successful runs")
    detection: Binomial | None = spec(None, doc="P_D (faulted cases)")
    false_alarm: FalseAlarms | None = spec(None, doc="false alarms")
    latency: Latency | None = spec(None, doc="detection latency (faulted cases)")
    characterization: Binomial | None = spec(None, doc="correct class among detections (faulted cases)")
    note: str | None = spec(None, doc="why there are no detection statistics")
    position_error_rms_km: dict[str, Spread | None] = spec(default_factory=dict, doc="per filter, over seeds",
                                                           unit="km")
    budget: CellBudget | None = spec(None, doc="budget over the runs")
    wall_time_s: Spread | None = spec(None, doc="wall time per run", unit="s")
    weights: dict[str, NetworkWeights] = spec(default_factory=dict, doc="per gating network")

    @property
    def nominal(self) -> bool:
        return self.fault_class == NOMINAL

    def _typed_encode(self, drop_defaults: bool) -> dict:
        # the detection block depends on the case: n/a without a calibration, false alarms first
        # for a nominal case, detection, false alarms, latency and class for a faulted one
        data = typed.encode(self, drop_defaults=drop_defaults)
        out: dict[str, Any] = {k: data[k] for k in ("key", "scenario", "fault", "variant")}
        out.update({k: data[k] for k in ("base_variant", "monitor") if data[k] is not None})
        out.update({k: data[k] for k in ("fault_class", "detector", "runs", "failed", "seeds")})
        if not self.detector.can_declare:
            out.update(detection=None, false_alarm=None, note=data["note"])
        elif self.nominal:
            out.update(false_alarm=data["false_alarm"], detection=None)
        else:
            out.update({k: data[k] for k in ("detection", "false_alarm", "latency", "characterization")})
        out.update({k: data[k] for k in ("position_error_rms_km", "budget", "wall_time_s", "weights")})
        return out


@dataclass(frozen=True)
class Confusion(JsonRecord):
    """Injected class (rows) against diagnosed class (columns) for one scenario and variant."""

    scenario: str = spec(doc="scenario")
    variant: str = spec(doc="variant")
    detector: str | None = spec(doc="detector network")
    true_classes: tuple[str, ...] = spec(doc="injected classes seen")
    diagnosed_classes: tuple[str, ...] = spec(doc="every class seen")
    matrix: dict[str, dict[str, int]] = spec(doc="true class -> diagnosed class -> runs")


@dataclass(frozen=True)
class WeightTableRow(JsonRecord):
    case: str = spec(doc="fault case")
    n: int = spec(doc="runs")
    mean: dict[str, float] | None = spec(doc="full-arc mean weight per filter")
    after_onset: dict[str, float] | None = spec(doc="after-onset mean weight per filter")


@dataclass(frozen=True)
class WeightTable(JsonRecord):
    """Mean weights of one network per fault case (Lubey & Ely 2022 Tables 3 and 4 layout)."""

    scenario: str = spec(doc="scenario")
    variant: str = spec(doc="variant")
    network: str = spec(doc="gating network")
    filters: tuple[str, ...] = spec(doc="columns")
    rows: tuple[WeightTableRow, ...] = spec(doc="one per fault case")


@dataclass(frozen=True)
class CampaignRuns(JsonRecord):
    planned: int | None = spec(doc="runs in the plan (None without a plan)")
    ok: int = spec(doc="successful runs")
    failed: int = spec(doc="failed runs")
    missing: int | None = spec(doc="planned runs without a row")
    stale_rows: int = spec(doc="rows of runs no longer in the plan")
    unreadable_lines: int = spec(doc="lines of runs.jsonl that are not rows")
    torn_tail: bool = spec(doc="runs.jsonl ends in a partial line")
    wall_time_s_total: float = spec(doc="run time summed over the runs", unit="s")


@dataclass(frozen=True)
class CampaignStats(JsonRecord):
    """A campaign's statistics (``summary.json`` of the campaign directory)."""

    campaign: str | None = spec(doc="campaign name")
    description: str = spec(doc="campaign description")
    generated_utc: str = spec(doc="when the statistics were computed")
    confidence_level: float = spec(doc="level of every interval", unit="1")
    runs: CampaignRuns = spec(doc="run counts")
    cells: tuple[CellStats, ...] = spec(doc="per cell")
    confusion: tuple[Confusion, ...] = spec(doc="per scenario and variant")
    weight_tables: tuple[WeightTable, ...] = spec(doc="per scenario, variant and network")
