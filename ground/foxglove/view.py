"""Which Foxglove messages each recorded ICD message makes (see :mod:`ground.foxglove`)."""

from __future__ import annotations

from typing import Any

import msgspec

from fsw.interface import topics
from ground.foxglove.logs import LogBuilder
from ground.foxglove.plots import PlotBuilder
from ground.foxglove.records import FoxgloveRecord
from ground.foxglove.scene import SceneBuilder

_STATUS = {topics.SIM_STATUS, topics.FSW_STATUS, topics.GROUND_STATUS}
#: topics the view reads; every other message costs it nothing
WANTED_PREFIXES = (topics.SIM_TRUTH, topics.SIM_FAULTS, topics.FSW_ANOMALY, topics.FSW_COMMANDS, topics.FSW_RESIDUALS,
                   topics.FSW_BPLANE + "/", topics.FSW_ESTIMATE + "/", *_STATUS)


_WANTED: dict[str, bool] = {}  # per topic name: a run has a few dozen, asked once per message


def wanted(topic: str) -> bool:
    known = _WANTED.get(topic)
    if known is None:
        bare = topic.strip("/")
        known = any(bare == p or (p.endswith("/") and bare.startswith(p)) for p in WANTED_PREFIXES)
        if len(_WANTED) < 4096:
            _WANTED[topic] = known
    return known


class FoxgloveView:
    """Stateful converter: ``convert(topic, message, log_ns)`` → the Foxglove records it makes.

    ``message`` is an ICD message as a JSON dict (what the logger parsed) or as encoded bytes; a
    message that is not what its topic promises makes nothing (the ICD channel keeps it)."""

    def __init__(self, scene_every_s: float = 3600.0) -> None:
        self.scene = SceneBuilder(every_s=scene_every_s)
        self.logs = LogBuilder()
        self.plots = PlotBuilder()
        self.errors = 0

    def convert(self, topic: str, message: Any, log_ns: int) -> list[FoxgloveRecord]:
        topic = topic.strip("/")
        if not wanted(topic):
            return []
        try:
            # msgspec parses the same JSON values as json.loads, several times faster (what arrives
            # here was decoded strictly by the logger already)
            msg = msgspec.json.decode(message) if isinstance(message, (bytes, str)) else message
            return self._convert(topic, msg, log_ns)
        except (KeyError, TypeError, ValueError, IndexError):
            self.errors += 1
            return []

    def _convert(self, topic: str, msg: dict[str, Any], log_ns: int) -> list[FoxgloveRecord]:
        if topic == topics.SIM_TRUTH:
            self.plots.truth(msg)
            return self.scene.truth(msg, log_ns)
        if topic.startswith(topics.FSW_ESTIMATE + "/"):
            return self.plots.estimate(msg, log_ns) + self.scene.estimate_message(msg, log_ns)
        if topic == topics.FSW_RESIDUALS:
            return self.plots.residuals(msg, log_ns)
        if topic.startswith(topics.FSW_BPLANE + "/"):
            return self.plots.bplane(msg, log_ns)
        if topic in _STATUS:
            return self.logs.status(msg, log_ns)
        if topic == topics.FSW_ANOMALY:
            return self.logs.anomaly(msg, log_ns)
        if topic == topics.SIM_FAULTS:
            return self.logs.fault(msg, log_ns)
        if topic == topics.FSW_COMMANDS:
            return self.logs.command(msg, log_ns)
        return []
