"""How a stage is charged against the frame budget, and whether it may start.

Both meters answer the same two questions: what will this stage probably cost (``predict``), and
what does it cost now that it has run (``charge``). A stage starts only if its predicted cost fits
the remaining budget — except the first stage of a frame, which always starts so that a stage
larger than a whole frame cannot stall the executive (it then counts as an overrun).
"""

from __future__ import annotations

import math

from fsw.executive.config import BudgetConfig
from fsw.executive.work import Stage


class WorkUnitMeter:
    """Declared costs: a stage costs what it says (or its class default), whatever the host does."""

    def __init__(self, config: BudgetConfig):
        self._config = config

    def predict(self, stage: Stage) -> float:
        return stage.cost if stage.cost is not None else self._config.default_cost(stage.kind)

    def admits(self, predicted: float, remaining: float) -> bool:
        return predicted <= remaining

    def fits(self, stage: Stage, remaining: float) -> bool:
        """``admits(predict(stage), remaining)`` in one call (asked before every stage)."""
        cost = stage.cost
        return (cost if cost is not None else self._config.default_cost(stage.kind)) <= remaining

    def charge(self, stage: Stage, measured_s: float) -> float:
        return self.predict(stage)


class CpuMeter:
    """Measured costs: thread CPU seconds times ``cpu_scale``.

    The prediction for a stage is a running mean of its past charged costs plus ``cost_margin``
    running mean absolute deviations, per stage label (seen-before work is admitted only if it
    will very probably fit; never-seen work is admitted while any budget is left).

    The first run of each stage label is charged but does not seed the estimate: a first call
    carries one-time costs (caches filled, tables built — 10-20× a typical run for the filter
    bank), and seeding the estimate with it kept the stage out of frames it fits in for hours of
    simulated time while the estimate decayed.
    """

    COLD_START_SAMPLES = 1

    def __init__(self, config: BudgetConfig):
        self._scale = config.cpu_scale
        self._gain = config.cost_gain
        self._margin = config.cost_margin
        self._mean: dict[str, float] = {}
        self._dev: dict[str, float] = {}
        self._seen: dict[str, int] = {}

    def predict(self, stage: Stage) -> float:
        key = stage.label
        mean = self._mean.get(key)
        if mean is None:
            return 0.0
        return mean + self._margin * self._dev[key]

    def admits(self, predicted: float, remaining: float) -> bool:
        return remaining > 0.0 and predicted <= remaining

    def fits(self, stage: Stage, remaining: float) -> bool:
        """``admits(predict(stage), remaining)`` in one call (asked before every stage)."""
        if remaining <= 0.0:
            return False
        mean = self._mean.get(stage.label)
        return (0.0 if mean is None else mean + self._margin * self._dev[stage.label]) <= remaining

    def charge(self, stage: Stage, measured_s: float) -> float:
        cost = measured_s * self._scale
        key = stage.label
        seen = self._seen.get(key, 0)
        self._seen[key] = seen + 1
        if seen < self.COLD_START_SAMPLES:
            return cost
        mean = self._mean.get(key)
        if mean is None:
            # Half the first sample as initial deviation: cautious until the cost is known.
            self._mean[key] = cost
            self._dev[key] = 0.5 * cost
        else:
            gain = self._gain
            err = cost - mean
            self._mean[key] = mean + gain * err
            dev = self._dev[key]
            self._dev[key] = dev + gain * (abs(err) - dev)
        return cost

    def estimates(self) -> dict[str, tuple[float, float]]:
        """(mean, mean absolute deviation) of the charged cost per stage label."""
        return {key: (self._mean[key], self._dev[key]) for key in self._mean}


def measured_interval(start: float, end: float) -> float:
    """CPU seconds between two clock readings; a clock that misbehaves charges nothing."""
    dt = end - start
    if not math.isfinite(dt) or dt < 0.0:
        return 0.0
    return dt
