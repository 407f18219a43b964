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

import signal
import sys
import threading
import time
from typing import Any, Callable, Sequence

from fsw.config import FswConfig
from fsw.core import FswCore
from fsw.interface import messages as m, topics, transport as tp

ALLOWED_TOPICS = (topics.SIM_MEASUREMENTS, topics.SIM_STATUS)


class _Telemetry:
    """Publishers declared once per topic, on first use."""

    def __init__(self, session: Any, run_id: str):
        self.session, self.run_id = session, run_id
        self.pubs: dict[str, tp.Publisher] = {}

    def __call__(self, topic: str, msg: Any) -> None:
        pub = self.pubs.get(topic)
        if pub is None:
            pub = self.pubs[topic] = tp.Publisher(self.session, self.run_id, topic)
        pub.put(msg)

    def close(self) -> None:
        for p in self.pubs.values():
            p.close()


def run_fsw(
    config: FswConfig,
    run_id: str,
    transport_cfg: tp.TransportConfig | None = None,
    *,
    consumers: Sequence[str] = ("ground",),
    producer: str = "sim",
    stop_event: Any = None,
    progress: Callable[[str], None] | None = None,
    idle_timeout_s: float | None = None,
    handle_signals: bool = True,
) -> dict[str, int]:
    """Run the FSW for run ``run_id`` until the producer's stream ends; returns its counters."""
    stop = threading.Event()
    old: dict[int, Any] = {}
    if handle_signals and threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGINT, signal.SIGTERM):
            old[sig] = signal.signal(sig, lambda *_: stop.set())
    try:
        with tp.open_session(transport_cfg) as session:
            tel = _Telemetry(session, run_id)
            core = FswCore(config, tel, run_id=run_id)
            # the FIFO must hold more than the producer's credit window (see CreditWindow)
            sub = tp.Subscriber(session, run_id, ALLOWED_TOPICS, decode=False, role="fsw", capacity=16384)
            server = tp.declare_command_server(session, run_id, core.command, threaded=False)
            refused = 0
            core.extra_counters = lambda: {
                "commands_malformed": int(server.status()["malformed"]),
                "refused_topics": refused,
                "transport_gaps": sum(sub.gaps.values()),
            }
            try:
                core.start()
                last_data = time.monotonic()
                next_progress = 0.0
                while True:
                    got = sub.recv(timeout=0.02)
                    server.poll()
                    now = time.monotonic()
                    if got is not None:
                        last_data = now
                        if got.topic == topics.SIM_MEASUREMENTS:
                            core.ingest_payload(got.payload)
                        elif got.topic != topics.SIM_STATUS:
                            refused += 1  # truth or anything else is never let in
                    elif sub.finished([producer]):
                        break
                    if stop.is_set() or (stop_event is not None and stop_event.is_set()):
                        raise KeyboardInterrupt
                    if idle_timeout_s is not None and now - last_data > idle_timeout_s:
                        raise tp.TransportError(f"no data from {producer} for {idle_timeout_s:g} s")
                    if progress is not None and now >= next_progress:
                        next_progress = now + 2.0
                        progress(_progress_line(core))
                # its end-of-run status announces the per-topic counts so the logger can confirm it has everything
                end = core.finish()
                counts = dict(end.counts)
                done = tp.drain(session, run_id, end, consumers, timeout_s=30.0)
                missing = [c for c, ok in done.items() if not ok]
                if missing:
                    raise tp.TransportError(f"no end-of-stream confirmation from {', '.join(missing)}")
                # stay until the producer has been told we have everything (its drain), or a while
                linger_end = time.monotonic() + 15.0
                while not sub.acknowledged.get(producer) and time.monotonic() < linger_end:
                    server.poll()
                    time.sleep(0.01)
                time.sleep(0.2)  # let the last reply leave before the session closes
                if progress is not None:
                    progress(_progress_line(core) + " done")
                return counts
            finally:
                server.close()
                sub.close()
                tel.close()
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)


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
