"""The re-run written as a run of its own: ``navbank replay --rerun --out DIR``.

``DIR/run.mcap`` holds what the recorded run's ground had — measurements, truth, fault events,
the simulator's statuses, copied byte for byte — with the re-run FSW's telemetry in place of
the recorded FSW's, so ``navbank report DIR`` draws the changed FSW against the same truth.
Every message is logged at its own timestamp (simulated time): the recording's receive times
belong to another run of the clock and would interleave the two wrongly. ``DIR/config.yaml``
(also attached) is the recorded scenario with the re-run's ``fsw:`` section, so the new file
re-runs as it is.
"""

from __future__ import annotations

import os
from pathlib import Path

import yaml

from fsw.config import FswConfig
from fsw.interface import codec, topics, typed
from fsw.interface.yamlconfig import parse_yaml
from ground.mcap_io.recorder import INVALID_PREFIX, McapRecorder, publish_time_of
from ground.replay.recording import CONFIG_ATTACHMENT, iter_raw
from ground.replay.rerun import RerunResult

RUN_MCAP = "run.mcap"
FSW_PREFIXES = ("/fsw/", INVALID_PREFIX + "/fsw/")


def rerun_config_text(recorded_text: str, config: FswConfig, file: str) -> str:
    """The recorded scenario YAML with its ``fsw:`` section replaced by ``config``."""
    data, _ = parse_yaml(recorded_text, file)
    if not isinstance(data, dict):
        data = {}
    data["fsw"] = typed.encode(config)
    return yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=100, allow_unicode=True)


def write_rerun_run(recording: str | os.PathLike, rerun: RerunResult, config_text: str, out_dir: str | os.PathLike,
                    *, run_id: str, changes: list[str]) -> Path:
    """Write ``out_dir/run.mcap`` and ``out_dir/config.yaml``; returns the MCAP path."""
    out = Path(out_dir)
    (out / CONFIG_ATTACHMENT).write_text(config_text, encoding="utf-8")
    rows: list[tuple[int, int, str, bytes, int]] = []  # (log time, order, topic, payload, sequence)
    for i, raw in enumerate(iter_raw(recording)):
        if not raw.topic.startswith(FSW_PREFIXES):
            rows.append((raw.publish_time_ns, i, raw.topic, raw.data, raw.sequence))
    base = len(rows)
    for j, (topic, msg) in enumerate(rerun.outputs):
        stamp = publish_time_of(msg)
        rows.append((stamp if stamp is not None else 0, base + j, topics.mcap_topic(topic), codec.to_json(msg), j))
    rows.sort(key=lambda r: (r[0], r[1]))
    path = out / RUN_MCAP
    with McapRecorder(path) as rec:
        rec.add_metadata("navbank.run", {"run_id": run_id, "rerun_of": os.fspath(recording),
                                         "changes": " ".join(changes) or "none"})
        rec.add_attachment(CONFIG_ATTACHMENT, config_text.encode("utf-8"), "application/yaml")
        for t_ns, _, topic, data, seq in rows:
            rec.write(topic, data, t_ns, t_ns, seq)
    return path
