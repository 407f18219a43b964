"""``navbank fsw`` as a process: the flight software on Zenoh.

Subscribes to measurements and the simulator's status only — never to truth: the subscription
names exactly those two topics, and any sample on another topic is refused and counted. Raw
measurement payloads go to :class:`fsw.core.FswCore`, which decodes them strictly (malformed ones
are counted, never fatal), re-orders within a window, and runs the bank, gating and detector
under the frame executive. Telemetry is published as it is produced; telecommands are served
between measurements on this thread (no locking of the core needed).

The run ends when the simulator's end-of-run status has arrived and every announced measurement
has been taken: the core drains its backlog, publishes its end-of-run status, and waits for the
ground logger to confirm it has everything before closing.
"""

from __future__ import annotations

import sys
import time
from typing import Callable, Sequence

import fsw.transport as tp
from fsw.config import FswConfig
from fsw.core import FswCore
from fsw.interface import topics

ALLOWED_TOPICS = (topics.SIM_MEASUREMENTS, topics.SIM_STATUS)


def run_fsw(
    config: FswConfig,
    run_id: str,
    transport_cfg: tp.TransportConfig | None = None,
    *,
    consumers: Sequence[str] = ("ground",),
    producer: str = "sim",
    stop_event: tp.StopFlag | None = None,
    progress: Callable[[str], None] | None = None,
    idle_timeout_s: float | None = None,
    handle_signals: bool = True,
) -> dict[str, int]:
    """Run the FSW for run ``run_id`` until the producer's stream ends; returns its counters."""
    with tp.ProcessLifecycle(run_id, transport_cfg, stop_event=stop_event, handle_signals=handle_signals) as life:
        core = FswCore(config, life.put, run_id=run_id)
        # the FIFO must hold more than the producer's credit window (see CreditWindow)
        sub = life.subscriber(ALLOWED_TOPICS, decode=False, role="fsw", capacity=16384)
        server = life.command_server(core.command, threaded=False, on_malformed=core.record_malformed_command,
                                     on_refused=core.record_refused_command)
        refused = 0
        core.extra_counters = lambda: {
            "refused_topics": refused,
            "transport_gaps": sum(sub.gaps.values()),
            # authentication refusals (only with the run's key): telecommands, and statuses or
            # drain queries that would have ended the run
            "refused_commands": server.refused,
            "refused_statuses": sum(sub.refused.values()),
        }
        core.start()
        last_data = time.monotonic()
        next_progress = 0.0
        while True:
            got = sub.recv(timeout=0.02)
            life.poll_commands()
            now = time.monotonic()
            if got is not None:
                last_data = now
                if got.topic == topics.SIM_MEASUREMENTS:
                    core.ingest_payload(got.payload)
                elif got.topic != topics.SIM_STATUS:
                    refused += 1  # truth or anything else is never let in
            elif sub.finished([producer]):
                break
            if life.should_stop():
                # say how far it got before it goes, so the recording holds the final counters
                core.stopped(f"stopped ({life.stop_reason()})")
                raise KeyboardInterrupt
            if idle_timeout_s is not None and now - last_data > idle_timeout_s:
                raise tp.TransportError(f"no data from {producer} for {idle_timeout_s:g} s")
            if progress is not None and now >= next_progress:
                next_progress = now + 2.0
                progress(_progress_line(core))

        # the core publishes its end-of-run status, whose per-topic counts let the logger
        # confirm it has everything
        end = core.finish()
        counts = dict(end.counts)

        life.confirm_end(end, consumers, timeout_s=30.0)
        # stay until the producer has been told we have everything (its drain), or a while
        life.wait_acknowledged(sub, [producer], timeout_s=15.0)
        if progress is not None:
            progress(_progress_line(core) + " done")
        return counts


def _progress_line(core: FswCore) -> str:
    days = (core.t_last - core.t0) / 86400.0
    c = core.status_counts()
    flag = "none"
    if core.detector is not None and core.detector.state.flag:
        flag = core.detector.state.anomaly_class
    return (f"fsw: day {days:5.1f}  processed {c['processed']}  rejected {c['rejected']}  "
            f"backlog {c['backlog']}  anomaly {flag}")


def stderr_progress(line: str) -> None:
    print(line, file=sys.stderr, flush=True)
