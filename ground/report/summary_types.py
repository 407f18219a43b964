"""The run summary as declared records: what ``summarize`` returns and ``summary.json`` holds.

A campaign row carries the same record under ``summary``, with one more block, ``monitors``: the
anomaly block of every further detector replayed on the run's weights. The JSON form is the one
``navbank run`` has always written (key order included); :meth:`RunSummary.from_json` reads it
back, strictly.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar, Literal

from fsw.interface import typed
from fsw.interface.typed import spec
from ground.report.json_record import JsonRecord


@dataclass(frozen=True)
class ErrorRecord(JsonRecord):
    """An exception turned into data: a failed run, or a monitor that could not be evaluated."""

    _omit_when_none: ClassVar[frozenset[str]] = frozenset({"traceback"})

    type: str = spec(doc="exception class name")
    message: str = spec(doc="exception message")
    traceback: str | None = spec(None, doc="the last lines of the traceback")


@dataclass(frozen=True)
class FaultEventRecord(JsonRecord):
    """One injected fault starting or ending, as the run recorded it."""

    id: str = spec(doc="fault identifier within the scenario")
    type: str = spec(doc="fault type, e.g. 'optical-bias'")
    event: str = spec(doc="'start' or 'end'")
    t_s: float = spec(doc="event epoch, TDB seconds past J2000", unit="s")
    day: float = spec(doc="event epoch in days since the scenario start", unit="d")
    magnitude: dict[str, float] = spec(default_factory=dict, doc="fault parameters with units in their names")


@dataclass(frozen=True)
class FaultBlock(JsonRecord):
    """What was injected: the preset asked for, the class a perfect diagnosis gives, the events."""

    _json_keys: ClassVar[dict[str, str]] = {"fault_class": "class"}

    preset: str | None = spec(doc="the fault preset or case label of the run, None when none was asked for")
    fault_class: str = spec(doc="anomaly class of the first injected fault, 'none' without one")
    events: tuple[FaultEventRecord, ...] = spec(doc="fault events in time order")


@dataclass(frozen=True)
class MeasurementCounts(JsonRecord):
    _omit_when_none: ClassVar[frozenset[str]] = frozenset({"unprocessed"})

    published: int = spec(doc="measurements the simulator published")
    processed: int = spec(doc="measurements the FSW processed")
    rejected: int = spec(doc="measurements the FSW rejected")
    lost: int = spec(doc="measurements lost on the way")
    duplicates: int = spec(doc="duplicates the FSW dropped")
    reordered: int = spec(doc="measurements that arrived out of order")
    unprocessed: int | None = spec(None, doc="a stopped FSW: measurements delivered to it (taken or still in its "
                                   "input queue) but not processed when it stopped")


#: How a ``navbank run`` ended.
RunEnding = Literal["complete", "interrupted", "failed"]


@dataclass(frozen=True)
class CommandEntry(JsonRecord):
    """One telecommand the FSW served during the run."""

    _omit_when_none: ClassVar[frozenset[str]] = frozenset({"network", "filter", "param", "value"})

    t_s: float = spec(doc="FSW clock when served, TDB seconds past J2000", unit="s")
    day: float = spec(doc="days since the scenario start", unit="d")
    id: str = spec(doc="the sender's command id")
    command: str = spec(doc="the command, or 'malformed' for a payload that did not decode")
    ok: bool = spec(doc="carried out")
    error: str = spec("", doc="why it was rejected")
    network: str | None = spec(None, doc="gating network addressed")
    filter: str | None = spec(None, doc="filter addressed")
    param: str | None = spec(None, doc="parameter set")
    value: float | None = spec(None, doc="value set")


@dataclass(frozen=True)
class GatingEntry(JsonRecord):
    """One gating network's weights over the run, filter name -> weight."""

    _omit_when_none: ClassVar[frozenset[str]] = frozenset({"mean_weights_before_onset", "mean_weights_after_onset"})

    mean_weights: dict[str, float] = spec(doc="mean over the full arc")
    updates: int = spec(doc="FilterWeights messages of the network")
    mean_weights_before_onset: dict[str, float] | None = spec(None, doc="mean before the true fault onset")
    mean_weights_after_onset: dict[str, float] | None = spec(None, doc="mean from the true fault onset on")
    final_weights: dict[str, float] = spec(default_factory=dict, doc="the last weights")


