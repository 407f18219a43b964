"""Command-line options of every subcommand that joins a run over Zenoh."""

from __future__ import annotations

import argparse

from fsw.transport import TransportConfig


def add_transport_arguments(parser: argparse.ArgumentParser) -> None:
    """``--listen/--connect/--zenoh-config/--client/--no-gossip/--connect-timeout`` options."""
    g = parser.add_argument_group("transport (Zenoh)")
    g.add_argument("--listen", action="append", default=None, metavar="EP", help="endpoint to listen on (repeatable; default: a free 127.0.0.1 port, found by the run's processes on this host)")
    g.add_argument("--connect", action="append", default=None, metavar="EP", help="endpoint to connect to (repeatable), e.g. tcp/127.0.0.1:7447")
    g.add_argument("--zenoh-config", default=None, metavar="FILE", help="Zenoh JSON5 config file (TLS, auth, access control)")
    g.add_argument("--client", action="store_true", help="client mode (connect through a Zenoh router)")
    g.add_argument("--no-gossip", action="store_true", help="do not discover peers through connected peers")
    g.add_argument("--connect-timeout", type=float, default=10.0, metavar="S", help="seconds allowed for every connect endpoint (default 10)")


def transport_config_from_args(args: argparse.Namespace) -> TransportConfig:
    """The :class:`TransportConfig` of options added by :func:`add_transport_arguments`."""
    default = TransportConfig()
    return TransportConfig(
        mode="client" if args.client else "peer",
        listen=tuple(args.listen) if args.listen else default.listen,
        connect=tuple(args.connect or ()),
        gossip=not args.no_gossip,
        config_file=args.zenoh_config,
        connect_timeout_s=args.connect_timeout,
    )
