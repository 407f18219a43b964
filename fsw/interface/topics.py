"""Key layout: every Zenoh key lives under ``navbank/<run-id>/``; MCAP topics drop that prefix.

One table maps each topic to its ICD type so publishers, subscribers, the logger and replay
agree without repeating themselves.
"""

from __future__ import annotations

import re
from functools import lru_cache

from fsw.interface import messages as m

ROOT = "navbank"

SIM_MEASUREMENTS = "sim/measurements"
SIM_TRUTH = "sim/truth"
SIM_FAULTS = "sim/faults"
SIM_STATUS = "sim/status"
FSW_WEIGHTS = "fsw/weights"  # + "/<network>"
FSW_ANOMALY = "fsw/anomaly"
FSW_ESTIMATE = "fsw/estimate"  # + "/<filter>" ("combined", "best", or a filter name)
FSW_BUDGET = "fsw/budget"
FSW_RESIDUALS = "fsw/residuals"  # pre-fit residuals, one message per executive frame
FSW_BPLANE = "fsw/bplane"  # + "/<filter>" ("combined", "best", or a filter name)
FSW_STATUS = "fsw/status"
FSW_COMMAND = "fsw/cmd"  # queryable: Telecommand in, TelecommandReply out
FSW_COMMANDS = "fsw/commands"  # every telecommand served, with its reply (CommandRecord)
FSW_RQP = "fsw/rqp"  # RQP parameter adaptations (RqpReport)
GROUND_STATUS = "ground/status"

#: topic (or topic prefix ending in "/") -> ICD type
TOPIC_TYPES: dict[str, type] = {
    SIM_MEASUREMENTS: m.Measurement,
    SIM_TRUTH: m.Truth,
    SIM_FAULTS: m.FaultEvent,
    SIM_STATUS: m.RunStatus,
    FSW_WEIGHTS + "/": m.FilterWeights,
    FSW_ANOMALY: m.AnomalyReport,
    FSW_ESTIMATE + "/": m.Estimate,
    FSW_BUDGET: m.BudgetReport,
    FSW_RESIDUALS: m.Residuals,
    FSW_BPLANE + "/": m.BPlane,
    FSW_STATUS: m.RunStatus,
    FSW_COMMANDS: m.CommandRecord,
    FSW_RQP: m.RqpReport,
    GROUND_STATUS: m.RunStatus,
}

_RUN_ID = re.compile(r"^[A-Za-z0-9_.-]{1,64}$")


def check_run_id(run_id: str) -> str:
    """A run id is one Zenoh key chunk: letters, digits, ``_ . -``, at most 64 characters."""
    if not _RUN_ID.match(run_id):
        raise ValueError(f"run id {run_id!r}: expected 1-64 characters from A-Z a-z 0-9 _ . -")
    return run_id


def key(run_id: str, topic: str) -> str:
    """Zenoh key expression of ``topic`` in run ``run_id``."""
    return f"{ROOT}/{check_run_id(run_id)}/{topic.strip('/')}"


def run_prefix(run_id: str) -> str:
    return f"{ROOT}/{check_run_id(run_id)}"


def topic_of_key(key_expr: str) -> tuple[str, str]:
    """Split a key into (run id, topic); raises ValueError for keys outside ``navbank/<id>/``."""
    parts = str(key_expr).split("/", 2)
    if len(parts) < 3 or parts[0] != ROOT:
        raise ValueError(f"key {key_expr!r} is not under {ROOT}/<run-id>/")
    return parts[1], parts[2]


def mcap_topic(topic: str) -> str:
    """MCAP channel topic for a topic: a leading slash, e.g. ``/fsw/weights/chi2``."""
    return "/" + topic.strip("/")


@lru_cache(maxsize=4096)  # asked for every message received; a run has a few dozen topics
def type_of_topic(topic: str) -> type:
    """The ICD type carried on ``topic`` (KeyError for unknown topics)."""
    topic = topic.strip("/")
    if topic in TOPIC_TYPES:
        return TOPIC_TYPES[topic]
    for prefix, cls in TOPIC_TYPES.items():
        if prefix.endswith("/") and topic.startswith(prefix) and len(topic) > len(prefix):
            return cls
    raise KeyError(topic)
