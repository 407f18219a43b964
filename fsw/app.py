"""``navbank fsw`` as a process: the flight software on Zenoh.

Subscribes to measurements and the simulator's status only — never to truth: the subscription
names exactly those two topics, and any sample on another topic is refused and counted. Raw
measurement payloads go to :class:`fsw.core.FswCore`, which decodes them strictly (malformed ones
are counted, never fatal), re-orders within a window, and runs the bank, gating and detector
under the frame executive. Telemetry is published in runs, between measurements, once no
measurement is waiting or the outbox is full (:mod:`fsw.transport.outbox`): never inside a
pipeline stage; telecommands are served between measurements on this thread (no locking of the
core needed).

The run ends when the simulator's end-of-run status has arrived and every announced measurement
has been taken: the core drains its backlog, publishes its end-of-run status, and waits for the
ground logger to confirm it has everything before closing.
"""

from __future__ import annotations

import os
import secrets
import sys
import time
from typing import Callable, Sequence

import fsw.transport as tp
from fsw import kernels
from fsw.config import FswConfig
from fsw.core import FswCore, checkpoint
from fsw.interface import topics

ALLOWED_TOPICS = (topics.SIM_MEASUREMENTS, topics.SIM_STATUS)
#: samples the FSW takes from its subscriptions at once: enough for the back-to-back gain (the
#: producer is usually a credit window ahead), few enough that a stop finds little taken but
#: unprocessed (it is counted as unread all the same)
RECEIVE_BATCH = 32


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
    checkpoint_path: str | os.PathLike[str] | None = None,
    resume: str | os.PathLike[str] | None = None,
    hold_for_logger_s: float | None = None,
) -> dict[str, int]:
    """Run the FSW for run ``run_id`` until the producer's stream ends; returns its counters.

    With ``checkpoint_path`` the FSW saves its state there at the configured cadence
    (``fsw.checkpoint``), right after it starts and once the stream is complete; with ``resume``
    it goes on from such a checkpoint (:class:`fsw.core.checkpoint.CheckpointError` if it is not
    this run's and configuration's) and the producer resends what came after it. With
    ``hold_for_logger_s`` telemetry waits while the logger is away (being restarted), at most
    that long each time."""
    # The kernels before the session: the peers wait minutes for this process's session to open,
    # and then seconds for its subscriptions. On a machine's first run the kernels are compiled
    # here (over a minute of CPU on a slow 2-vCPU machine): opened first, the session would
    # have made a simulator give up waiting for the FSW's subscriptions while they compiled.
    kernels.load_all()
    with tp.ProcessLifecycle(run_id, transport_cfg, stop_event=stop_event, handle_signals=handle_signals) as life:
        signer = None if life.authenticator is None else life.authenticator.file_tag
        # telemetry goes out in runs of puts, not one by one (see fsw.transport.outbox)
        outbox = tp.Outbox(life.put)
        restored = None if resume is None else checkpoint.read(resume, config, run_id, outbox.put, signer)
        if restored is None:
            core = FswCore(config, outbox.put, run_id=run_id)
        else:
            core = restored.core
            life.restore_publishers(restored.published)
            for topic, msg in restored.unpublished:  # first, as it would have been
                outbox.put(topic, msg)
        if hold_for_logger_s is not None:
            life.hold_while_away(topics.FSW_STATUS, hold_for_logger_s)  # only the logger takes the status
        # the FIFO must hold more than the producer's credit window (see CreditWindow); samples
        # are taken RECEIVE_BATCH at a time (see Subscriber), still processed one by one
        sub = life.subscriber(ALLOWED_TOPICS, decode=False, role="fsw", capacity=16384, batch=RECEIVE_BATCH,
                              resume=None if restored is None else {topics.SIM_MEASUREMENTS: restored.measurements_taken})
        # every start of the process is told apart; a resumed one says where it goes on from
        sub.progress_extra[tp.INCARNATION] = secrets.randbelow(2**31)
        if restored is not None:
            sub.progress_extra[tp.RESUMED_FROM] = restored.measurements_taken
            if restored.producer_end is not None:
                sub.end_of_run[producer] = restored.producer_end
        server = life.command_server(core.command, threaded=False, on_malformed=core.record_malformed_command,
                                     on_refused=core.record_refused_command)
        if restored is not None:
            server.restore_nonces(restored.accepted_nonces)
        refused = 0
        at_stop: dict[str, int] = {}  # counters added as it goes or stops
        core.extra_counters = lambda: {
            "refused_topics": refused,
            "transport_gaps": sum(sub.gaps.values()),
            # authentication refusals (only with the run's key): telecommands, and statuses or
            # drain queries that would have ended the run
            "refused_commands": server.refused,
            "refused_statuses": sum(sub.refused.values()),
            **at_stop,
        }
        if restored is None:
            core.start()
        ckpt = config.checkpoint
        schedule = checkpoint.Schedule(ckpt.every_measurements, ckpt.every_s, core.taken, core.t_last)

        served_at_save = server.served

        def save() -> None:
            nonlocal served_at_save
            served_at_save = server.served
            if checkpoint_path is not None:
                # The telemetry not yet published goes into the checkpoint, which counts what was:
                # a restart publishes it first, under the numbers it would have had. (Published
                # first, a burst put just before the checkpoint may still wait in Zenoh's queue, and
                # die with a process killed right after it while the restart goes on after it.)
                try:
                    checkpoint.write(checkpoint_path, checkpoint.Checkpoint(
                        core, core.taken, {t: p.count for t, p in life.publishers.items()},
                        sub.end_of_run.get(producer), server.accepted_nonces, outbox.held()), signer)
                except OSError:
                    # a full disk must not stop the flight software: the previous checkpoint stays
                    at_stop["checkpoint_errors"] = at_stop.get("checkpoint_errors", 0) + 1
            outbox.flush()
            schedule.mark(core.taken, core.t_last)

        if restored is None:
            save()  # a restart before the first cadence point goes on from the start, not from nothing
        last_data = time.monotonic()
        next_progress = 0.0
        try:
            while True:
                # the outbox is flushed once no measurement is waiting (or holds its limit)
                got = sub.recv(timeout=0.0 if outbox.pending else 0.02)
                if got is None and outbox.pending:
                    outbox.flush()
                    got = sub.recv(timeout=0.02)
                if life.poll_commands() and server.served != served_at_save:
                    # a served command changes state: keep it (and its nonce) before anything else
                    save()
                now = time.monotonic()
                if got is not None:
                    last_data = now
                    if got.topic == topics.SIM_MEASUREMENTS:
                        # with the measurements the batch took behind it, decoded back to back
                        # (commands are then served between such runs, at most RECEIVE_BATCH apart)
                        run = sub.next_taken(topics.SIM_MEASUREMENTS)
                        core.ingest_payloads([got.payload, *(g.payload for g in run)])
                        if schedule.due(core.taken, core.t_last):
                            save()
                        if outbox.full:
                            outbox.flush()  # here, between measurements: outside the core's stages
                    elif got.topic != topics.SIM_STATUS:
                        refused += 1  # truth or anything else is never let in
                elif sub.finished([producer]):
                    save()  # the producer may be gone by the time a restart would ask it to resend
                    break
                if life.should_stop():
                    # what was delivered but not yet taken is not processed either: counted, with the
                    # measurements queued before the filter bank and what the intake holds, in the status
                    # that says how far it got
                    unread = sum(1 for g in sub.drain_available() if g.topic == topics.SIM_MEASUREMENTS)
                    at_stop.update(unread=unread, unprocessed=unread + core.unprocessed())
                    core.stopped(f"stopped ({life.stop_reason()})")
                    raise KeyboardInterrupt  # the stop status goes out with the rest (below)
                if idle_timeout_s is not None and now - last_data > idle_timeout_s:
                    raise tp.TransportError(f"no data from {producer} for {idle_timeout_s:g} s")
                if progress is not None and now >= next_progress:
                    next_progress = now + 2.0
                    progress(_progress_line(core))
        except BaseException:
            # whatever ends the process early, what the core emitted still goes out if it can
            try:
                outbox.flush()
            except Exception:
                pass
            raise

        # the core publishes its end-of-run status, whose per-topic counts let the logger
        # confirm it has everything
        end = core.finish()
        outbox.flush()
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
