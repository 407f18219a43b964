"""``navbank credentials``: make a run's credentials for processes started by hand."""

from __future__ import annotations

import os
import sys

from tools.credentials import make_credentials

NAME = "credentials"
HELP = "make a credentials directory (a fresh CA, one certificate per role, the HMAC key) for processes started by hand"
DESCRIPTION = """`navbank run` makes its own credentials for every run. Processes started by hand
(`navbank sim`, `fsw`, `ground log`, each with `--credentials DIR`) share one directory made by
this command: a fresh certificate authority whose private key is never written, one certificate
per role (sim, fsw, ground, operator; CN = role, SAN IP:127.0.0.1 unless --host says otherwise),
and the run's HMAC key. The directory is mode 0700 and every file 0600; copy it to another host
only over a channel you trust. Exit 2 if DIR already exists or cannot be made."""


def add_arguments(p) -> None:
    p.add_argument("dir", metavar="DIR", help="directory to create (must not exist)")
    p.add_argument("--days", type=float, default=7.0, metavar="D", help="validity of the certificates in days (default 7)")
    p.add_argument("--host", default="127.0.0.1", metavar="IP", help="IP address in the certificates (default 127.0.0.1)")


def run(args) -> int:
    if args.days <= 0:
        print("navbank credentials: --days must be > 0", file=sys.stderr)
        return 2
    try:
        d = make_credentials(args.dir, days=args.days, host=args.host)
    except (OSError, ValueError) as exc:
        why = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        print(f"navbank credentials: {os.fspath(args.dir)}: {why}", file=sys.stderr)
        return 2
    print(f"credentials written to {d} (use --credentials {d})")
    return 0