@dataclass(frozen=True)
class AnomalyBlock(JsonRecord):
    """A detector's verdict on a run (:func:`ground.report.run_facts.anomaly_summary`)."""

    _json_keys: ClassVar[dict[str, str]] = {"anomaly_class": "class"}
    # written only for a declaration (first_class) and for a detection (latency_day)
    _omit_when_none: ClassVar[frozenset[str]] = frozenset({"first_class", "latency_day"})

    detector: bool = spec(doc="the run had a detector (it reported at least once)")
    declared: bool = spec(doc="an anomaly was declared")
    time: float | None = spec(doc="declaration epoch, TDB seconds past J2000", unit="s")
    time_day: float | None = spec(doc="declaration epoch in days since the scenario start", unit="d")
    onset_true: float | None = spec(doc="true onset of the first injected fault", unit="s")
    onset_true_day: float | None = spec(doc="true onset in days since the scenario start", unit="d")
    onset_estimate: float | None = spec(doc="the detector's onset estimate", unit="s")
    latency_s: float | None = spec(doc="declaration minus true onset, for a detection", unit="s")
    anomaly_class: str = spec(doc="the class the detector settled on, 'none' without a declaration")
    true_class: str = spec(doc="the injected class, 'none' without a fault")
    confidence: float = spec(doc="confidence in the class", unit="1")
    network: str | None = spec(doc="gating network the detector watched")
    false_alarm: bool = spec(doc="declared before the true onset, or with nothing injected")
    correct_class: bool | None = spec(doc="the class matches the injected one (None without a declaration)")
    final_flag: bool = spec(doc="the detector's flag at the end of the run")
    final_class: str = spec(doc="the detector's class at the end of the run")
    first_class: str | None = spec(None, doc="the class at the first declaration")
    latency_day: float | None = spec(None, doc="latency in days, for a detection", unit="d")

    @property
    def detected(self) -> bool:
        """Declared at or after the true onset."""
        return self.declared and not self.false_alarm

    @property
    def diagnosed(self) -> str:
        """The declared class, 'none' when nothing was declared."""
        return (self.anomaly_class or "unknown") if self.declared else "none"

    @property
    def first_diagnosis(self) -> str:
        """The class at the first declaration (the settled one for blocks that do not record it)."""
        return self.first_class if self.first_class is not None else self.anomaly_class


@dataclass(frozen=True)
class MonitorBlock:
    """A monitor's outcome in ``summary.monitors``: its anomaly block, or the error that kept it
    from being evaluated (JSON: the anomaly block itself, or ``{"error": {...}}``)."""

    anomaly: AnomalyBlock | None = None
    error: ErrorRecord | None = None

    @classmethod
    def _typed_decode(cls, data: Any, path: str) -> "MonitorBlock":
        if isinstance(data, dict) and set(data) == {"error"}:
            return cls(error=ErrorRecord._typed_decode(data["error"], f"{path}.error"))
        return cls(anomaly=AnomalyBlock._typed_decode(data, path))

    def _typed_encode(self, drop_defaults: bool) -> dict:
        if self.error is not None:
            return {"error": self.error._typed_encode(drop_defaults)}
        assert self.anomaly is not None  # a monitor block holds its anomaly block or its error
        return self.anomaly._typed_encode(drop_defaults)

    @classmethod
    def _typed_schema(cls) -> dict:
        return {"anyOf": [typed.json_schema(AnomalyBlock, top=False),
                          {"type": "object", "properties": {"error": typed.json_schema(ErrorRecord, top=False)},
                           "required": ["error"], "additionalProperties": False}]}


