"""The ICD: every message navbank's processes exchange, declared once.

Conventions used by every message:

* ``t_s`` — simulation epoch, TDB seconds past J2000 (the time axis of every plot and test).
* ``timestamp`` — the same instant as Foxglove-style ``{sec, nsec}`` since the Unix epoch (UTC),
  so Foxglove's "header stamp" plot mode shows mission time.
* Positions are Mars-centred ICRF/EME2000 in km, velocities km/s, unless a field says otherwise.
* Measurement kinds, with the unit and dimension of their values, are declared in
  :mod:`fsw.interface.kinds`.

Each class carries ``SCHEMA_VERSION``; :mod:`fsw.interface.codec` encodes/decodes them and
generates their JSON Schemas from these declarations.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal, get_args

from fsw.interface import kinds
from fsw.interface.frozen import fast_init
from fsw.interface.typed import spec

SCHEMA_VERSION = 1

# The kinds are declared in fsw.interface.kinds; the Literal that makes decoding and the JSON
# Schema enumerate them is built from that declaration. A type checker cannot follow a Literal
# built at run time, so for it a kind is a plain string.
if TYPE_CHECKING:
    MeasurementKind = str
else:
    MeasurementKind = Literal[kinds.NAMES]
MEASUREMENT_KINDS: tuple[str, ...] = kinds.NAMES
#: Dimension n_j of each kind (None: any, given by the scenario).
MEASUREMENT_DIMENSION: dict[str, int | None] = {k.name: k.dimension for k in kinds.DECLARED}

AnomalyClass = Literal["none", "optical-measurement", "radiometric-measurement", "dynamics", "unknown"]
ANOMALY_CLASSES: tuple[str, ...] = get_args(AnomalyClass)

#: Size limits, enforced by the decoder before it looks at a single element: a message the ICD
#: accepts is bounded in size, so decoding any payload takes bounded time (a 10⁶-element value
#: would otherwise occupy the FSW's thread while telecommands wait).
NAME_CHARS = 128  # identifiers: filters, networks, stations, targets, faults, run and command ids
TEXT_CHARS = 4096  # free text: errors, status messages, textual status
MAX_FILTERS = 64  # filters of a bank, and so every per-filter list or mapping
MAX_STATES = 64  # components of a state vector
MAX_COMPONENTS = 64  # components of one measurement value
MAX_COUNTERS = 1024  # entries of a counter or status mapping

RunState = Literal["start", "running", "end-of-run", "error"]

TelecommandName = Literal["reset-gating", "enable-filter", "disable-filter", "set-param", "status", "set-rqp"]
TELECOMMANDS: tuple[str, ...] = get_args(TelecommandName)


@fast_init
@dataclass(frozen=True, slots=True)
class Stamp:
    """Foxglove-style time: seconds and nanoseconds since the Unix epoch (UTC)."""

    sec: int = spec(doc="whole seconds since 1970-01-01T00:00:00Z", ge=0)
    nsec: int = spec(doc="nanoseconds within the second", ge=0, lt=1_000_000_000)

    @classmethod
    def from_unix(cls, unix_s: float) -> "Stamp":
        # floor and round give ints (of a numpy float too, numpy >= 2); the fields passed by
        # position: this stamps ~2 messages per measurement
        sec = math.floor(unix_s)
        nsec = round((unix_s - sec) * 1e9)
        if nsec >= 1_000_000_000:
            sec, nsec = sec + 1, nsec - 1_000_000_000
        return cls(sec if sec > 0 else 0, nsec)

    def to_unix(self) -> float:
        return self.sec + self.nsec * 1e-9

    def to_ns(self) -> int:
        return self.sec * 1_000_000_000 + self.nsec


@fast_init
@dataclass(frozen=True, slots=True)
class Measurement:
    """One measurement as the spacecraft receives it (sim → fsw)."""

    seq: int = spec(doc="sequence number, 0-based, strictly increasing per run", ge=0)
    t_s: float = spec(doc="time tag read on the onboard clock at reception, TDB seconds past J2000", unit="s")
    timestamp: Stamp = spec(doc="time tag as Unix time (Foxglove header stamp)")
    kind: MeasurementKind = spec(doc="measurement type")
    source: str = spec(max_length=NAME_CHARS, doc="DSN station (range/doppler, e.g. 'DSS-14'), optical target ('mars', 'phobos', 'deimos' or an asteroid beacon, e.g. 'vesta'), or a scenario label")
    value: tuple[float, ...] = spec(max_items=MAX_COMPONENTS, doc="observed value: range km; doppler km/s range-rate; optical [sample, line] pixel")
    sigma: tuple[float, ...] = spec(max_items=MAX_COMPONENTS, doc="1-sigma noise of each component, same units as value")
    attitude_q: tuple[float, ...] | None = spec(
        None, doc="optical only: camera-to-ICRF attitude quaternion as known onboard, scalar first [w, x, y, z]", shape=(4,)
    )
    count_time_s: float | None = spec(None, doc="doppler only: count interval ending at t_s", unit="s", gt=0)

    def __post_init__(self) -> None:
        if len(self.value) == 0:
            raise ValueError("value must not be empty")
        if len(self.sigma) != len(self.value):
            raise ValueError(f"sigma has {len(self.sigma)} components, value has {len(self.value)}")
        declared = kinds.BY_NAME.get(self.kind)
        want = None if declared is None else declared.dimension
        if want is not None and len(self.value) != want:
            raise ValueError(f"a {self.kind} measurement has {want} component(s), got {len(self.value)}")
        for s in self.sigma:  # a loop, not any() over a generator: every measurement passes here
            if s <= 0.0:
                raise ValueError("sigma components must be > 0")
        if declared is not None:
            for name in declared.requires:
                if getattr(self, name) is None:
                    raise ValueError(f"a measurement of kind {self.kind} needs {name}")


@fast_init
@dataclass(frozen=True, slots=True)
class Truth:
    """True spacecraft and clock state (sim → ground only; the FSW never subscribes to it)."""

    t_s: float = spec(doc="true epoch, TDB seconds past J2000", unit="s")
    timestamp: Stamp = spec(doc="epoch as Unix time")
    position_km: tuple[float, ...] = spec(doc="ICRF position from the central body (Mars; the Earth in Earth-orbit scenarios)", unit="km", shape=(3,))
    velocity_km_s: tuple[float, ...] = spec(doc="ICRF velocity relative to the central body (Mars; the Earth in Earth-orbit scenarios)", unit="km/s", shape=(3,))
    clock_phase_s: float = spec(doc="onboard clock phase error (clock reading minus TDB)", unit="s")
    clock_frequency: float = spec(doc="onboard clock fractional frequency error", unit="1")
    clock_drift_per_s: float = spec(doc="onboard clock fractional frequency drift", unit="1/s")
    srp_scale: float = spec(1.0, doc="true solar-radiation-pressure scale factor", unit="1")
    acs_accel_km_s2: tuple[float, ...] = spec((0.0, 0.0, 0.0), doc="true attitude-thruster acceleration, ICRF", unit="km/s^2", shape=(3,))
    active_faults: tuple[str, ...] = spec((), max_items=MAX_COUNTERS, max_length=NAME_CHARS, doc="identifiers of the faults active at t_s")


@fast_init
@dataclass(frozen=True, slots=True)
class FaultEvent:
    """A fault starting or ending (sim → ground), so campaigns can score detection."""

    t_s: float = spec(doc="event epoch, TDB seconds past J2000", unit="s")
    timestamp: Stamp = spec(doc="epoch as Unix time")
    fault_id: str = spec(max_length=NAME_CHARS, doc="identifier of the fault within the scenario")
    fault_type: str = spec(max_length=NAME_CHARS, doc="fault type, e.g. 'optical-bias', 'range-bias', 'clock-bias', 'thruster-mismodel'")
    event: Literal["start", "end"] = spec(doc="whether the fault starts or ends")
    fault_class: AnomalyClass = spec(doc="the anomaly class a perfect diagnosis would give")
    magnitude: dict[str, float] = spec(default_factory=dict, max_items=MAX_COUNTERS, max_length=NAME_CHARS, doc="fault parameters with units in their names")


@fast_init
@dataclass(frozen=True, slots=True)
class FilterWeights:
    """Weights of one gating network after one batch (fsw → ground)."""

    t_s: float = spec(doc="epoch of the last measurement in the batch, TDB seconds past J2000", unit="s")
    timestamp: Stamp = spec(doc="epoch as Unix time")
    network: str = spec(max_length=NAME_CHARS, doc="gating network name, e.g. 'chi2'")
    batch: int = spec(doc="batch index, 0-based", ge=0)
    filters: tuple[str, ...] = spec(max_items=MAX_FILTERS, max_length=NAME_CHARS, doc="filter names, bank order")
    weights: tuple[float, ...] = spec(max_items=MAX_FILTERS, doc="weight per filter; sums to 1 over enabled filters", unit="1")
    groups: dict[str, float] = spec(default_factory=dict, max_items=MAX_FILTERS, max_length=NAME_CHARS, doc="hierarchical networks: top-level weight per bank")
    statistic: tuple[float, ...] = spec((), max_items=MAX_FILTERS, doc="per-filter batch statistic behind the weights (e.g. G_k,i of Lubey & Ely 2022 eq. 6)")

    def __post_init__(self) -> None:
        if len(self.filters) != len(self.weights):
            raise ValueError(f"{len(self.filters)} filters but {len(self.weights)} weights")
        if self.statistic and len(self.statistic) != len(self.filters):
            raise ValueError(f"{len(self.filters)} filters but {len(self.statistic)} statistics")


@fast_init
@dataclass(frozen=True, slots=True)
class AnomalyReport:
    """The onboard anomaly flag and diagnosis (fsw → ground)."""

    t_s: float = spec(doc="epoch of the decision, TDB seconds past J2000", unit="s")
    timestamp: Stamp = spec(doc="epoch as Unix time")
    flag: bool = spec(doc="an anomaly is declared")
    anomaly_class: AnomalyClass = spec(doc="diagnosed class")
    confidence: float = spec(doc="confidence in the class", unit="1", ge=0.0, le=1.0)
    onset_s: float | None = spec(None, doc="estimated onset epoch, TDB seconds past J2000", unit="s")
    declared_s: float | None = spec(None, doc="epoch at which the flag was raised", unit="s")
    network: str = spec("", max_length=NAME_CHARS, doc="gating network whose weights were used")
    statistic: float = spec(0.0, doc="detection statistic at t_s", unit="1")
    threshold: float = spec(0.0, doc="declaration threshold", unit="1")
    evidence: dict[str, float] = spec(default_factory=dict, max_items=MAX_FILTERS, max_length=NAME_CHARS, doc="filter name -> weight at the decision")


@fast_init
@dataclass(frozen=True, slots=True)
class Estimate:
    """A navigation solution (fsw → ground)."""

    t_s: float = spec(doc="epoch of the estimate, TDB seconds past J2000", unit="s")
    timestamp: Stamp = spec(doc="epoch as Unix time")
    filter: str = spec(max_length=NAME_CHARS, doc="filter name, or 'combined' (gating-weighted sum of the enabled filters, "
                       "Chaer et al. 1997 eq. 3, weights of the detector's network) / 'best' (the filter navigated on: "
                       "smallest RTPC until an anomaly is declared, then the highest-weighted)")
    position_km: tuple[float, ...] = spec(doc="ICRF position from the central body (Mars; the Earth in Earth-orbit scenarios)", unit="km", shape=(3,))
    velocity_km_s: tuple[float, ...] = spec(doc="ICRF velocity relative to the central body (Mars; the Earth in Earth-orbit scenarios)", unit="km/s", shape=(3,))
    position_sigma_km: float = spec(doc="root-trace of the position covariance (RTPC)", unit="km", ge=0.0)
    state_names: tuple[str, ...] = spec(max_items=MAX_STATES, max_length=NAME_CHARS, doc="names of the state components")
    state: tuple[float, ...] = spec(max_items=MAX_STATES, doc="full state vector, units per state_names")
    sigma: tuple[float, ...] = spec(max_items=MAX_STATES, doc="1-sigma of each state component (sqrt of the covariance diagonal)")
    covariance: tuple[tuple[float, ...], ...] | None = spec(None, max_items=MAX_STATES, doc="full covariance, row-major (optional)")

    def __post_init__(self) -> None:
        n = len(self.state_names)
        if len(self.state) != n or len(self.sigma) != n:
            raise ValueError(f"state_names has {n} entries, state {len(self.state)}, sigma {len(self.sigma)}")
        if self.covariance is not None and (len(self.covariance) != n or any(len(r) != n for r in self.covariance)):
            raise ValueError(f"covariance must be {n}x{n}")


@fast_init
@dataclass(frozen=True, slots=True)
class ResidualSample:
    """Pre-fit residuals of one measurement in every filter of the bank (Lubey & Ely 2022 eq. 5:
    z̄_ij = y_j − h_ij(x̄_ij), S_ij = R_ij + H̃_ij P̄_ij H̃_ijᵀ), as the bank computed them for the gating."""

    t_s: float = spec(doc="measurement time tag, TDB seconds past J2000", unit="s")
    seq: int = spec(doc="measurement sequence number", ge=0)
    kind: MeasurementKind = spec(doc="measurement type")
    source: str = spec(max_length=NAME_CHARS, doc="station (range/doppler) or optical target")
    residual: tuple[tuple[float, ...], ...] = spec(max_items=MAX_FILTERS, doc="pre-fit residual per filter (rows, bank order) and component, measurement units")
    sigma: tuple[tuple[float, ...], ...] = spec(max_items=MAX_FILTERS, doc="sqrt of the diagonal of S per filter and component, measurement units")
    normalised: tuple[tuple[float, ...], ...] = spec(max_items=MAX_FILTERS, doc="residual / sigma per filter and component", unit="1")
    nis: tuple[float, ...] = spec(max_items=MAX_FILTERS, doc="normalised innovation squared z̄ᵀ S⁻¹ z̄ per filter (Lubey & Ely 2022 eq. 6)", unit="1")
    processed: tuple[bool, ...] = spec(max_items=MAX_FILTERS, doc="the filter updated its state with this measurement")

    def __post_init__(self) -> None:
        n = len(self.nis)
        if not (len(self.residual) == len(self.sigma) == len(self.normalised) == len(self.processed) == n):
            raise ValueError("residual, sigma, normalised, nis and processed need one entry per filter")


@fast_init
@dataclass(frozen=True, slots=True)
class Residuals:
    """The pre-fit residuals of the measurements one executive frame took on (fsw → ground): one
    message per frame that filtered any, so the bus rate follows frames, not measurements."""

    t_s: float = spec(doc="end of the frame, TDB seconds past J2000", unit="s")
    timestamp: Stamp = spec(doc="epoch as Unix time")
    filters: tuple[str, ...] = spec(max_items=MAX_FILTERS, max_length=NAME_CHARS, doc="filter names, bank order (rows of every sample)")
    samples: tuple[ResidualSample, ...] = spec(max_items=MAX_COUNTERS, doc="one entry per measurement filtered in the frame, in order")


@fast_init
@dataclass(frozen=True, slots=True)
class BPlane:
    """B-plane targeting of one navigation solution (fsw → ground): the incoming hyperbolic
    asymptote relative to Mars. T̂ = Ŝ×k̂/|Ŝ×k̂| with k̂ the Mars pole (IAU 2009), R̂ = Ŝ×T̂."""

    t_s: float = spec(doc="epoch of the solution, TDB seconds past J2000", unit="s")
    timestamp: Stamp = spec(doc="epoch as Unix time")
    filter: str = spec(max_length=NAME_CHARS, doc="filter name, or 'combined' / 'best' (as Estimate.filter)")
    b_dot_r_km: float = spec(doc="B·R", unit="km")
    b_dot_t_km: float = spec(doc="B·T", unit="km")
    covariance_km2: tuple[tuple[float, ...], ...] = spec(doc="covariance of (B·R, B·T) mapped from the state covariance", unit="km^2", shape=(2, 2))
    periapsis_s: float = spec(doc="epoch of closest approach on the osculating hyperbola, TDB seconds past J2000", unit="s")
    periapsis_sigma_s: float = spec(doc="1-sigma of the closest-approach epoch", unit="s", ge=0.0)
    v_inf_km_s: float = spec(doc="hyperbolic excess speed", unit="km/s", ge=0.0)


@fast_init
@dataclass(frozen=True, slots=True)
class BudgetReport:
    """One frame of the FSW frame executive (fsw → ground)."""

    frame: int = spec(doc="frame index, 0-based", ge=0)
    t_s: float = spec(doc="simulated epoch at the end of the frame, TDB seconds past J2000", unit="s")
    timestamp: Stamp = spec(doc="epoch as Unix time")
    mode: Literal["cpu", "work-units"] = spec(doc="budget accounting mode")
    used: float = spec(doc="budget used this frame (scaled CPU seconds, or work units)", ge=0.0)
    budget: float = spec(doc="budget per frame (scaled CPU seconds, or work units)", gt=0.0)
    utilisation: float = spec(doc="used / budget (may exceed 1 on an overrun)", unit="1", ge=0.0)
    processed: int = spec(doc="stages (work items) completed this frame", ge=0)
    deferred: int = spec(doc="due stages not run this frame, moved to a later frame", ge=0)
    backlog: int = spec(doc="measurement jobs with work outstanding at the end of the frame", ge=0)
    overruns: int = spec(doc="cumulative count of items that exceeded the remaining budget", ge=0)
    errors: int = spec(0, doc="cumulative count of work items that raised", ge=0)


@fast_init
@dataclass(frozen=True, slots=True)
class AuthTag:
    """Proof that a message comes from a holder of the run's key: HMAC-SHA256 (RFC 2104) over the
    message's canonical bytes and a fresh nonce (:mod:`fsw.interface.auth` defines both)."""

    nonce: str = spec(max_length=64, doc="random hex chosen by the signer; a telecommand's nonce is accepted once")
    mac: str = spec(max_length=64, doc="HMAC-SHA256 in hex over the schema name, the nonce and the message without this tag")


