"""Per-run MCAP recordings of a campaign (``keep_mcap``): which runs keep one, and the file.

A campaign run is flown in process (:mod:`tools.inprocess`), so there is no logger: the worker
writes the run's messages — what a ``navbank run`` logger would have recorded — into an MCAP
file with the run's configuration attached, and hands back its bytes (the worker may be on
another host); the campaign stores them as ``mcap/<run id>.mcap``, which ``navbank report`` and
``navbank replay --rerun`` read like any recorded run.
"""

from __future__ import annotations

import os
import tempfile
from typing import TYPE_CHECKING

from ground.mcap_io.recorder import McapRecorder, publish_time_of
from ground.report.summary_types import RunSummary
from tools.scenario import to_yaml

if TYPE_CHECKING:
    from tools.inprocess import RunResult

def detection_failed(summary: RunSummary) -> bool:
    """The onboard detector got the run wrong: missed the injected fault, declared a false alarm,
    or declared the wrong class."""
    a = summary.anomaly
    missed = a.onset_true is not None and not a.declared
    return missed or a.false_alarm or (a.declared and a.correct_class is False)


def keeps(policy: str, summary: RunSummary) -> bool:
    """Whether a run with ``summary`` keeps its MCAP under ``policy``."""
    if policy == "all":
        return True
    if policy == "detected":
        return summary.anomaly.declared
    if policy == "failed":
        return detection_failed(summary)
    return False


def mcap_bytes(result: "RunResult", run_id: str) -> bytes:
    """The run as an MCAP file: every message at its own timestamp, its configuration attached."""
    fd, tmp = tempfile.mkstemp(suffix=".mcap")
    os.close(fd)
    try:
        with McapRecorder(tmp) as rec:
            rec.add_metadata("navbank.run", {"run_id": run_id, "seed": str(result.seed), "source": "campaign"})
            rec.add_attachment("config.yaml", to_yaml(result.config, complete=True).encode("utf-8"), "application/yaml")
            for topic, msg in result.messages:
                t_ns = publish_time_of(msg)
                rec.write_message(topic, msg, log_time_ns=t_ns if t_ns is not None else 0)
        with open(tmp, "rb") as fh:
            return fh.read()
    finally:
        os.unlink(tmp)
