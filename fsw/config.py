"""Configuration of the flight software: bank, gating networks, detector, budget, telemetry.

This is the ``fsw:`` section of a scenario file. Each piece is declared next to the code it
configures; this module composes them and adds what only the FSW as a whole needs (the a-priori
state uplinked before the run, telemetry cadences, input screening).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, Literal

from fsw.executive.config import BudgetConfig
from fsw.fdir.config import DetectorConfig
from fsw.fdir.families import FilterFamily
from fsw.filters import kinds
from fsw.filters.config import BankConfig
from fsw.filters.presets import nominal_bank
from fsw.filters.rqp_config import RqpConfig
from fsw.gating.registry import NETWORKS, params_type
from fsw.interface import typed
from fsw.interface.typed import DecodeError, spec


@dataclass(frozen=True)
class GatingEntry:
    """One gating network and its parameters, written in YAML as ``{network: NAME, <params>…}``.

    The parameter type depends on the network name, so this class decodes itself: the error for a
    bad parameter still points at ``fsw.gating[i].<param>``.
    """

    network: str
    params: Any

    @classmethod
    def of(cls, network: str, **params: Any) -> "GatingEntry":
        return cls._typed_decode({"network": network, **params}, "")

    @classmethod
    def _typed_decode(cls, data: Any, path: str) -> "GatingEntry":
        if not isinstance(data, dict):
            raise DecodeError(path, "a mapping {network: NAME, parameters...}", type(data).__name__)
        name = data.get("network")
        if name not in NETWORKS:
            raise DecodeError(f"{path}.network" if path else "network", "one of " + ", ".join(NETWORKS),
                              repr(name) + typed.did_you_mean(name, NETWORKS))
        rest = {k: v for k, v in data.items() if k != "network"}
        return cls(network=name, params=typed.decode(params_type(name), rest, path))

    def _typed_encode(self, drop_defaults: bool) -> dict[str, Any]:
        return {"network": self.network, **typed.encode(self.params, drop_defaults=drop_defaults)}

    def _typed_annotated(self) -> tuple[list[tuple[str, Any, str]], Any]:
        return [("network", self.network, "gating network (see docs/scenarios.md)")], self.params

    @classmethod
    def _typed_schema(cls) -> dict[str, Any]:
        variants = []
        for name in NETWORKS:
            sch = typed.json_schema(params_type(name), top=False)
            sch["properties"] = {"network": {"const": name}, **sch["properties"]}
            sch["required"] = ["network", *sch.get("required", [])]
            variants.append(sch)
        return {"oneOf": variants}


@dataclass(frozen=True)
class DetectorSection:
    """Which gating network drives the anomaly detector, and its calibration."""

    network: str = spec("chi2", doc="gating network whose weights the detector watches")
    calibration: DetectorConfig | None = spec(
        None, doc="calibrated thresholds and nominal band (from `navbank calibrate`); none: detector off"
    )


@dataclass(frozen=True)
class TelemetryConfig:
    """How often the FSW publishes what (simulated time)."""

    estimate_every_s: float = spec(3600.0, doc="cadence of Estimate messages (combined, best, per filter), on a grid from the initial epoch", unit="s", gt=0)
    per_filter_estimates: bool = spec(True, doc="also publish each filter's estimate")
    full_covariance: bool = spec(False, doc="include the full covariance in Estimate messages")
    anomaly_every_s: float = spec(6 * 3600.0, doc="periodic AnomalyReport cadence (also sent on every change)", unit="s", gt=0)
    idle_budget_every_s: float = spec(3600.0, doc="BudgetReport cadence for frames with nothing to do", unit="s", gt=0)
    status_every_s: float = spec(86400.0, doc="periodic RunStatus (counters) cadence", unit="s", gt=0)
    residuals_every_s: float | None = spec(
        None, doc="pre-fit residuals (Residuals): the measurements filtered since the last message, sent at the end of "
        "the first executive frame this long after it (null: not sent)", unit="s", ge=0)
    bplane_every_s: float | None = spec(
        None, doc="B-plane targeting (BPlane) of the combined, best and per-filter estimates, on the estimate grid "
        "at this cadence (null: not sent)", unit="s", gt=0)


@dataclass(frozen=True)
class IntakeConfig:
    """Plausibility limits of the measurement intake (:mod:`fsw.ingest`): what no valid
    measurement can look like, so that one forged or corrupted message cannot change state."""

    max_ahead_s: float = spec(
        10 * 86400.0, doc="a time tag more than this ahead of the FSW clock (newest processed tag) is rejected; "
        "longer than the longest tracking gap", unit="s", gt=0)
    max_sequence_jump: int = spec(
        100_000, doc="a sequence number more than this beyond the next expected one is rejected; "
        "far more than the simulator's credit window", ge=1)


@dataclass(frozen=True)
class CheckpointConfig:
    """How often a supervised FSW saves its state (:mod:`fsw.core.checkpoint`): a restarted FSW
    goes on from the last checkpoint and the simulator resends what came after it. Written only
    by a process given a checkpoint file (``navbank run`` gives one); whichever limit is reached
    first triggers the next."""

    every_measurements: int = spec(500, doc="measurements taken between checkpoints (0: no count limit)", ge=0)
    every_s: float = spec(0.0, doc="mission time between checkpoints (0: no time limit)", unit="s", ge=0)


@dataclass(frozen=True)
class InitialState:
    """A-priori spacecraft state uplinked to the FSW before the run (never the truth)."""

    t_s: float = spec(doc="epoch, TDB seconds past J2000", unit="s")
    position_km: tuple[float, ...] = spec(doc="ICRF position from the central body (Mars; the Earth in Earth-orbit scenarios)", unit="km", shape=(3,))
    velocity_km_s: tuple[float, ...] = spec(doc="ICRF velocity relative to the central body (Mars; the Earth in Earth-orbit scenarios)", unit="km/s", shape=(3,))


@dataclass(frozen=True)
class FswConfig:
    """The flight software as configured for a run."""

    bank: BankConfig = spec(default_factory=nominal_bank, doc="the filter bank")
    gating: tuple[GatingEntry, ...] = spec(
        default_factory=lambda: (GatingEntry.of("chi2"), GatingEntry.of("magill")),
        doc="gating networks, each {network: NAME, parameters}",
    )
    detector: DetectorSection = spec(default_factory=DetectorSection, doc="anomaly detector")
    budget: BudgetConfig = spec(default_factory=BudgetConfig, doc="frame executive budget")
    telemetry: TelemetryConfig = spec(default_factory=TelemetryConfig, doc="telemetry cadences")
    reorder_window: int = spec(32, doc="out-of-order measurements within this many sequence numbers are re-ordered", ge=0)
    intake: IntakeConfig = spec(default_factory=IntakeConfig, doc="measurement plausibility limits")
    checkpoint: CheckpointConfig = spec(default_factory=CheckpointConfig, doc="checkpoint cadence of a supervised run")
    rqp: RqpConfig = spec(default_factory=RqpConfig, doc="RQP adaptation of the best filter's noise parameters")
    initial_state: InitialState | None = spec(
        None, doc="a-priori state; none: the launcher derives it from the scenario (design trajectory + a-priori error draw)"
    )
    central_body: Literal["mars", "earth"] = spec(
        "mars", doc="mars: the Mars-centred EKF bank (fsw.filters.bank); earth: the Earth-orbit bank of ground-station "
        "tracking after injection (fsw.filters.orbit_bank: two-body + J2, range, range rate, azimuth, elevation; "
        "each filter's name, process_noise, velocity_noise_psd and a-priori sigmas are used)")

    def __post_init__(self) -> None:
        if self.central_body == "earth" and self.rqp.enabled:
            raise ValueError("RQP adaptation is not available with the Earth-orbit bank (central_body: earth)")
        names = [g.network for g in self.gating]
        if len(set(names)) != len(names):
            raise ValueError(f"each gating network may appear once, got {names}")
        filters = [f.name for f in self.bank.filters]
        if self.gating and self.detector.network not in names:
            raise ValueError(f"detector.network {self.detector.network!r} is not among the gating networks {names}")
        cal = self.detector.calibration
        if cal is not None and cal.network != self.detector.network:
            raise ValueError(f"detector calibration is for network {cal.network!r}, the detector watches {self.detector.network!r}")
        if cal is not None and tuple(cal.filters) != tuple(filters):
            raise ValueError(f"detector calibration is for filters {list(cal.filters)}, the bank has {filters}")

    def families(self) -> tuple[FilterFamily, ...]:
        """Family tags of each filter, derived from the kinds it processes and its ``high_q`` flag
        (never from names)."""
        out = []
        for f in self.bank.filters:
            fams: list[str] = []
            for kind, model in kinds.REGISTRY.items():
                if kind in f.processes and model.family not in fams:
                    fams.append(model.family)
            out.append(FilterFamily(name=f.name, families=tuple(fams) or ("other",),
                                    high_q=f.high_q))
        return tuple(out)

    def with_initial_state(self, state: InitialState) -> "FswConfig":
        return dataclasses.replace(self, initial_state=state)
