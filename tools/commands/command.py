"""``navbank command``: send one telecommand to a running FSW and print its reply."""

from __future__ import annotations

import json
import sys
import uuid

import fsw.transport as tp
from fsw.interface import codec
from fsw.interface.auth import MessageAuthenticator
from fsw.interface.messages import TELECOMMANDS, Telecommand
from tools.commands.arg_types import run_id_arg
from tools.commands.errors import UsageError
from tools.commands.transport_args import add_transport_arguments
from tools.rendezvous import joined

NAME = "command"
HELP = "send a telecommand to a running FSW (signed with the run's key when given --credentials)"
DESCRIPTION = """Send one telecommand to the FSW of run ID (queryable navbank/<ID>/fsw/cmd) and print the
FSW's reply as JSON. With --credentials the link is mutual TLS with the operator's certificate
(the only role the FSW takes commands from) and the command carries an HMAC tag under the run's
key with a fresh nonce; without them the FSW of an authenticated run refuses it, or cannot be
reached at all. Exit 0 when the FSW carried the command out, 1 when it refused or nobody answered."""


def add_arguments(p) -> None:
    p.add_argument("name", choices=TELECOMMANDS, metavar="COMMAND", help=f"one of {', '.join(TELECOMMANDS)}")
    p.add_argument("--run-id", type=run_id_arg, required=True, metavar="ID", help="run to command")
    p.add_argument("--network", default=None, help="gating network (reset-gating, set-param)")
    p.add_argument("--filter", default=None, help="filter (enable-filter, disable-filter)")
    p.add_argument("--param", default=None, help="parameter name (set-param)")
    p.add_argument("--value", type=float, default=None, help="parameter value (set-param)")
    p.add_argument("--timeout", type=float, default=5.0, metavar="S", help="seconds to wait for the reply (default 5)")
    add_transport_arguments(p)


def run(args) -> int:
    try:
        cmd = Telecommand(id=f"cli-{uuid.uuid4().hex[:8]}", command=args.name, network=args.network, filter=args.filter,
                          param=args.param, value=args.value)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    try:
        # without endpoint options: the run's processes on this host, as they announced themselves
        with joined(args, args.run_id, "operator", announce=False, name="command") as cfg:
            signer = MessageAuthenticator(cfg.credentials.run_key) if cfg.credentials is not None else None
            with tp.open_session(cfg) as session:
                reply = tp.send_command(session, args.run_id, cmd, timeout_s=args.timeout, authenticator=signer)
    except tp.TransportError as exc:
        print(f"navbank command: {exc}", file=sys.stderr)
        return 1
    print(json.dumps(codec.to_dict(reply), indent=2))
    return 0 if reply.ok else 1