@dataclass(frozen=True)
class BudgetBlock(JsonRecord):
    """The frame executive over the run (from its BudgetReports)."""

    _omit_when_none: ClassVar[frozenset[str]] = frozenset({"stage_cpu_us"})

    frames: int = spec(doc="frames run")
    reports: int = spec(doc="BudgetReports received")
    overruns: int = spec(doc="items that exceeded the remaining budget")
    max_utilisation: float = spec(doc="largest used / budget of a frame", unit="1")
    mean_utilisation_busy: float = spec(doc="mean utilisation of the frames that processed something", unit="1")
    max_backlog: int = spec(doc="largest backlog at a frame end")
    final_backlog: int = spec(doc="backlog at the last frame end")
    errors: int = spec(doc="work items that raised")
    mode: str | None = spec(doc="budget accounting mode, None without reports")
    stage_cpu_us: dict[str, float] | None = spec(
        None, doc="budget mode cpu: CPU per processed measurement spent in each stage label, from the FSW's last "
                  "RunStatus (where the FSW core's CPU goes); None in mode work-units or without a status", unit="us")


@dataclass(frozen=True)
class BPlaneEntry(JsonRecord):
    """B-plane targeting of one solution at its last B-plane epoch (Mars mean equator)."""

    t_s: float = spec(doc="epoch, TDB seconds past J2000", unit="s")
    b_dot_r_km: float = spec(doc="B·R", unit="km")
    b_dot_t_km: float = spec(doc="B·T", unit="km")
    b_dot_r_sigma_km: float = spec(doc="1-sigma of B·R", unit="km")
    b_dot_t_sigma_km: float = spec(doc="1-sigma of B·T", unit="km")
    b_dot_r_error_km: float | None = spec(doc="B·R minus the truth's (null without truth)", unit="km")
    b_dot_t_error_km: float | None = spec(doc="B·T minus the truth's (null without truth)", unit="km")
    periapsis_error_s: float | None = spec(doc="closest-approach epoch minus the truth's", unit="s")
    periapsis_sigma_s: float = spec(doc="1-sigma of the closest-approach epoch", unit="s")


@dataclass(frozen=True)
class NisEntry(JsonRecord):
    """Normalised innovation squared of one filter on one measurement kind."""

    count: int = spec(doc="measurements of the kind the filter processed")
    dimension: int = spec(doc="measurement dimension n: the expected mean NIS")
    mean_nis: float = spec(doc="mean NIS", unit="1")
    outside_95: float = spec(doc="fraction outside the two-sided 95 % chi-square(n) bounds", unit="1")


@dataclass(frozen=True)
class RunFiles(JsonRecord):
    mcap: str = spec(doc="the run's MCAP recording")
    config: str = spec(doc="the run's exact configuration")


@dataclass(frozen=True)
class RestartEntry(JsonRecord):
    """One restart of a supervised process during a ``navbank run``."""

    _omit_when_none: ClassVar[frozenset[str]] = frozenset({"checkpoint_measurements", "checkpoint_t_s", "checkpoint_day",
                                                           "resent"})

    process: str = spec(doc="the process restarted (fsw)")
    exit_code: int = spec(doc="how the process ended (negative: killed by that signal number)")
    at_unix_s: float = spec(doc="wall-clock time the launcher saw it end, Unix seconds", unit="s")
    at_wall_s: float = spec(doc="seconds into the run", unit="s")
    checkpoint_measurements: int | None = spec(None, doc="measurements its checkpoint had taken: the restart went on after them")
    checkpoint_t_s: float | None = spec(None, doc="mission time of the checkpoint's newest measurement, TDB s past J2000", unit="s")
    checkpoint_day: float | None = spec(None, doc="the same as days since the scenario start", unit="d")
    resent: int | None = spec(None, doc="measurements the simulator sent again to the restarted FSW (from its status)")


@dataclass(frozen=True)
class SegmentEntry(JsonRecord):
    """One segment of a recording whose logger was restarted (merged into the run's MCAP file):
    between one segment's last message and the next one's first, nothing was recorded."""

    _omit_when_none: ClassVar[frozenset[str]] = frozenset({"first_log_unix_s", "last_log_unix_s"})

    file: str = spec(doc="the segment file")
    messages: int = spec(doc="messages it holds")
    complete: bool = spec(doc="its logger finished it (false: the logger died; read up to its last complete chunk)")
    first_log_unix_s: float | None = spec(None, doc="receive time of its first message, Unix seconds", unit="s")
    last_log_unix_s: float | None = spec(None, doc="receive time of its last message, Unix seconds", unit="s")


