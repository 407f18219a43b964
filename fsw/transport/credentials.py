"""A run's credentials on disk, and the transport security they configure (mutual TLS + access control).

``navbank run`` writes one directory per run (``tools/credentials.py`` makes it; mode 0700, every
file 0600)::

    ca.pem                 the run's own certificate authority (its private key is never written)
    <role>.pem, <role>.key one certificate per role, CN = role, SAN IP:127.0.0.1
    run.key                32 random bytes (hex): the HMAC key of :mod:`fsw.interface.auth`

The roles are the processes of a run and the commanding side: ``sim``, ``fsw``, ``ground`` and
``operator`` (whoever sends telecommands). With credentials a process listens and connects only
on ``tls/`` endpoints with mutual TLS, so a peer without a certificate of this run's CA cannot
link to it at all, and it holds an ingress access-control list (:func:`access_control`) keyed on
the certificate's common name, so a peer of the run in the wrong role cannot put on another
role's keys or send telecommands. Zenoh drops what the list refuses silently; what must be
counted and recorded is refused again by the application, by HMAC tag (``fsw.interface.auth``).

Loading is strict: a missing or unreadable file, or one that others can read (mode not 0600,
directory not 0700), is a :class:`CredentialsError` with one line naming it.
"""

from __future__ import annotations

import os
import stat
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

#: The roles a run's CA issues certificates to.
Role = Literal["sim", "fsw", "ground", "operator"]
ROLES: tuple[Role, ...] = ("sim", "fsw", "ground", "operator")
CA_FILE = "ca.pem"
KEY_FILE = "run.key"


class CredentialsError(ValueError):
    """A credentials directory or file is missing, unreadable, malformed or open to others."""


def _check_private(path: Path, want: int, what: str) -> None:
    try:
        st = path.stat()
    except OSError as exc:
        raise CredentialsError(f"{what} {path}: {exc.strerror or exc}") from None
    mode = stat.S_IMODE(st.st_mode)
    if mode & 0o077:
        raise CredentialsError(f"{what} {path}: mode {mode:04o} lets others read it; expected {want:04o}")
    if st.st_uid != os.getuid():
        raise CredentialsError(f"{what} {path}: owned by uid {st.st_uid}, not by this user")


def _read(path: Path, what: str) -> bytes:
    _check_private(path, 0o600, what)
    try:
        return path.read_bytes()
    except OSError as exc:
        raise CredentialsError(f"{what} {path}: {exc.strerror or exc}") from None


@dataclass(frozen=True, slots=True)
class RunCredentials:
    """The files one role uses from a credentials directory (checked when loaded)."""

    directory: str
    role: Role
    ca: str  # path of the CA certificate
    certificate: str
    private_key: str
    run_key: bytes  # HMAC key


def load_credentials(directory: str | os.PathLike, role: str) -> RunCredentials:
    """Check and load ``role``'s credentials from ``directory`` (see the module docstring)."""
    if role not in ROLES:
        raise CredentialsError(f"credentials role {role!r}: expected one of {', '.join(ROLES)}")
    d = Path(directory)
    if not d.is_dir():
        raise CredentialsError(f"credentials directory {d}: not a directory")
    _check_private(d, 0o700, "credentials directory")
    for name, what in ((CA_FILE, "CA certificate"), (f"{role}.pem", "certificate"), (f"{role}.key", "private key")):
        data = _read(d / name, what)
        if b"-----BEGIN " not in data:
            raise CredentialsError(f"{what} {d / name}: not a PEM file")
    text = _read(d / KEY_FILE, "run key").decode("ascii", "replace").strip()
    try:
        key = bytes.fromhex(text)
    except ValueError:
        raise CredentialsError(f"run key {d / KEY_FILE}: expected hex digits") from None
    if len(key) < 32:
        raise CredentialsError(f"run key {d / KEY_FILE}: {len(key)} bytes, expected at least 32")
    return RunCredentials(str(d), role, str(d / CA_FILE), str(d / f"{role}.pem"), str(d / f"{role}.key"), key)


def tls_settings(creds: RunCredentials) -> dict[str, Any]:
    """``transport/link/tls`` of a peer that presents ``creds`` and accepts only peers of the same CA."""
    return {
        "root_ca_certificate": creds.ca,
        "listen_private_key": creds.private_key,
        "listen_certificate": creds.certificate,
        "connect_private_key": creds.private_key,
        "connect_certificate": creds.certificate,
        "enable_mtls": True,
        "verify_name_on_connect": True,
    }


_ALL_MESSAGES = ("put", "delete", "declare_subscriber", "query", "reply", "declare_queryable", "liveliness_token",
                 "declare_liveliness_subscriber", "liveliness_query")

# Who may do what on a run's keys (``navbank/<run>/...``). Every peer of the run may subscribe
# (that is how data finds its way to it); a role serves queries and replies only under its own
# keys, so no one else can answer the FSW's telecommand or progress queries in its place.
_RULES: tuple[tuple[str, tuple[str, ...], tuple[str, ...], tuple[Role, ...]], ...] = (
    ("subscribe", ("declare_subscriber",), ("navbank/**",), ROLES),
    ("fsw-serve", ("declare_queryable", "reply"), ("navbank/*/fsw/**",), ("fsw",)),
    ("ground-serve", ("declare_queryable", "reply"), ("navbank/*/ground/**",), ("ground",)),
    ("sim-put", ("put",), ("navbank/*/sim/**",), ("sim",)),
    ("fsw-put", ("put",), ("navbank/*/fsw/**",), ("fsw",)),
    # credit, readiness and the end-of-stream drain: the producers ask their consumers
    ("progress", ("query",), ("navbank/*/fsw/progress", "navbank/*/ground/progress"), ("sim", "fsw")),
    ("command", ("query",), ("navbank/*/fsw/cmd",), ("operator",)),
    # what this peer sends is limited by the others' ingress lists; its own egress is not a defence
    ("egress", _ALL_MESSAGES, ("**",), ROLES),
)


def access_control() -> dict[str, Any]:
    """The ingress ``access_control`` block every peer of a run holds (default: deny)."""
    rules, policies = [], []
    for rule_id, messages, keys, roles in _RULES:
        flows = ["egress"] if rule_id == "egress" else ["ingress"]
        rules.append({"id": rule_id, "permission": "allow", "flows": flows, "messages": list(messages),
                      "key_exprs": list(keys)})
        policies.append({"rules": [rule_id], "subjects": list(roles)})
    return {
        "enabled": True,
        "default_permission": "deny",
        "rules": rules,
        "subjects": [{"id": r, "cert_common_names": [r]} for r in ROLES],
        "policies": policies,
    }
