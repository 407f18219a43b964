"""Telecommands: the FSW's command queryable and the ground's sender.

:func:`declare_command_server` serves ``navbank/<run>/fsw/cmd``: a strict ICD decode of the query
payload, the handler's :class:`TelecommandReply` back, a ``TelecommandReply(ok=False)`` for a
malformed payload (counted), never an exception, and the Query dropped after every reply (a
Query kept alive leaves the sender waiting for its whole timeout, then with an extra error).
With the run's key (:class:`~fsw.interface.auth.MessageAuthenticator`) a command whose tag is
missing, wrong or already used is refused before the handler sees it: counted, answered
``ok=False`` and reported to ``on_refused`` so the FSW puts it on the record.
:func:`send_command` is the ground side (it signs with the key it is given).
"""

from __future__ import annotations

import json
import threading
from collections.abc import Callable
from typing import Any

import zenoh

from fsw.interface import auth, codec, topics
from fsw.interface.messages import Telecommand, TelecommandReply
from fsw.transport import wire
from fsw.transport.session import TransportError


def _best_effort_id(payload: bytes) -> str:
    try:
        data = json.loads(payload.decode("utf-8"), parse_constant=lambda t: None)
    except (UnicodeDecodeError, ValueError, RecursionError):
        return ""
    if isinstance(data, dict) and isinstance(data.get("id"), str):
        return data["id"][:200]
    return ""


class CommandServer:
    """Queryable on ``navbank/<run>/fsw/cmd`` turning Telecommands into TelecommandReplies.

    ``threaded=True``: the handler runs on Zenoh's thread as queries arrive (it must be thread
    safe). ``threaded=False``: queries wait in a FIFO until :meth:`poll` serves them on the
    caller's thread (e.g. at frame boundaries of the executive).

    Counters: ``served`` (valid commands answered), ``malformed`` (payloads rejected before the
    handler), ``refused`` (well-formed commands whose authentication failed), ``handler_errors``
    (handler raised or returned something else than a reply). ``on_malformed(payload, reply)``
    and ``on_refused(command, payload, reply, reason)``, if given, are told of every payload
    rejected before the handler (so the FSW can put it on the record).
    """

    def __init__(
        self,
        session: zenoh.Session,
        run_id: str,
        handler: Callable[[Telecommand], TelecommandReply],
        *,
        threaded: bool = True,
        on_malformed: Callable[[bytes, TelecommandReply], None] | None = None,
        authenticator: auth.MessageAuthenticator | None = None,
        on_refused: Callable[[Telecommand, bytes, TelecommandReply, str], None] | None = None,
    ):
        self.handler = handler
        self.on_malformed = on_malformed
        self.authenticator = authenticator
        self.on_refused = on_refused
        self._nonces = auth.NonceGuard()
        self.served = 0
        self.malformed = 0
        self.refused = 0
        self.handler_errors = 0
        self.last_error = ""
        self._lock = threading.Lock()
        k = topics.key(run_id, topics.FSW_COMMAND)
        self.threaded = threaded
        # a callback queryable serves on Zenoh's thread; a FIFO one waits for poll()
        self._queryable: zenoh.Queryable[None] | zenoh.Queryable[zenoh.handlers.Handler[zenoh.Query]] | None
        self._fifo: zenoh.Queryable[zenoh.handlers.Handler[zenoh.Query]] | None = None
        if threaded:
            self._queryable = session.declare_queryable(k, self._serve)
        else:
            self._queryable = self._fifo = session.declare_queryable(k, zenoh.handlers.FifoChannel(256))

    def _answer(self, payload: bytes | None, schema: str) -> TelecommandReply:
        if payload is None:
            return self._refuse(b"", "no payload", TelecommandReply(id="", ok=False, error="malformed telecommand: no payload"))
        want = codec.schema_name(Telecommand)
        if schema and schema != want:
            return self._refuse(payload, f"schema {schema}", TelecommandReply(
                id=_best_effort_id(payload), ok=False, error=f"malformed telecommand: schema {schema}, expected {want}"))
        try:
            cmd = codec.from_json(Telecommand, payload)
        except codec.ICDError as exc:
            return self._refuse(payload, str(exc), TelecommandReply(
                id=_best_effort_id(payload), ok=False, error=f"malformed telecommand: {exc}"[:500]))
        if self.authenticator is not None:
            why = self.authenticator.refusal(cmd)
            if why is None and cmd.auth is not None and not self._nonces.first_use(cmd.auth.nonce):
                why = auth.REPLAYED
            if why is not None:
                return self._refuse_unauthenticated(cmd, payload, why)
        try:
            reply = self.handler(cmd)
            if not isinstance(reply, TelecommandReply):
                raise TypeError(f"handler returned {type(reply).__name__}, not TelecommandReply")
            codec.to_json(reply)  # a reply with NaN would fail later, outside our control
        except Exception as exc:
            with self._lock:
                self.handler_errors += 1
                self.last_error = f"{type(exc).__name__}: {exc}"
            return TelecommandReply(id=cmd.id, ok=False, error=f"command failed: {type(exc).__name__}: {exc}"[:500])
        with self._lock:
            self.served += 1
        return reply

    def _refuse(self, payload: bytes, why: str, reply: TelecommandReply) -> TelecommandReply:
        with self._lock:
            self.malformed += 1
            self.last_error = why[:300]
        if self.on_malformed is not None:
            try:
                self.on_malformed(payload, reply)
            except Exception as exc:  # the record is lost, the reply still goes out
                with self._lock:
                    self.handler_errors += 1
                    self.last_error = f"{type(exc).__name__}: {exc}"
        return reply

    def _refuse_unauthenticated(self, cmd: Telecommand, payload: bytes, why: str) -> TelecommandReply:
        reply = TelecommandReply(id=cmd.id, ok=False, error=f"refused: {why}")
        with self._lock:
            self.refused += 1
            self.last_error = f"command {cmd.id!r} refused: {why}"[:300]
        if self.on_refused is not None:
            try:
                self.on_refused(cmd, payload, reply, why)
            except Exception as exc:  # the record is lost, the refusal still stands
                with self._lock:
                    self.handler_errors += 1
                    self.last_error = f"{type(exc).__name__}: {exc}"
        return reply

    def _serve(self, query: Any) -> None:
        with query:
            try:
                payload = query.payload.to_bytes() if query.payload is not None else None
                reply = self._answer(payload, wire.schema_of(query.encoding))
                query.reply(query.key_expr, codec.to_json(reply), encoding=wire.encoding(TelecommandReply))
            except Exception as exc:
                with self._lock:
                    self.handler_errors += 1
                    self.last_error = f"{type(exc).__name__}: {exc}"
                try:
                    query.reply_err(f"telecommand server error: {exc}"[:300])
                except Exception:
                    pass

    def poll(self) -> int:
        """Serve every waiting command on this thread (``threaded=False``); returns how many."""
        if self._fifo is None:
            return 0
        n = 0
        while (query := self._fifo.try_recv()) is not None:
            self._serve(query)
            n += 1
        return n

    @property
    def accepted_nonces(self) -> list[str]:
        """Nonces of the authenticated telecommands served so far (for a checkpoint)."""
        return self._nonces.snapshot()

    def restore_nonces(self, nonces: list[str]) -> None:
        """Refuse ``nonces`` as replays from now on (a restarted FSW, from its checkpoint)."""
        self._nonces.restore(nonces)

    def status(self) -> dict[str, float]:
        with self._lock:
            return {"served": self.served, "malformed": self.malformed, "refused": self.refused,
                    "handler_errors": self.handler_errors}

    def close(self) -> None:
        if self._queryable is not None:
            wire.undeclare_quietly(self._queryable)
            self._queryable = self._fifo = None

    def __enter__(self) -> "CommandServer":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def declare_command_server(
    session: zenoh.Session,
    run_id: str,
    handler: Callable[[Telecommand], TelecommandReply],
    *,
    threaded: bool = True,
) -> CommandServer:
    """Serve telecommands of run ``run_id`` with ``handler`` (see :class:`CommandServer`)."""
    return CommandServer(session, run_id, handler, threaded=threaded)


