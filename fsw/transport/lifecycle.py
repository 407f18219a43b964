"""The life of one navbank process on Zenoh, from its signal handlers to its last reply.

The simulator, the FSW, the ground logger and the replay live the same way, and the order of
the steps is what keeps a run lossless and lets every process exit:

1. SIGINT/SIGTERM (if handled) only set a stop flag, so the process's own loop decides how to
   stop and every way out still runs the steps below; the previous handlers come back at the end.
2. One session, opened in this process (never inherited through fork).
3. Publishers, subscribers and command servers are registered here and undeclared on every
   path, before the session closes: a Python callback still declared at exit hangs the process.
4. A producer ends its stream by publishing its end-of-run status and draining into its
   consumers (:func:`fsw.transport.flow.drain`): closing right after the last put would lose
   what is in flight. A consumer that did not confirm is an error naming it.
5. A process that is also a consumer stays until its producers' drain queries were answered,
   then lingers a moment so the last reply leaves before the session closes.

With credentials in the transport configuration the lifecycle holds the run's key: its
publishers sign the statuses they put, its subscribers and command servers refuse statuses and
telecommands without a valid tag, and the end-of-stream drain sends a signed status.
"""

from __future__ import annotations

import signal
import threading
import time
from collections.abc import Callable, Iterable, Sequence
from contextlib import ExitStack
from typing import Any, Protocol

import zenoh

from fsw.interface.auth import MessageAuthenticator
from fsw.interface.messages import RunStatus, Telecommand, TelecommandReply
from fsw.transport import flow
from fsw.transport.commands import CommandServer
from fsw.transport.pubsub import ConsumerHold, Publisher, Subscriber, TopicPublisher
from fsw.transport.session import TransportConfig, TransportError, open_session

#: Time for a last query reply to leave before the session closes.
REPLY_LINGER_S = 0.2


class StopFlag(Protocol):
    """What asks a process to stop from outside: a threading or multiprocessing event."""

    def is_set(self) -> bool: ...