@dataclass(frozen=True)
class RestartsBlock(JsonRecord):
    """Restarts of a ``navbank run`` and what they cost: what was sent or published twice (the
    logger recorded it once and dropped the repeat) and what was never recorded."""

    events: tuple[RestartEntry, ...] = spec(doc="each restart, in order")
    duplicates_dropped: dict[str, int] = spec(doc="per topic: messages received again after a restart, recorded once")
    gaps: dict[str, int] = spec(doc="per topic: publisher sequence numbers never recorded (lost)")
    segments: tuple[SegmentEntry, ...] = spec(default_factory=tuple, doc="the recording's segments, if the logger was restarted")


@dataclass(frozen=True)
class RunSummary(JsonRecord):
    """Every number ``navbank run`` prints and writes to ``summary.json``."""

    # monitors: campaign runs with monitors; run_id and files: summaries of ``navbank run``;
    # commands: runs that were commanded; status, reason: summaries of ``navbank run``
    _omit_when_none: ClassVar[frozenset[str]] = frozenset({"monitors", "run_id", "files", "commands", "status", "reason",
                                                           "restarts", "refused", "bplane", "nis"})

    scenario: str = spec(doc="scenario name")
    seed: int = spec(doc="random seed of the run")
    t0: float = spec(doc="scenario start epoch, TDB seconds past J2000", unit="s")
    fault: FaultBlock = spec(doc="what was injected")
    measurements: MeasurementCounts = spec(doc="measurement counts")
    filters: tuple[str, ...] = spec(doc="the bank's filters, in the order they reported")
    gating: dict[str, GatingEntry] = spec(doc="per gating network")
    anomaly: AnomalyBlock = spec(doc="the onboard detector's verdict")
    position_error_rms_km: dict[str, float] = spec(
        doc="RMS position error against truth over the run, per filter and for 'combined' (the gating-weighted "
        "sum of the enabled filters, weights of the detector's network) and 'best' (the filter navigated on: "
        "smallest RTPC until an anomaly is declared, then the highest-weighted)", unit="km")
    position_error_final_km: dict[str, float] = spec(doc="per solution (as above), at the last estimate", unit="km")
    position_within_3sigma: dict[str, float] = spec(
        doc="per solution, fraction of estimates whose position error is at most 3 RTPC", unit="1")
    budget: BudgetBlock = spec(doc="the frame executive")
    wall_time_s: float | None = spec(doc="wall-clock time of the run", unit="s")
    monitors: dict[str, MonitorBlock] | None = spec(None, doc="further detectors replayed on the run, per network")
    run_id: str | None = spec(None, doc="the run's id")
    files: RunFiles | None = spec(None, doc="the run's files")
    commands: tuple[CommandEntry, ...] | None = spec(None, doc="telecommands the FSW served, in order")
    refused: dict[str, int] | None = spec(
        None, doc="attempts the FSW refused for failed authentication, from its final counters: 'telecommands' "
                  "(listed on /fsw/commands, not among the commands served) and 'statuses' (forged end-of-run "
                  "statuses and drain queries); runs over Zenoh only")
    status: RunEnding | None = spec(
        None, doc="how the run ended: complete; interrupted (SIGINT/SIGTERM); failed (a process failed, time ran out)")
    reason: str | None = spec(None, doc="why it did not complete, in one line")
    restarts: RestartsBlock | None = spec(None, doc="supervised restarts of a ``navbank run`` (written when restarts were enabled)")
    bplane: dict[str, BPlaneEntry] | None = spec(None, doc="B-plane targeting per solution at the last B-plane epoch")
    nis: dict[str, dict[str, NisEntry]] | None = spec(None, doc="NIS statistics per measurement kind and filter")
