"""How a stage is charged against the frame budget, and whether it may start.

Both meters answer the same two questions: what will this stage probably cost (``predict``), and
what does it cost now that it has run (``charge``). A stage starts only if its predicted cost fits
the remaining budget — except the first stage of a frame, which always starts so that a stage
larger than a whole frame cannot stall the executive (it then counts as an overrun).
"""

from __future__ import annotations


from fsw.executive.config import BudgetConfig
from fsw.executive.work import Stage


class WorkUnitMeter:
    """Declared costs: a stage costs what it says (or its class default), whatever the host does."""

    __slots__ = ("_config",)  # see FrameExecutive's

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


class _LabelCost:
    """The running estimate of one stage label's charged cost."""

    __slots__ = ("seen", "mean", "dev", "predicted", "cpu_s")

    def __init__(self) -> None:
        self.seen = 0
        #: thread CPU seconds measured in this label's stages so far (every run, cold ones too)
        self.cpu_s = 0.0
        self.mean: float | None = None  # None until a sample past the cold start seeds it
        self.dev = 0.0
        #: mean + margin × dev, made when they change (asked before every stage, changed after one)
        self.predicted = 0.0


class CpuMeter:
    """Measured costs: thread CPU seconds times ``cpu_scale``.

    The prediction for a stage is a running mean of its past charged costs plus ``cost_margin``
    running mean absolute deviations, per stage label (seen-before work is admitted only if it
    will very probably fit; never-seen work is admitted while any budget is left).

    The first run of each stage label is charged but does not seed the estimate: a first call
    carries one-time costs (caches filled, tables built — 10-20× a typical run for the filter
    bank), and seeding the estimate with it kept the stage out of frames it fits in for hours of
    simulated time while the estimate decayed.

    The meter is asked before and charged after every stage the executive runs, so each label's
    estimate is one record found by one dictionary look-up, holding its prediction ready.
    """

    COLD_START_SAMPLES = 1

    __slots__ = ("_scale", "_gain", "_margin", "_costs", "_estimated")  # see FrameExecutive's

    def __init__(self, config: BudgetConfig):
        self._scale = config.cpu_scale
        self._gain = config.cost_gain
        self._margin = config.cost_margin
        self._costs: dict[str, _LabelCost] = {}
        #: the labels with an estimate, in the order they got it (what :meth:`estimates` lists)
        self._estimated: dict[str, _LabelCost] = {}

    def predict(self, stage: Stage) -> float:
        rec = self._costs.get(stage.label)
        return 0.0 if rec is None else rec.predicted

    def admits(self, predicted: float, remaining: float) -> bool:
        return remaining > 0.0 and predicted <= remaining

    def fits(self, stage: Stage, remaining: float) -> bool:
        """``admits(predict(stage), remaining)`` in one call (asked before every stage)."""
        if remaining <= 0.0:
            return False
        rec = self._costs.get(stage.label)
        return rec is None or rec.predicted <= remaining

    def charge(self, stage: Stage, measured_s: float) -> float:
        cost = measured_s * self._scale
        rec = self._costs.get(stage.label)
        if rec is None:
            rec = self._costs[stage.label] = _LabelCost()
        seen = rec.seen
        rec.seen = seen + 1
        rec.cpu_s += measured_s
        if seen < self.COLD_START_SAMPLES:
            return cost
        mean = rec.mean
        if mean is None:
            # Half the first sample as initial deviation: cautious until the cost is known.
            rec.mean = mean = cost
            rec.dev = dev = 0.5 * cost
            self._estimated[stage.label] = rec
        else:
            gain = self._gain
            err = cost - mean
            rec.mean = mean = mean + gain * err
            dev = rec.dev
            rec.dev = dev = dev + gain * (abs(err) - dev)
        rec.predicted = mean + self._margin * dev
        return cost

    def cpu_by_label(self) -> dict[str, tuple[int, float]]:
        """(stages run, thread CPU seconds measured in them) per stage label, in the order the
        labels first ran: where the core's CPU went, stage by stage."""
        return {label: (rec.seen, rec.cpu_s) for label, rec in self._costs.items()}

    def estimates(self) -> dict[str, tuple[float, float]]:
        """(mean, mean absolute deviation) of the charged cost per stage label."""
        return {key: (rec.mean, rec.dev) for key, rec in self._estimated.items()}  # type: ignore[misc]
