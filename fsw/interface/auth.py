"""Authentication of the messages that command the FSW or end a run: HMAC-SHA256 under the run's key.

Transport security (mutual TLS and access control, :mod:`fsw.transport.credentials`) keeps
strangers off the bus, but a refusal there is silent. The messages that change another
process's state — a :class:`~fsw.interface.messages.Telecommand`, and a
:class:`~fsw.interface.messages.RunStatus` (an end-of-run status makes the FSW and the logger
finish) — therefore also carry an :class:`~fsw.interface.messages.AuthTag`, so a receiver that
holds the run's key can refuse a forged or replayed one *and count and record the refusal*.

The tag is HMAC-SHA256 (RFC 2104, Python's ``hmac``) over the **canonical bytes**, defined here
once::

    schema name  "\\n"  nonce  "\\n"  codec JSON of the message with auth = null

The schema name keeps a tag made for one message type from passing for another; the nonce (16
random bytes, hex) makes every tag distinct, so a receiver can refuse a telecommand it has
already served (:class:`NonceGuard`). A RunStatus is not nonce-checked: a producer's drain sends
the same signed end-of-run status several times, and replaying a genuine status of the same run
(the key is per run) can only repeat what its producer already said.
"""

from __future__ import annotations

import hmac
import secrets
from collections import OrderedDict
from dataclasses import replace
from hashlib import sha256
from typing import TypeVar

from fsw.interface import codec
from fsw.interface.messages import AuthTag, RunStatus, Telecommand

T = TypeVar("T", bound=Telecommand | RunStatus)

#: The message types that carry an authentication tag.
AUTHENTICATED_TYPES = (Telecommand, RunStatus)
#: Bytes of a run key (HMAC-SHA256's block-size guidance: at least the 32-byte output).
KEY_BYTES = 32
NONCE_BYTES = 16

#: Prefix of what :meth:`MessageAuthenticator.file_tag` covers (message tags start with a schema name).
FILE_DOMAIN = b"navbank-file\n"

MISSING = "missing authentication tag"
BAD = "bad authentication tag"
REPLAYED = "replayed authentication nonce"


def canonical_bytes(msg: Telecommand | RunStatus, nonce: str) -> bytes:
    """What the tag of ``msg`` covers (see the module docstring)."""
    if not isinstance(msg, AUTHENTICATED_TYPES):
        raise TypeError(f"{type(msg).__name__} carries no authentication tag")
    body = codec.to_json(replace(msg, auth=None))
    return codec.schema_name(type(msg)).encode() + b"\n" + nonce.encode() + b"\n" + body


class MessageAuthenticator:
    """Signs and checks :data:`AUTHENTICATED_TYPES` messages with one run key."""

    def __init__(self, key: bytes):
        if len(key) < KEY_BYTES:
            raise ValueError(f"run key: expected at least {KEY_BYTES} bytes, got {len(key)}")
        self._key = bytes(key)

    def _mac(self, msg: Telecommand | RunStatus, nonce: str) -> str:
        return hmac.new(self._key, canonical_bytes(msg, nonce), sha256).hexdigest()

    def file_tag(self, data: bytes) -> str:
        """HMAC-SHA256 (hex) of a file's bytes under the run key, e.g. an FSW checkpoint's payload.

        Domain-separated from message tags: file bytes can never pass for a message's."""
        return hmac.new(self._key, FILE_DOMAIN + data, sha256).hexdigest()

    def sign(self, msg: T, nonce: str | None = None) -> T:
        """``msg`` with a tag under a fresh nonce (or ``nonce``)."""
        nonce = nonce if nonce is not None else secrets.token_hex(NONCE_BYTES)
        return replace(msg, auth=AuthTag(nonce=nonce, mac=self._mac(msg, nonce)))

    def refusal(self, msg: Telecommand | RunStatus) -> str | None:
        """Why ``msg`` must be refused (:data:`MISSING` or :data:`BAD`), or None if its tag is valid."""
        tag = msg.auth
        if tag is None:
            return MISSING
        if not hmac.compare_digest(self._mac(msg, tag.nonce), tag.mac):
            return BAD
        return None


class NonceGuard:
    """Nonces already accepted, the newest ``capacity`` of them: a nonce is accepted once.

    Only tags that passed the HMAC check are remembered, so only holders of the key can fill it;
    at 65 536 a run would have to serve that many telecommands before an old one could return.
    """

    def __init__(self, capacity: int = 65536):
        self.capacity = capacity
        self._seen: OrderedDict[str, None] = OrderedDict()

    def first_use(self, nonce: str) -> bool:
        """True the first time ``nonce`` is seen (and remember it), False afterwards."""
        if nonce in self._seen:
            return False
        self._seen[nonce] = None
        if len(self._seen) > self.capacity:
            self._seen.popitem(last=False)
        return True

    def snapshot(self) -> list[str]:
        """The remembered nonces, oldest first (what a checkpoint keeps)."""
        return list(self._seen)

    def restore(self, nonces: list[str]) -> None:
        """Remember ``nonces`` (from :meth:`snapshot`) as already accepted."""
        for nonce in nonces[-self.capacity:]:
            self._seen[nonce] = None