@fast_init
@dataclass(frozen=True, slots=True)
class RqpReport:
    """One RQP parameter adaptation of the best filter, Chaer et al. 1997 §IV (fsw → ground)."""

    t_s: float = spec(doc="epoch when the search ended and its result was applied, TDB seconds past J2000", unit="s")
    timestamp: Stamp = spec(doc="epoch as Unix time")
    filter: str = spec(max_length=NAME_CHARS, doc="the filter re-tuned (the one the gating network preferred)")
    params: tuple[str, ...] = spec(max_items=MAX_STATES, max_length=NAME_CHARS, doc="names of the components of α")
    alpha_before: tuple[float, ...] = spec(max_items=MAX_STATES, doc="α before the adaptation")
    alpha_after: tuple[float, ...] = spec(max_items=MAX_STATES, doc="α found (applied when 'applied')")
    nll_before: float = spec(doc="J (eq. 22, negative log-likelihood of the window) at α before", unit="1")
    nll_after: float = spec(doc="J at α after", unit="1")
    window: int = spec(doc="measurements in the window (P)", ge=0)
    iterations: int = spec(doc="SLSQP iterations", ge=0)
    evaluations: int = spec(doc="J evaluations (α rows; a gradient costs 2·dim α)", ge=0)
    cost: float = spec(doc="budget its slices were charged, all together: scaled CPU seconds (mode cpu) or work "
                       "units (mode work-units), as the executive charges them", ge=0.0)
    applied: bool = spec(doc="the new α was applied (false: within the minimum change of the old)")
    status: str = spec(max_length=NAME_CHARS, doc="how SLSQP ended")

    def __post_init__(self) -> None:
        if not len(self.params) == len(self.alpha_before) == len(self.alpha_after):
            raise ValueError("params, alpha_before and alpha_after must have the same length")