class ProcessLifecycle:
    """``with ProcessLifecycle(run_id, cfg) as life:`` — a process's session and endpoints on run ``run_id``.

    ``stop_event`` is anything with ``is_set()`` (threading or multiprocessing events) that asks
    the process to stop from outside. With ``handle_signals`` (honoured on the main thread only,
    the one Python delivers signals to) SIGINT and SIGTERM ask it to stop too.
    """

    def __init__(
        self,
        run_id: str,
        transport_cfg: TransportConfig | None = None,
        *,
        stop_event: StopFlag | None = None,
        handle_signals: bool = True,
    ):
        self.run_id = run_id
        self.transport_cfg = transport_cfg
        self.stop_event = stop_event
        self.handle_signals = handle_signals
        creds = transport_cfg.credentials if transport_cfg is not None else None
        #: signs and checks statuses and telecommands with the run's key (None: no credentials)
        self.authenticator = MessageAuthenticator(creds.run_key) if creds is not None else None
        self._session: zenoh.Session | None = None
        self._signalled = threading.Event()
        self._pubs: dict[str, TopicPublisher] = {}
        self._subs: list[Subscriber] = []
        self._servers: list[CommandServer] = []
        self._stack = ExitStack()
        self._hold: ConsumerHold | None = None

    # -- entering and leaving ------------------------------------------------------------
    def __enter__(self) -> "ProcessLifecycle":
        with ExitStack() as stack:
            if self.handle_signals and threading.current_thread() is threading.main_thread():
                for sig in (signal.SIGINT, signal.SIGTERM):
                    stack.callback(signal.signal, sig, signal.signal(sig, self._on_signal))
            stack.callback(setattr, self, "_session", None)
            self._session = stack.enter_context(open_session(self.transport_cfg))
            stack.callback(self._close_endpoints)
            self._stack = stack.pop_all()
        return self

    def __exit__(self, *exc: Any) -> None:
        self._stack.close()

    def _on_signal(self, signum: int, frame: Any) -> None:
        self._signalled.set()

    def _close_endpoints(self) -> None:
        # Servers first: a threaded command handler may still publish through the publishers.
        endpoints: list[CommandServer | Subscriber | TopicPublisher] = [*self._servers, *self._subs, *self._pubs.values()]
        for endpoint in endpoints:
            try:
                endpoint.close()
            except zenoh.ZError:
                pass  # the others must still be undeclared
        self._servers, self._subs, self._pubs = [], [], {}

    # -- stopping ----------------------------------------------------------------------------
    @property
    def signalled(self) -> bool:
        """SIGINT or SIGTERM arrived while the handlers were installed."""
        return self._signalled.is_set()

    def stop_reason(self) -> str | None:
        """``"signal"``, ``"stop"`` (the stop event) or None while the process should go on."""
        if self.signalled:
            return "signal"
        if self.stop_event is not None and self.stop_event.is_set():
            return "stop"
        return None

    def should_stop(self) -> bool:
        return self.stop_reason() is not None

    # -- endpoints ---------------------------------------------------------------------------
    def publisher(self, topic: str, *, credit: Sequence[flow.CreditWindow] = ()) -> Publisher:
        """The ICD publisher of ``topic``, declared on first use and closed with the lifecycle
        (later calls return the first one whatever their ``credit``)."""
        pub = self._pubs.get(topic)
        if pub is None:
            pub = self._pubs[topic] = Publisher(self.session, self.run_id, topic, credit=credit,
                                                authenticator=self.authenticator)
            pub.hold = self._hold
        if not isinstance(pub, Publisher):
            raise TypeError(f"{topic} was declared with a publisher of raw payloads, not ICD messages")
        return pub

    def hold_while_away(self, sentinel_topic: str, timeout_s: float) -> ConsumerHold:
        """Hold every put of this process while the consumer of ``sentinel_topic`` (one only the
        logger takes) is away, at most ``timeout_s`` per absence (:class:`ConsumerHold`): what is
        published while a logger is restarted waits for the new one instead of being lost."""
        self._hold = ConsumerHold(self.publisher(sentinel_topic), timeout_s)
        for pub in self._pubs.values():
            if isinstance(pub, Publisher):
                pub.hold = self._hold
        return self._hold

    def restore_publishers(self, counts: dict[str, int]) -> None:
        """Declare the publishers of ``counts``' topics with their sequence counters where a
        checkpoint left them: what a restarted process publishes again carries the numbers it
        carried the first time (so the logger recognises it as a duplicate)."""
        for topic, n in counts.items():
            self.publisher(topic).count = int(n)

    def raw_publisher(self, topic: str, make: Callable[[str], TopicPublisher]) -> TopicPublisher:
        """The publisher ``make(topic)`` builds (e.g. of recorded payloads on a topic outside the
        ICD), declared on first use and closed with the lifecycle."""
        pub = self._pubs.get(topic)
        if pub is None:
            pub = self._pubs[topic] = make(topic)
        return pub

    def put(self, topic: str, msg: object) -> None:
        """Publish ``msg`` on ``topic`` (an ICD topic), declaring its publisher on first use."""
        self.publisher(topic).put(msg)

    @property
    def publishers(self) -> dict[str, TopicPublisher]:
        """Publishers by topic, in the order they were declared."""
        return dict(self._pubs)

    def subscriber(self, topic_exprs: Sequence[str] | str = ("**",), **kwargs: Any) -> Subscriber:
        """A :class:`Subscriber` of this run (keyword arguments as there), closed with the lifecycle."""
        kwargs.setdefault("authenticator", self.authenticator)
        sub = Subscriber(self.session, self.run_id, topic_exprs, **kwargs)
        self._subs.append(sub)
        return sub

    def command_server(self, handler: Callable[[Telecommand], TelecommandReply], *, threaded: bool = True,
                       on_malformed: Callable[[bytes, TelecommandReply], None] | None = None,
                       on_refused: Callable[[Telecommand, bytes, TelecommandReply, str], None] | None = None,
                       ) -> CommandServer:
        """A :class:`CommandServer` of this run (refusing commands without a valid tag when the
        lifecycle holds the run's key), closed with the lifecycle."""
        server = CommandServer(self.session, self.run_id, handler, threaded=threaded, on_malformed=on_malformed,
                               authenticator=self.authenticator, on_refused=on_refused)
        self._servers.append(server)
        return server

    def poll_commands(self) -> int:
        """Serve the commands waiting for the servers that are not threaded; returns how many."""
        return sum(server.poll() for server in self._servers)

    @property
    def session(self) -> zenoh.Session:
        """The open session (for what the lifecycle does not declare itself, e.g. a CreditWindow)."""
        if self._session is None:
            raise RuntimeError("the session is open only inside `with ProcessLifecycle(...)`")
        return self._session

    # -- the stream ----------------------------------------------------------------------------
    def wait_for_consumers(self, consumers: Iterable[str], timeout_s: float = 30.0) -> None:
        """Return once every consumer's subscriptions are up (:func:`fsw.transport.flow.wait_for_consumers`)."""
        flow.wait_for_consumers(self.session, self.run_id, consumers, timeout_s=timeout_s)

    def announce_end(self, topic: str, status: RunStatus) -> None:
        """Publish the end-of-run ``status`` (counts per topic) on ``topic``."""
        self.publisher(topic).put(status)

    def confirm_end(
        self, status: RunStatus, consumers: Iterable[str], timeout_s: float = 30.0, *, require_all: bool = True,
        on_reply: Callable[[str, RunStatus], None] | None = None,
    ) -> dict[str, bool]:
        """Drain into ``consumers`` until each confirms it has what ``status`` announces.

        Returns whether each consumer confirmed; with ``require_all`` a consumer that did not
        raises :class:`TransportError` naming it. ``on_reply`` as in :func:`fsw.transport.flow.drain`.
        """
        if self.authenticator is not None:
            status = self.authenticator.sign(status)
        done = flow.drain(self.session, self.run_id, status, consumers, timeout_s=timeout_s, on_reply=on_reply)
        missing = [c for c, ok in done.items() if not ok]
        if require_all and missing:
            raise TransportError(f"no end-of-stream confirmation from {', '.join(missing)}")
        return done

    def end_of_stream(
        self, topic: str, status: RunStatus, consumers: Iterable[str], timeout_s: float = 30.0, *, require_all: bool = True
    ) -> dict[str, bool]:
        """:meth:`announce_end` then :meth:`confirm_end`: what a producer does before it closes."""
        self.announce_end(topic, status)
        return self.confirm_end(status, consumers, timeout_s, require_all=require_all)

    def wait_acknowledged(
        self, sub: Subscriber, producers: Iterable[str], timeout_s: float = 15.0, linger_s: float = REPLY_LINGER_S
    ) -> bool:
        """Stay until each producer's drain into ``sub`` was answered "complete", at most ``timeout_s``.

        Commands keep being served meanwhile (progress queries are answered on Zenoh's thread);
        then the process lingers ``linger_s`` so the last reply leaves. False if a producer
        never asked.
        """
        producers = list(producers)
        deadline = time.monotonic() + timeout_s
        while not all(sub.acknowledged.get(p) for p in producers) and time.monotonic() < deadline:
            self.poll_commands()
            time.sleep(0.01)
        acknowledged = all(sub.acknowledged.get(p) for p in producers)
        self.let_replies_leave(linger_s)
        return acknowledged

    @staticmethod
    def let_replies_leave(linger_s: float = REPLY_LINGER_S) -> None:
        """Wait a moment so a query reply just sent leaves before the session closes."""
        time.sleep(linger_s)
