"""Fly the recorded measurements through a fresh FSW in this process.

The recorded ``/sim/measurements`` payloads are fed to :class:`fsw.core.FswCore` — the code the
``navbank fsw`` process runs — in sequence order, and its telemetry is collected exactly as the
process would publish it: ``start`` status, telemetry as produced, the drain at end of stream,
then the end-of-run status with the per-topic message counts the process announces. The budget
is accounted in the mode the configuration says (work units: deterministic; CPU: measured thread
time, as the recorded run did).

Payloads that do not decode are fed raw at the position they were recorded (the core counts
them as decode errors, as the process did); decodable ones are ordered by sequence number
(stable, so duplicates keep their recorded order).

Telecommands are part of the record (``/fsw/commands``, one ``CommandRecord`` per command
served): each is served again after as many measurement payloads as the FSW had taken when it
served it (``taken``), or after the end-of-run sequence if that is when it came, so a commanded
run re-runs identically in work-unit mode. A payload that did not decode changed nothing but a
transport counter; its record is carried over as recorded.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from fsw.config import FswConfig
from fsw.core import FswCore, FswMessage
from fsw.interface import codec, topics
from fsw.interface.messages import CommandRecord, Measurement
from ground.replay.recording import iter_raw

MEASUREMENTS = topics.mcap_topic(topics.SIM_MEASUREMENTS)
INVALID_MEASUREMENTS = "/_invalid" + MEASUREMENTS
COMMANDS = topics.mcap_topic(topics.FSW_COMMANDS)


@dataclass
class RerunResult:
    """What the fresh FSW produced."""

    outputs: list[tuple[str, FswMessage]] = field(default_factory=list)  # (topic, message) in emission order
    measurements: int = 0  # decodable measurements fed
    undecodable: int = 0  # raw payloads fed that the core rejected as malformed
    elapsed_s: float = 0.0


def recorded_measurement_stream(path: str | os.PathLike) -> tuple[list[Measurement | bytes], int]:
    """Recorded measurements in feeding order, and how many did not decode (kept as bytes)."""
    groups: list[tuple[int, int, list[Measurement | bytes]]] = [(-1, -1, [])]
    bad = 0
    for i, raw in enumerate(iter_raw(path, topics=(MEASUREMENTS, INVALID_MEASUREMENTS))):
        try:
            meas = codec.from_json(Measurement, raw.data)
        except codec.ICDError:
            groups[-1][2].append(raw.data)  # stays right after the measurement recorded before it
            bad += 1
            continue
        groups.append((meas.seq, i, [meas]))
    groups.sort(key=lambda g: (g[0], g[1]))
    return [item for _, _, items in groups for item in items], bad


def recorded_commands(path: str | os.PathLike) -> list[CommandRecord]:
    """The telecommands the recorded FSW served, in the order it served them (undecodable
    records are skipped: the comparison reports them)."""
    raws = sorted(iter_raw(path, topics=(COMMANDS,)), key=lambda r: r.sequence)
    out = []
    for raw in raws:
        try:
            out.append(codec.from_json(CommandRecord, raw.data))
        except codec.ICDError:
            continue
    return out


def _serve(core: FswCore, record: CommandRecord) -> None:
    if record.refused:
        core.record_refused_command(record.telecommand, record.payload, record.reply, record.refused)
    elif record.telecommand is not None:
        core.command(record.telecommand)
    else:
        core.record_malformed_command(record.payload, record.reply)


def rerun_fsw(config: FswConfig, stream: list[Measurement | bytes], run_id: str = "rerun",
              commands: Sequence[CommandRecord] = (), observe: Callable[[FswCore], None] | None = None) -> RerunResult:
    """Run ``config``'s FSW over ``stream`` the way the FSW process does; collect its telemetry.
    ``observe`` is handed the core before it starts (ground post-processing taps what the bank
    computes, e.g. ``ground.tuning.recorded_residuals``)."""
    result = RerunResult()
    t0 = time.monotonic()
    core = FswCore(config, lambda topic, msg: result.outputs.append((topic, msg)), run_id=run_id)
    if observe is not None:
        observe(core)
    core.start()
    during = sorted((c for c in commands if not c.ended), key=lambda c: c.taken)  # stable: served order
    k = 0
    for item in stream:
        while k < len(during) and during[k].taken <= core.taken:
            _serve(core, during[k])
            k += 1
        if isinstance(item, Measurement):
            core.ingest(item)
            result.measurements += 1
        else:
            core.ingest_payload(item)
            result.undecodable += 1
    for record in during[k:]:
        _serve(core, record)
    core.finish()
    for record in commands:
        if record.ended:
            _serve(core, record)
    result.elapsed_s = time.monotonic() - t0
    return result
