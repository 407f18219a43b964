"""Joining the Zenoh network: session configuration, opening, and the port layout of a local run.

The measured Zenoh pitfalls (NOTES-zenoh-mcap.md) that concern sessions are handled here, once:

* **Loopback by default.** Sessions are peers, multicast scouting off, listening on
  ``tcp/127.0.0.1:0``; nothing binds to another interface unless asked (``--listen``).
* **Failed connects are errors.** Connect endpoints are opened with ``connect/timeout_ms`` and
  ``connect/exit_on_failure``, so an unreachable peer raises :class:`TransportError` instead of
  a silent session with zero peers. Zenoh then requires *every* connect endpoint to answer.
* **Topology.** Peers do not forward data for other peers, so every pair of processes needs a
  direct link. Gossip is on by default: processes that only know one rendezvous endpoint
  (``--connect`` to the logger, say) learn each other's listeners from it and link directly.
  ``navbank run`` knows all processes and uses :func:`mesh_configs`: a fixed free port per
  process, each connecting to the ones started before it, so the mesh does not depend on gossip.
* **Authentication.** With :class:`~fsw.transport.credentials.RunCredentials` a session listens
  and connects only on ``tls/`` endpoints with mutual TLS and holds the run's ingress access
  control list (:mod:`fsw.transport.credentials`); a ``tcp/`` endpoint is then a configuration
  error, so a run never falls back to plain links by accident.
* **Processes.** Forking after ``zenoh.open()`` hangs the child: open sessions only in the
  process that uses them (``spawn``).
"""

from __future__ import annotations

import json
import socket
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any, Literal

import zenoh

from fsw.interface.typed import spec
from fsw.transport.credentials import RunCredentials, access_control, tls_settings


class TransportError(RuntimeError):
    """A Zenoh session, link, query or flow-control wait failed."""


@dataclass(frozen=True, slots=True)
class TransportConfig:
    """How a navbank process joins the Zenoh network.

    Fields here always override the same keys of ``config_file``; the file supplies everything
    else (TLS, user/password auth, access control, namespace, ...).
    """

    mode: Literal["peer", "client"] = spec("peer", doc="Zenoh mode: 'peer' (embedded, no router needed) or 'client' (through a router)")
    listen: tuple[str, ...] = spec(
        ("tcp/127.0.0.1:0",), doc="endpoints to listen on (peer mode); port 0 picks a free port; loopback unless told otherwise"
    )
    connect: tuple[str, ...] = spec((), doc="endpoints to connect to; every one must answer within connect_timeout_s")
    multicast_scouting: bool = spec(False, doc="discover peers by UDP multicast (off: loopback simulators must not leak onto the LAN)")
    gossip: bool = spec(True, doc="learn other peers' listeners through connected peers and link to them directly")
    config_file: str | None = spec(None, doc="Zenoh JSON5 configuration file used as the base configuration")
    connect_timeout_s: float = spec(10.0, doc="time allowed for every connect endpoint to answer", unit="s", gt=0.0)
    credentials: RunCredentials | None = spec(
        None, doc="the run's credentials for this process's role: mutual TLS, access control and the HMAC key (None: plain links)"
    )

    def __post_init__(self) -> None:
        for ep in (*self.listen, *self.connect):
            if "/" not in ep or not ep.split("/", 1)[1]:
                raise ValueError(f"endpoint {ep!r}: expected <protocol>/<address>, e.g. tcp/127.0.0.1:7447")
            if self.credentials is not None and not ep.startswith("tls/"):
                raise ValueError(f"endpoint {ep!r}: with credentials every endpoint is tls/<address>")
        if self.mode == "client" and not self.connect:
            raise ValueError("client mode needs at least one connect endpoint (a router)")


def zenoh_config(cfg: TransportConfig) -> zenoh.Config:
    """The zenoh.Config for ``cfg`` (see :class:`TransportConfig` for precedence)."""
    try:
        zc = zenoh.Config.from_file(cfg.config_file) if cfg.config_file else zenoh.Config()
    except zenoh.ZError as exc:
        raise TransportError(f"zenoh config file {cfg.config_file!r}: {exc}") from None

    def put(path: str, value: Any) -> None:
        try:
            zc.insert_json5(path, json.dumps(value))
        except zenoh.ZError as exc:
            raise TransportError(f"zenoh config {path} = {value!r}: {exc}") from None

    put("mode", cfg.mode)
    put("scouting/multicast/enabled", cfg.multicast_scouting)
    put("scouting/gossip/enabled", cfg.gossip)
    if cfg.mode == "peer":
        put("listen/endpoints", list(cfg.listen))
        put("listen/exit_on_failure", True)
    put("connect/endpoints", list(cfg.connect))
    if cfg.credentials is not None:
        put("transport/link/tls", tls_settings(cfg.credentials))
        put("access_control", access_control())
    if cfg.connect:
        put("connect/timeout_ms", int(round(cfg.connect_timeout_s * 1000)))
        put("connect/exit_on_failure", True)
        # Retry quickly so processes started together find each other within a fraction of a second.
        put("connect/retry", {"period_init_ms": 100, "period_max_ms": 1000, "period_increase_factor": 2})
    return zc


def open_session(cfg: TransportConfig | None = None) -> zenoh.Session:
    """Open a Zenoh session for ``cfg``; raises :class:`TransportError` if an endpoint fails.

    Use it as a context manager (``with open_session(cfg) as s:``) so it is closed on every
    path. Open sessions only in the process that uses them (spawn, never fork after open).
    """
    cfg = cfg or TransportConfig()
    zc = zenoh_config(cfg)
    try:
        return zenoh.open(zc)
    except zenoh.ZError as exc:
        where = ", ".join(cfg.connect + cfg.listen)
        raise TransportError(f"cannot open Zenoh session ({where}): {str(exc).splitlines()[0][:200]}") from None


def free_tcp_ports(n: int, host: str = "127.0.0.1") -> list[int]:
    """``n`` distinct TCP ports free on ``host`` right now (a later bind may still race)."""
    socks, ports = [], []
    try:
        for _ in range(n):
            s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            s.bind((host, 0))
            socks.append(s)
            ports.append(s.getsockname()[1])
    finally:
        for s in socks:
            s.close()
    return ports


def mesh_configs(
    roles: Sequence[str],
    base: TransportConfig | None = None,
    host: str = "127.0.0.1",
    ports: Sequence[int] | None = None,
    gossip: bool = False,
    protocol: str = "tcp",
) -> dict[str, TransportConfig]:
    """A full mesh for processes started together (``navbank run``): one fixed port per role.

    Role ``i`` listens on its own port (``protocol`` ``tls`` for a run with credentials) and connects to roles ``0..i-1``, so every pair has exactly
    one direct link. Gossip is off by default here: the mesh does not need it, and the links are
    then exactly the configured ones. Start the roles in the given order; a later role's connects
    are retried until ``connect_timeout_s``, and every earlier role must still be running then
    (a role that has already closed its session makes the later one fail to open).
    """
    base = base or TransportConfig()
    ports = list(ports) if ports is not None else free_tcp_ports(len(roles), host)
    if len(ports) != len(roles):
        raise ValueError(f"{len(roles)} roles but {len(ports)} ports")
    eps = [f"{protocol}/{host}:{p}" for p in ports]
    return {r: replace(base, listen=(eps[i],), connect=tuple(eps[:i]), gossip=gossip) for i, r in enumerate(roles)}