@fast_init
@dataclass(frozen=True, slots=True)
class Telecommand:
    """A command to the FSW (ground → fsw, as a Zenoh query payload)."""

    id: str = spec(max_length=NAME_CHARS, doc="command identifier chosen by the sender, echoed in the reply")
    command: TelecommandName = spec(doc="what to do")
    network: str | None = spec(None, max_length=NAME_CHARS, doc="gating network the command applies to (reset-gating, set-param)")
    filter: str | None = spec(None, max_length=NAME_CHARS, doc="filter the command applies to (enable-filter, disable-filter)")
    param: str | None = spec(None, max_length=NAME_CHARS, doc="parameter name (set-param), e.g. 'sigma_w', 'batch_size', "
                             "'eta'; set-rqp: 'enabled' (value 1 or 0) or 'every' (window of P measurements)")
    value: float | None = spec(None, doc="parameter value (set-param, set-rqp)")
    auth: AuthTag | None = spec(None, doc="authentication tag; an FSW that holds the run's key refuses a command without a valid one")

    def __post_init__(self) -> None:
        needs = {
            "enable-filter": ("filter",),
            "disable-filter": ("filter",),
            "set-param": ("network", "param", "value"),
            "set-rqp": ("param", "value"),
        }.get(self.command, ())
        for name in needs:
            if getattr(self, name) is None:
                raise ValueError(f"'{self.command}' needs '{name}'")


