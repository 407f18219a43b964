"""Command-line options of every subcommand that joins a run over Zenoh."""

from __future__ import annotations

import argparse

from fsw.transport import TransportConfig
from fsw.transport.credentials import ROLES, CredentialsError, load_credentials
from tools.commands.errors import UsageError


def add_transport_arguments(parser: argparse.ArgumentParser) -> None:
    """``--listen/--connect/--zenoh-config/--client/--no-gossip/--connect-timeout/--credentials/--role`` options."""
    g = parser.add_argument_group("transport (Zenoh)")
    g.add_argument("--listen", action="append", default=None, metavar="EP",
                   help="endpoint to listen on (repeatable; default: a free 127.0.0.1 port, found by the run's processes "
                        "on this host; tls/ with --credentials)")
    g.add_argument("--connect", action="append", default=None, metavar="EP", help="endpoint to connect to (repeatable), e.g. tcp/127.0.0.1:7447")
    g.add_argument("--zenoh-config", default=None, metavar="FILE", help="Zenoh JSON5 config file (TLS, auth, access control)")
    g.add_argument("--client", action="store_true", help="client mode (connect through a Zenoh router)")
    g.add_argument("--no-gossip", action="store_true", help="do not discover peers through connected peers")
    g.add_argument("--connect-timeout", type=float, default=10.0, metavar="S", help="seconds allowed for every connect endpoint (default 10)")
    g.add_argument("--credentials", default=None, metavar="DIR",
                   help="the run's credentials directory (written by `navbank run`): mutual TLS on tls/ endpoints, "
                        "access control, and the key that signs and checks telecommands and end-of-run statuses")
    g.add_argument("--role", default=None, choices=ROLES,
                   help="whose certificate to present from --credentials (default: this command's own role)")


def transport_config_from_args(args: argparse.Namespace, role: str | None = None) -> TransportConfig:
    """The :class:`TransportConfig` of options added by :func:`add_transport_arguments`; ``role``
    is the command's own role (its certificate in ``--credentials`` unless ``--role`` says otherwise).
    A bad credentials directory or endpoint is a :class:`UsageError` (one line, exit code 2)."""
    default = TransportConfig()
    creds = None
    listen = tuple(args.listen) if args.listen else default.listen
    if getattr(args, "credentials", None) is not None:
        who = getattr(args, "role", None) or role
        if who is None:
            raise UsageError("--credentials needs --role (which certificate to present)")
        try:
            creds = load_credentials(args.credentials, who)
        except CredentialsError as exc:
            raise UsageError(f"--credentials: {exc}") from None
        if not args.listen:
            listen = ("tls/127.0.0.1:0",)
    try:
        return TransportConfig(
            mode="client" if args.client else "peer",
            listen=listen,
            connect=tuple(args.connect or ()),
            gossip=not args.no_gossip,
            config_file=args.zenoh_config,
            connect_timeout_s=args.connect_timeout,
            credentials=creds,
        )
    except ValueError as exc:
        raise UsageError(str(exc)) from None
