"""A supervised process ends with its supervisor.

``navbank run`` starts the simulator, the FSW and the logger as separate processes, each in its
own session (a Ctrl-C at the terminal goes to the launcher, which stops them in order). If the
launcher itself is killed without warning (SIGKILL, an OOM kill) nobody would stop them: they
would be orphaned, holding ports and files. So the launcher names itself in
:data:`SUPERVISOR_ENV`, and a child that finds it set watches its parent: once it has been
re-parented (the launcher is gone) it sends itself SIGTERM — the same stop request the launcher
would have sent, so the logger still finishes its file — and if that has not ended it within
:data:`GRACE_S`, it exits with a non-zero code. Polling the parent id is portable (no
``prctl``) and costs nothing measurable at :data:`POLL_S`.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
import time

SUPERVISOR_ENV = "NAVBANK_SUPERVISOR_PID"
POLL_S = 0.2
GRACE_S = 4.0
ORPHANED_EXIT = 70  # EX_SOFTWARE: the process could not finish its job


def supervisor_env(pid: int | None = None) -> dict[str, str]:
    """The environment entry that makes a child watch its supervisor (this process by default)."""
    return {SUPERVISOR_ENV: str(os.getpid() if pid is None else pid)}


def _say(text: str) -> None:
    try:
        print(text, file=sys.stderr, flush=True)
    except (OSError, ValueError):
        pass  # our output went to the supervisor, which is gone: the pipe is broken


def _watch(supervisor: int) -> None:
    while os.getppid() == supervisor:
        time.sleep(POLL_S)
    _say(f"navbank: supervisor (pid {supervisor}) is gone; stopping")
    os.kill(os.getpid(), signal.SIGTERM)
    time.sleep(GRACE_S)
    os._exit(ORPHANED_EXIT)


def watch_supervisor_from_env() -> bool:
    """Start watching the supervisor named in the environment, if any; whether one is watched."""
    value = os.environ.get(SUPERVISOR_ENV)
    if not value:
        return False
    try:
        supervisor = int(value)
    except ValueError:
        return False
    if os.getppid() != supervisor:  # gone before we even started
        _say(f"navbank: supervisor (pid {supervisor}) is gone; not starting")
        os._exit(ORPHANED_EXIT)
    threading.Thread(target=_watch, args=(supervisor,), name="supervisor-watch", daemon=True).start()
    return True
