"""The simulator's top-level configuration: trajectory, forces, clock, sensors, faults, truth output.

The random seed is not part of it: the caller gives it to :func:`sim.stream.generate`, so one
configuration runs under many seeds (Monte Carlo campaigns).
"""

from __future__ import annotations

from dataclasses import dataclass

from fsw.interface.typed import spec
from sim.clock import ClockConfig
from sim.dynamics.config import ForceModelConfig, TrajectoryConfig
from sim.faults.config import FaultConfig, fault_ids
from sim.scenarios.leo_injection import LeoInjectionConfig
from sim.sensors.config import OpticalConfig, RadiometricConfig


@dataclass(frozen=True, slots=True)
class SimConfig:
    """Everything the truth/sensor simulator needs except the seed."""

    trajectory: TrajectoryConfig = spec(TrajectoryConfig(), doc="approach trajectory (entry conditions, arc length)")
    forces: ForceModelConfig = spec(ForceModelConfig(), doc="truth force model and its dispersions")
    clock: ClockConfig = spec(ClockConfig(), doc="onboard clock random process")
    radiometric: RadiometricConfig = spec(RadiometricConfig(), doc="DSN one-way range and Doppler")
    optical: OpticalConfig = spec(OpticalConfig(), doc="optical navigation camera")
    faults: tuple[FaultConfig, ...] = spec((), doc="injected faults (docs/scenarios.md#faults)")
    truth_interval_s: float = spec(
        600.0, doc="cadence of published Truth messages; 0 publishes one at every measurement time", unit="s", ge=0.0
    )
    leo: LeoInjectionConfig | None = spec(
        None, doc="an Earth orbiter tracked from the ground just after injection (Garhwal, Halder & Sinha); when set, "
        "it replaces the Mars trajectory, clock, radiometric and optical sections")

    @property
    def span_days(self) -> float:
        """Length of the simulated arc [day] (the Mars trajectory's, or the Earth-orbit tracking arc)."""
        return self.leo.arc_s / 86400.0 if self.leo is not None else self.trajectory.span_days

    @property
    def trajectory_kind(self) -> str:
        return "leo-injection" if self.leo is not None else self.trajectory.kind

    def __post_init__(self) -> None:
        fault_ids(self.faults)  # unique identifiers
        if self.leo is not None and self.faults:
            raise ValueError("faults are not available in the Earth-orbit (leo) case")
        span = self.trajectory.span_days
        for f in self.faults:
            if f.onset_day > span:
                raise ValueError(f"fault {f.type} starts on day {f.onset_day}, after the {span}-day run")
            if f.type == "nga-level" and not self.forces.nga_sigma_km_s2 > 0.0:
                raise ValueError("an nga-level fault needs the non-gravitational acceleration on "
                                 "(forces.nga_sigma_km_s2 > 0)")