@fast_init
@dataclass(frozen=True, slots=True)
class TelecommandReply:
    """The FSW's answer to a telecommand."""

    id: str = spec(max_length=NAME_CHARS, doc="identifier of the command answered ('' if it could not be read)")
    ok: bool = spec(doc="the command was valid and carried out")
    error: str = spec("", max_length=TEXT_CHARS, doc="why the command was rejected")
    status: dict[str, float] = spec(default_factory=dict, max_items=MAX_COUNTERS, max_length=NAME_CHARS, doc="counters and values (status command)")
    detail: dict[str, str] = spec(default_factory=dict, max_items=MAX_COUNTERS, max_length=TEXT_CHARS, doc="textual status (filters enabled, networks, ...)")


@fast_init
@dataclass(frozen=True, slots=True)
class CommandRecord:
    """A telecommand as the FSW served it, with its reply (fsw → ground): commands are part of the
    record, so a commanded run can be re-run with the same commands at the same points."""

    t_s: float = spec(doc="FSW clock when served: epoch of the newest measurement handled, TDB seconds past J2000", unit="s")
    timestamp: Stamp = spec(doc="epoch as Unix time")
    taken: int = spec(doc="measurement payloads the FSW had taken when it served the command (a re-run serves it "
                      "after as many)", ge=0)
    telecommand: Telecommand | None = spec(doc="the command; null when the payload did not decode")
    reply: TelecommandReply = spec(doc="the FSW's answer")
    payload: str = spec("", max_length=TEXT_CHARS, doc="the payload as received, when it did not decode (truncated)")
    ended: bool = spec(False, doc="served after the FSW's end-of-run sequence")
    refused: str = spec("", max_length=TEXT_CHARS, doc="why the command was refused before it was looked at "
                        "(authentication); it changed nothing. Empty for a command that was served")


