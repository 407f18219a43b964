"""How the processes of one run find each other on one host without endpoint options.

``navbank run`` gives its three processes their endpoints. Started by hand (``navbank ground log
--run-id X`` in one terminal, ``navbank replay RUN.mcap --run-id X --consumers ground`` in
another), a process given no ``--listen``, ``--connect``, ``--client`` or ``--zenoh-config``
joins through a small rendezvous directory instead:

* it listens on a free loopback port (still ``127.0.0.1`` only) and says so on stderr;
* it writes ``<runtime dir>/<run id>/<role>-<pid>.json`` (its endpoint and process id) while it
  runs, and removes it on the way out;
* it connects to the endpoints the run's other live processes wrote there (a file whose process
  is gone is ignored and removed).

The runtime directory is per user: ``$XDG_RUNTIME_DIR/navbank``, else ``/tmp/navbank-<uid>``,
created mode 0700 and used only if it is a real directory owned by this user, so another user
can neither read nor plant endpoints. Files are keyed by run id, so concurrent runs never meet;
two processes of the same role and run (two loggers) each have their own file. When the
directory cannot be used, the process runs exactly as before (listening on a port of its own,
connecting to nothing), so discovery never stops a run.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import stat
import sys
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

from fsw.transport import TransportConfig, free_tcp_ports
from tools.commands.transport_args import transport_config_from_args

HOST = "127.0.0.1"


def runtime_dir() -> Path | None:
    """This user's rendezvous directory, created if needed; None if it cannot be trusted."""
    base = os.environ.get("XDG_RUNTIME_DIR")
    path = Path(base) / "navbank" if base else Path("/tmp") / f"navbank-{os.getuid()}"
    try:
        path.mkdir(mode=0o700, parents=bool(base), exist_ok=True)
        st = os.lstat(path)
    except OSError:
        return None
    if not stat.S_ISDIR(st.st_mode) or st.st_uid != os.getuid() or st.st_mode & 0o077:
        return None  # a symlink, someone else's, or open to others: not ours to trust
    return path


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def endpoints(run_id: str, directory: Path | None = None) -> list[str]:
    """The endpoints the live processes of ``run_id`` announced on this host (stale files are
    removed)."""
    directory = directory if directory is not None else runtime_dir()
    if directory is None:
        return []
    found = []
    for path in sorted((directory / run_id).glob("*.json")):
        try:
            entry = json.loads(path.read_text(encoding="utf-8"))
            endpoint, pid = str(entry["endpoint"]), int(entry["pid"])
        except (OSError, ValueError, KeyError, TypeError):
            continue
        if pid != os.getpid() and _alive(pid) and endpoint.startswith(f"tcp/{HOST}:"):
            found.append(endpoint)
        elif not _alive(pid):
            with contextlib.suppress(OSError):
                path.unlink()
    return found


def _announce(directory: Path, run_id: str, role: str, endpoint: str) -> Path | None:
    run_dir = directory / run_id
    path = run_dir / f"{role}-{os.getpid()}.json"
    try:
        run_dir.mkdir(mode=0o700, exist_ok=True)
        tmp = path.with_suffix(".tmp")
        tmp.write_text(json.dumps({"endpoint": endpoint, "pid": os.getpid(), "role": role}), encoding="utf-8")
        os.replace(tmp, path)
    except OSError:
        return None
    return path


def _withdraw(path: Path) -> None:
    with contextlib.suppress(OSError):
        path.unlink()
    with contextlib.suppress(OSError):
        path.parent.rmdir()  # only when it was the run's last file


def explicit(args: argparse.Namespace) -> bool:
    """The user said how to join: endpoints, a router or a Zenoh configuration file."""
    return bool(args.listen or args.connect or args.client or args.zenoh_config)


@contextlib.contextmanager
def joined(args: argparse.Namespace, run_id: str, role: str, *, announce: bool = True,
           name: str | None = None) -> Iterator[TransportConfig]:
    """The transport configuration of a process of ``run_id`` started by hand: the options as
    given when there are any, else a loopback port of its own (announced while inside the
    block when ``announce``) and connections to the run's other processes on this host.
    ``name`` (``ground log``) signs the line that gives the endpoint; it does not start with
    ``navbank``, the mark of a process's error line."""
    cfg = transport_config_from_args(args)
    label = name or role
    if explicit(args):
        if cfg.mode == "peer":
            print(f"{label}: run {run_id} listening on {', '.join(cfg.listen)}", file=sys.stderr, flush=True)
        yield cfg
        return
    directory = runtime_dir()
    endpoint = f"tcp/{HOST}:{free_tcp_ports(1, HOST)[0]}"
    others = endpoints(run_id, directory) if directory is not None else []
    cfg = replace(cfg, listen=(endpoint,), connect=tuple(others))
    path = _announce(directory, run_id, role, endpoint) if (directory is not None and announce) else None
    found = f"; joined {', '.join(others)}" if others else ""
    where = f" (announced in {path.parent})" if path is not None else ""
    print(f"{label}: run {run_id} listening on {endpoint}{where}{found}", file=sys.stderr, flush=True)
    try:
        yield cfg
    finally:
        if path is not None:
            _withdraw(path)