def send_command(session: zenoh.Session, run_id: str, cmd: Telecommand, timeout_s: float = 2.0,
                 authenticator: auth.MessageAuthenticator | None = None) -> TelecommandReply:
    """Send a telecommand (signed with ``authenticator``'s key if given) and return the FSW's
    reply; :class:`TransportError` if none comes."""
    if not isinstance(cmd, Telecommand):
        raise TypeError(f"expected a Telecommand, got {type(cmd).__name__}")
    if authenticator is not None:
        cmd = authenticator.sign(cmd)
    return send_command_payload(session, run_id, codec.to_json(cmd), timeout_s=timeout_s)


def send_command_payload(
    session: zenoh.Session,
    run_id: str,
    payload: bytes,
    *,
    schema: str | None = codec.schema_name(Telecommand),
    timeout_s: float = 2.0,
) -> TelecommandReply:
    """Send a hand-made telecommand payload (e.g. JSON typed by an operator) as-is.

    ``schema`` goes into the Zenoh encoding (None: plain JSON without a schema name).
    """
    encoding = zenoh.Encoding.APPLICATION_JSON if schema is None else zenoh.Encoding.APPLICATION_JSON.with_schema(schema)
    errors = []
    answer = None
    for reply in session.get(topics.key(run_id, topics.FSW_COMMAND), payload=payload, encoding=encoding, timeout=timeout_s):
        if reply.ok is not None:
            if answer is None:
                try:
                    answer = codec.from_json(TelecommandReply, reply.ok.payload.to_bytes())
                except codec.ICDError as exc:
                    errors.append(f"unreadable reply: {exc}")
        elif reply.err is not None:
            errors.append(reply.err.payload.to_bytes().decode("utf-8", "replace"))
    if answer is not None:
        return answer
    if errors:
        raise TransportError(f"telecommand to run {run_id} failed: {'; '.join(errors)[:300]}")
    raise TransportError(f"no FSW of run {run_id} answered the telecommand within {timeout_s:g} s")