@fast_init
@dataclass(frozen=True, slots=True)
class RunStatus:
    """Lifecycle and counters of a process (start, periodic, end-of-run)."""

    t_s: float = spec(doc="simulated epoch, TDB seconds past J2000", unit="s")
    timestamp: Stamp = spec(doc="epoch as Unix time")
    run_id: str = spec(max_length=NAME_CHARS, doc="run identifier (the Zenoh key prefix navbank/<run-id>/)")
    source: Literal["sim", "fsw", "ground", "replay"] = spec(doc="process reporting")
    state: RunState = spec(doc="lifecycle state")
    counts: dict[str, int] = spec(default_factory=dict, max_items=MAX_COUNTERS, max_length=NAME_CHARS, doc="counters, e.g. published, processed, rejected, lost")
    message: str = spec("", max_length=TEXT_CHARS, doc="human-readable detail (errors)")
    auth: AuthTag | None = spec(None, doc="authentication tag; consumers that hold the run's key act only on a status with a valid one")


#: Every ICD type, by its schema name.
MESSAGE_TYPES: dict[str, type] = {
    cls.__name__: cls
    for cls in (
        Measurement,
        Truth,
        FaultEvent,
        FilterWeights,
        AnomalyReport,
        Estimate,
        Residuals,
        BPlane,
        BudgetReport,
        Telecommand,
        TelecommandReply,
        CommandRecord,
        RunStatus,
        RqpReport,
    )
}
