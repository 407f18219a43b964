"""What a campaign worker does with one run: fly it in process and return one result row.

The function is importable by name (``tools.campaign.worker.execute``) so a spawned process pool
and a dask worker run the same code. Its input and output are plain data: the row (the run's
summary, id, cell, seed, status, error, wall time) and, on request, gating networks' weight
histories as compact arrays — never the run's messages, which are ~10^5 objects for a 45-day run.

Any exception raised by the run itself is caught here and becomes a ``failed`` row with the error
type, message and the tail of the traceback: one bad run never stops a campaign.
"""

from __future__ import annotations

import os
import socket
import time
import traceback
from typing import Any

import numpy as np

from fsw.interface import topics, typed
from tools.inprocess import RunResult, run_in_process
from tools.scenario import ScenarioConfig

TRACEBACK_LINES = 12


def weight_history(result: RunResult, network: str) -> dict[str, Any]:
    """The FilterWeights history of ``network``: filter names, epochs, batch indices, weights,
    per-filter statistics and (hierarchical networks) the top-level weight of each bank."""
    msgs = result.topic(f"{topics.FSW_WEIGHTS}/{network}")
    if not msgs:
        return {"filters": [], "t_s": np.zeros(0), "batch": np.zeros(0, dtype=np.int64),
                "weights": np.zeros((0, 0)), "statistic": np.zeros((0, 0)), "group_names": [],
                "groups": np.zeros((0, 0))}
    group_names = list(msgs[-1].groups)
    stat_len = len(msgs[-1].statistic)
    return {
        "filters": list(msgs[-1].filters),
        "t_s": np.array([m.t_s for m in msgs], dtype=float),
        "batch": np.array([m.batch for m in msgs], dtype=np.int64),
        "weights": np.array([m.weights for m in msgs], dtype=float),
        "statistic": np.array([m.statistic if len(m.statistic) == stat_len else (np.nan,) * stat_len
                               for m in msgs], dtype=float),
        "group_names": group_names,
        "groups": np.array([[m.groups.get(g, np.nan) for g in group_names] for m in msgs], dtype=float),
    }


def error_record(exc: BaseException) -> dict[str, str]:
    tb = traceback.format_exception(type(exc), exc, exc.__traceback__)
    tail = "".join(tb).rstrip().splitlines()[-TRACEBACK_LINES:]
    return {"type": type(exc).__name__, "message": str(exc), "traceback": "\n".join(tail)}


def base_row(payload: dict) -> dict[str, Any]:
    return {
        "id": payload["id"], "cell": payload["cell"], "seed": payload["seed"],
        "fault_class": payload["fault_class"], "detector": payload["detector"],
        "span_days": payload["span_days"],
    }


def execute(payload: dict) -> dict[str, Any]:
    """Run one campaign run; returns ``{"row": row, "weights": None | {network: arrays}}``."""
    t0 = time.perf_counter()
    row = base_row(payload)
    row.update({"host": socket.gethostname(), "pid": os.getpid()})
    weights = None
    try:
        cfg = typed.decode(ScenarioConfig, payload["scenario"])
        result = run_in_process(cfg, payload["seed"], fault_label=payload["fault_label"], run_id=payload["id"])
        nets = payload.get("extract_weights") or ()
        if nets:
            weights = {net: weight_history(result, net) for net in nets}
        row.update({"status": "ok", "error": None, "summary": result.summary})
        del result
    except Exception as exc:  # a failed run is data for the campaign, not the end of it
        row.update({"status": "failed", "error": error_record(exc), "summary": None})
    row["wall_time_s"] = time.perf_counter() - t0
    row["finished_utc"] = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    return {"row": row, "weights": weights}
