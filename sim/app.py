"""``navbank sim`` as a process: publish the simulator's stream over Zenoh.

The whole run is generated first (deterministic, a few seconds), then published in time order:
fault events, truth and measurements interleaved as ``SimRun.iter_messages`` orders them. Paced
as fast as possible by default, or at ``rate`` × real time.

Delivery of measurements to the FSW is lossless even when the FSW stalls: a credit window keeps
the simulator at most ``window`` measurements ahead of what the FSW has taken. The run ends with
an end-of-run ``RunStatus`` (counts per topic) and the drain handshake with every consumer
before the session closes (:class:`fsw.transport.ProcessLifecycle`).
"""

from __future__ import annotations

import time
from typing import Callable, Sequence

import fsw.transport as tp
from sim.truth.timescales import tdb_to_unix
from fsw.interface import topics
from fsw.interface.messages import Measurement, RunState, RunStatus, Stamp
from sim.resend import RESEND_FROM, RESENT, ResendingPublisher, Rewind
from sim.stream import SimRun


def _status(run: SimRun, run_id: str, state: RunState, counts: dict[str, int], t: float, message: str = "") -> RunStatus:
    return RunStatus(t_s=t, timestamp=Stamp.from_unix(float(tdb_to_unix(t))), run_id=run_id, source="sim",
                     state=state, counts=counts, message=message)


def publish_run(
    run: SimRun,
    run_id: str,
    transport_cfg: tp.TransportConfig | None = None,
    *,
    consumers: Sequence[str] = ("fsw", "ground"),
    credit_role: str | None = "fsw",
    window: int = 2000,
    rate: float | None = None,
    wait_s: float = 60.0,
    progress: Callable[[float], None] | None = None,
    hold_for_logger_s: float | None = None,
) -> dict[str, int]:
    """Publish ``run`` under ``navbank/<run_id>/sim/...``; returns the end-of-run counts.

    ``consumers`` are the roles that must be up before the first message and must confirm the
    end of the stream; ``credit_role`` (one of them) paces the measurements. With
    ``hold_for_logger_s`` publishing waits while the logger is away (being restarted), at most
    that long each time.
    """
    # SIGINT/SIGTERM keep their default action: a stopped simulator has nothing left to save.
    with tp.ProcessLifecycle(run_id, transport_cfg, handle_signals=False) as life:
        life.wait_for_consumers(consumers, timeout_s=wait_s)
        credit = []
        if credit_role is not None:
            credit.append(tp.CreditWindow(life.session, run_id, credit_role, topics.SIM_MEASUREMENTS, window=window))
        pubs = {
            topics.SIM_MEASUREMENTS: life.publisher(topics.SIM_MEASUREMENTS, credit=credit),
            topics.SIM_TRUTH: life.publisher(topics.SIM_TRUTH),
            topics.SIM_FAULTS: life.publisher(topics.SIM_FAULTS),
        }
        if hold_for_logger_s is not None:
            life.hold_while_away(topics.SIM_TRUTH, hold_for_logger_s)  # only the logger takes the truth
        # a restarted FSW is sent again what came after its checkpoint (sim/resend.py)
        measurements = ResendingPublisher(pubs[topics.SIM_MEASUREMENTS])

        def say_resent(rewind: Rewind) -> None:
            # on the record: when and from where the restarted FSW was sent the stream again
            first = rewind.resume_from
            t = measurements.sent[first].t_s if first < len(measurements.sent) else run.t_start
            life.put(topics.SIM_STATUS, _status(
                run, run_id, "running", {RESEND_FROM: first, RESENT: max(0, rewind.sent - first)}, t,
                "the FSW restarted: measurements sent again from its checkpoint"))

        measurements.on_rewind = say_resent
        life.put(topics.SIM_STATUS, _status(run, run_id, "start", {"measurements": len(run.measurements)}, run.t_start))
        wall0 = time.monotonic()
        n = max(len(run.measurements), 1)
        sent = 0
        next_progress = 0.0
        for topic, msg in run.iter_messages():
            if rate is not None:
                due = wall0 + (msg.t_s - run.t_start) / rate
                delay = due - time.monotonic()
                if delay > 0:
                    time.sleep(delay)
            if not isinstance(msg, Measurement):
                pubs[topic].put(msg)
                continue
            measurements.put(msg)
            sent += 1
            if progress is not None and time.monotonic() >= next_progress:
                progress(sent / n)
                next_progress = time.monotonic() + 1.0
        counts = tp.end_of_run_counts(pubs.values(), measurements=pubs[topics.SIM_MEASUREMENTS].count)
        end = _status(run, run_id, "end-of-run", counts, run.t_end)
        life.announce_end(topics.SIM_STATUS, end)

        def on_reply(role: str, reply: RunStatus) -> None:
            for window in credit:
                if role == window.role:
                    window.observe(reply)

        while True:
            try:
                life.confirm_end(end, consumers, timeout_s=max(wait_s, 30.0), on_reply=on_reply)
                break
            except tp.ConsumerRestarted as restart:  # the FSW restarted after the last measurement went out
                measurements.rewind(restart)
        counts = dict(counts, resent=measurements.resent, consumer_restarts=len(measurements.rewinds),
                      credit_queries=sum(w.queries for w in credit), credit_waits=sum(w.waits for w in credit))
        if progress is not None:
            progress(1.0)
        return counts
