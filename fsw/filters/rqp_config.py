"""Configuration of onboard RQP parameter adaptation (Chaer et al. 1997 §IV): what is tuned, inside
which boxes (eq. 23), how often, and how much of it runs per executive slice."""

from __future__ import annotations

from dataclasses import dataclass

from fsw.interface.typed import spec


@dataclass(frozen=True)
class RqpParam:
    """One component of α: a filter noise parameter (as ``set-param`` names it) and its box."""

    name: str = spec(doc="sigma_scale.<kind>, velocity_noise_psd or clock.q_white_fm / q_random_walk_fm / q_random_run")
    lower: float = spec(doc="lower bound (eq. 23); > 0, the search runs on ln α", gt=0.0)
    upper: float = spec(doc="upper bound (eq. 23)", gt=0.0)

    def __post_init__(self) -> None:
        if not self.lower < self.upper:
            raise ValueError(f"{self.name}: lower {self.lower} must be below upper {self.upper}")
        if not self.name.startswith(("sigma_scale.", "velocity_noise_psd", "clock.q_")):
            raise ValueError(f"{self.name!r} is not a tunable noise parameter")


def _default_params() -> tuple[RqpParam, ...]:
    return (RqpParam("sigma_scale.range", 0.2, 5.0), RqpParam("sigma_scale.doppler", 0.2, 5.0),
            RqpParam("sigma_scale.optical", 0.2, 5.0))


@dataclass(frozen=True)
class RqpConfig:
    """Periodic re-tuning of the filter the gating network prefers (off unless enabled)."""

    enabled: bool = spec(False, doc="run the adaptation (the set-rqp telecommand switches it at run time)")
    every: int = spec(40, doc="P: measurements per window; the best filter is re-tuned on each closed window", ge=2, le=1000)
    params: tuple[RqpParam, ...] = spec(default_factory=_default_params,
                                        doc="the components of α with their boxes; a filter is searched over those that "
                                        "concern it (the sigma_scale of kinds it does not process are left out)", max_items=8)
    slice_steps: int = spec(4, doc="filter steps (one measurement re-processed for one α) per executive slice", ge=1)
    slice_cost: float = spec(2.0, doc="declared cost of one slice (mode work-units)", unit="work unit", ge=0.0)
    max_iter: int = spec(20, doc="SLSQP iteration cap per adaptation", ge=1)
    ftol: float = spec(1e-4, doc="SLSQP tolerance on J per measurement", unit="1", gt=0.0)
    min_change: float = spec(0.05, doc="a result within this relative change of every current component is not applied",
                             unit="1", ge=0.0)

    def __post_init__(self) -> None:
        names = [p.name for p in self.params]
        if not names or len(set(names)) != len(names):
            raise ValueError(f"rqp.params needs one or more distinct parameters, got {names}")
