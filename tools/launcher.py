"""``navbank run``: start the ground logger, the FSW and the simulator as separate processes.

Each process is the real subcommand (``navbank ground log``, ``navbank fsw``, ``navbank sim``)
started with the same interpreter, so what ``navbank run`` does a user can do by hand in three
terminals. The launcher gives each a fixed loopback port and connects them as a full mesh
(logger ← FSW ← simulator, and simulator → logger), writes the exact configuration of the run
first, and supervises:

* if a process exits with an error, the others are stopped (SIGTERM, then SIGKILL after a
  grace period) and the launcher names the process, its exit code and its last words — its
  error line (``navbank <command>: …``), kept in memory even when its log file cannot be
  written (a full disk fills the logs too: the cause must not be lost with them);
* SIGINT/SIGTERM to the launcher stops all three the same way, producers first (the FSW records its
  final counters, the logger finishes its file);
* a run that does not end within ``timeout_s`` is stopped and reported.

Unless asked for plain TCP, the run is authenticated: the launcher makes the run's credentials (a
fresh CA, one certificate per role, the HMAC key; ``tools/credentials.py``) in a private temporary
directory, not in the output directory (results get copied and shared; keys must not travel with
them), the mesh links are mutual TLS, and each process gets ``--credentials``. The directory is
removed when the run ends: its certificates and key are worth nothing to anyone afterwards.

On success ``navbank run`` writes the summary (``ground.report.run_summary``) to
``DIR/summary.json`` next to ``DIR/run.mcap``, ``DIR/config.yaml`` and one log per process. The
logger computes it from the messages as it records them (:data:`LOGGER_SUMMARY`); a run it did not
record whole (a restart, an interrupted or failed run) is summarised from the MCAP read back.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any, Callable, Mapping

from fsw.transport import free_tcp_ports
from tools.commands.outputs import write_json
from tools.credentials import make_credentials
from tools.supervision import supervisor_env
from tools.scenario import ScenarioConfig, to_yaml

ROLES = ("ground", "fsw", "sim")  # start order: each connects to the ones before it
GRACE_S = 10.0


class RunFailed(RuntimeError):
    """A process of the run failed; the message says which and why."""


@dataclass
class Child:
    role: str
    proc: subprocess.Popen
    log_path: Path
    tail: list[str] = field(default_factory=list)
    thread: threading.Thread | None = None
    log_error: str | None = None  # why the log file could not be (fully) written


def _pump(child: Child, stream: IO[str], echo: Callable[[str], None] | None) -> None:
    """Copy the child's output into its log, keep its last lines and echo them. The pipe is read
    to its end whatever happens to the log: a pump that died on a full disk would leave the
    child blocked on a full pipe and the launcher with no last words to report."""
    log: IO[str] | None = None
    try:
        log = open(child.log_path, "w", encoding="utf-8")
    except OSError as exc:
        child.log_error = _errno_text(exc)
    for line in stream:
        child.tail.append(line.rstrip("\n"))
        del child.tail[:-20]
        if echo is not None:
            echo(line.rstrip("\n"))
        if log is not None:
            try:
                log.write(line)
                log.flush()
            except OSError as exc:
                child.log_error = _errno_text(exc)
                _close_quietly(log)
                log = None
    if log is not None:
        _close_quietly(log)


def _errno_text(exc: OSError) -> str:
    return f"[Errno {exc.errno}] {exc.strerror}" if exc.errno is not None and exc.strerror else str(exc)


def _close_quietly(log: IO[str]) -> None:
    try:
        log.close()  # flushes what is buffered: may fail the same way
    except OSError:
        pass


def last_words(tail: list[str]) -> str:
    """What a failed process said last: its one-line error (``navbank <command>: …``, the form
    every command gives), or the exception line of a traceback that came after it, else its last
    non-empty line, else that it said nothing. Lines a library logs on the way out (Zenoh's
    warnings as the session closes) do not hide the error line."""
    lines = [ln.rstrip() for ln in tail if ln.strip()]
    said = max((i for i, ln in enumerate(lines) if ln.startswith("navbank ")), default=-1)
    trace = max((i for i, ln in enumerate(lines) if ln.startswith("Traceback (most recent call last)")), default=-1)
    if trace > said:
        exception = [ln for ln in lines[trace + 1:] if not ln[:1].isspace()]
        if exception:
            return exception[-1]
    if said >= 0:
        return lines[said]
    return lines[-1] if lines else "no output"


def _command(role: str, cfg_path: Path, run_id: str, out_dir: Path, eps: dict[str, str],
             credentials: Path | None = None, live: tuple[str, int] | None = None,
             rate: float | None = None, summary_context: Mapping[str, Any] | None = None) -> list[str]:
    base = [sys.executable, "-m", "tools.cli"]
    before = [eps[r] for r in ROLES[: ROLES.index(role)]]
    connect = [a for ep in before for a in ("--connect", ep)]
    if connect:
        connect += ["--connect-timeout", f"{PEER_START_S:g}"]
    net = ["--listen", eps[role], *connect, *(["--credentials", str(credentials)] if credentials else [])]
    if role == "ground":
        # The producers are our own processes, which encode from the ICD types: strict re-validation
        # of every message in the logger (~90 µs each) only slowed the whole run down.
        view = [] if live is None else ["--live", "--live-host", live[0], "--live-port", str(live[1])]
        # the summary from the messages as they are recorded: reading them back took ~0.8 s after the run
        fed = [] if summary_context is None else ["--summary", str(out_dir / LOGGER_SUMMARY),
                                                   "--summary-context", json.dumps(dict(summary_context))]
        return [*base, "ground", "log", "--run-id", run_id, "--out", str(out_dir / "run.mcap"), "--no-validate",
                "--attach", str(cfg_path), *view, *fed, *net]
    if role == "fsw":
        return [*base, "fsw", "--scenario", str(cfg_path), "--run-id", run_id, "--checkpoint", str(out_dir / CHECKPOINT),
                "--hold-for-logger", f"{HOLD_FOR_LOGGER_S:g}", *net]
    paced = [] if rate is None else ["--rate", repr(rate)]
    return [*base, "sim", "--scenario", str(cfg_path), "--run-id", run_id, "--hold-for-logger", f"{HOLD_FOR_LOGGER_S:g}",
            *paced, *net]


#: How long a process waits for the ones started before it to open their sessions. The three
#: start together, and the FSW opens its session only once its kernels are loaded: on a machine's
#: first run they are compiled first (about 30 s of CPU on a 2-core Xeon), and the simulator's
#: default 10 s to reach every peer ran out. A process that dies instead is seen by the launcher
#: at once (it stops the others), so waiting longer costs nothing when a peer fails.
PEER_START_S = 300.0
#: How often the launcher looks at its children: the run's end is seen this late at most (three
#: ``poll()`` calls cost microseconds; at 0.1 s the end waited 50 ms on average).
POLL_S = 0.02
#: The FSW's checkpoint file in the run directory (``fsw.checkpoint`` sets the cadence).
CHECKPOINT = "fsw.ckpt"
#: The run's summary as the logger computed it while recording (``navbank ground log --summary``):
#: what ``summary.json`` is made from when the logger recorded the whole run.
LOGGER_SUMMARY = "ground-summary.json"
#: How long the producers wait for a restarted logger each time it is away (then they go on).
HOLD_FOR_LOGGER_S = 60.0
#: Restarts of a dying FSW (or logger) before the run is failed.
DEFAULT_MAX_RESTARTS = 3


@dataclass(frozen=True)
class Restart:
    """One restart of a supervised process, as the launcher saw it."""

    process: str
    exit_code: int  # of the process that died (negative: killed by that signal)
    at_unix_s: float
    at_wall_s: float  # seconds since the launcher started the run
    checkpoint_measurements: int | None  # measurements the checkpoint had taken (it goes on after them)
    checkpoint_t_s: float | None  # mission time (TDB s past J2000) of the checkpoint's newest measurement


#: What is restarted when it dies: the FSW from its checkpoint, the logger on a new segment.
RESTARTABLE = ("fsw", "ground")


def _died(child: Child) -> bool:
    """The process died (a signal, a crash) rather than failing for a reason it stated in its
    one-line error (a full disk, a refused checkpoint): only the former is worth a restart."""
    if child.proc.returncode is not None and child.proc.returncode < 0:
        return True
    return not last_words(child.tail).startswith("navbank ")


def segment_path(out_dir: Path, n: int) -> Path:
    """Segment ``n`` of the recording of a run whose logger was restarted (``run.mcap`` is
    renamed segment 0 when its logger dies); they are merged into ``run.mcap`` at the end."""
    return out_dir / f"run.seg{n}.mcap"


def _restart_arguments(role: str, out_dir: Path, n: int) -> tuple[str, ...]:
    """The options that make the ``n``-th restarted process go on where the dead one stopped."""
    if role == "fsw":
        return ("--resume", str(out_dir / CHECKPOINT))
    if n == 1 and (out_dir / "run.mcap").exists():
        os.replace(out_dir / "run.mcap", segment_path(out_dir, 0))
    earlier = [a for i in range(n) if segment_path(out_dir, i).exists() for a in ("--after", str(segment_path(out_dir, i)))]
    return ("--out", str(segment_path(out_dir, n)), *earlier)  # the last --out is the one taken


def _restart_record(child: Child, ckpt: Path, wall_s: float) -> Restart:
    from fsw.core.checkpoint import CheckpointError, read_header

    if child.role != "fsw":
        return Restart(child.role, int(child.proc.returncode), time.time(), wall_s, None, None)
    try:
        header = read_header(ckpt)
        taken: int | None = header.measurements_taken
        t_s: float | None = header.t_s
    except CheckpointError:
        taken = t_s = None  # the new process refuses it with one line, and the run fails with it
    return Restart(child.role, int(child.proc.returncode), time.time(), wall_s, taken, t_s)


#: How long a producer (simulator, FSW) may take to stop before it is killed; the logger, stopped
#: last, gets GRACE_S to finish its file.
PRODUCER_GRACE_S = 3.0


def _stop(children: list[Child]) -> None:
    """Stop the processes in the reverse of their start order — the simulator, then the FSW, the
    logger last — so the logger still records what the others say as they stop (the FSW's final
    counters)."""
    for i, c in enumerate(reversed(children)):
        if c.proc.poll() is None:
            c.proc.send_signal(signal.SIGTERM)
        grace = GRACE_S if i == len(children) - 1 else PRODUCER_GRACE_S
        try:
            c.proc.wait(timeout=grace)
        except subprocess.TimeoutExpired:
            c.proc.kill()
            c.proc.wait()


def launch(cfg: ScenarioConfig, run_id: str, out_dir: Path, *, timeout_s: float = 3600.0,
           echo: Callable[[str], None] | None = None, max_restarts: int = DEFAULT_MAX_RESTARTS,
           restarts: list[Restart] | None = None, authenticated: bool = True,
           live: tuple[str, int] | None = None, rate: float | None = None,
           summary_context: Mapping[str, Any] | None = None) -> dict[str, int]:
    """Run the three processes for ``cfg`` (already resolved: seed and initial state fixed);
    ``live``: (host, port) of the logger's Foxglove WebSocket live view; ``rate``: the simulator
    publishes at that many times real time (default: as fast as the FSW takes it);
    ``summary_context``: the logger writes the run's summary to :data:`LOGGER_SUMMARY` with these
    facts (``navbank ground log --summary-context``).

    An FSW that dies is restarted from its last checkpoint, a logger that dies on a new segment
    (:func:`segment_path`), each at most ``max_restarts`` times; each restart is appended to
    ``restarts`` (also when the run then fails). Returns the exit code
    per role; raises :class:`RunFailed` if a process failed for good or time ran out. With
    ``authenticated`` the run's credentials are made first and removed at the end (module doc)."""
    restarts = [] if restarts is None else restarts
    out_dir.mkdir(parents=True, exist_ok=True)
    # a directory used before must not hand this run another run's checkpoint or segments
    for stale in [out_dir / CHECKPOINT, out_dir / LOGGER_SUMMARY, *out_dir.glob("run.seg*.mcap")]:
        stale.unlink(missing_ok=True)
    cfg_path = out_dir / "config.yaml"
    cfg_path.write_text(to_yaml(cfg, complete=True), encoding="utf-8")
    private = credentials = None
    if authenticated:
        try:
            private = Path(tempfile.mkdtemp(prefix=f"navbank-{run_id}-"))  # mode 0700
            credentials = make_credentials(private / "credentials")
        except OSError as exc:
            if private is not None:
                shutil.rmtree(private, ignore_errors=True)
            raise RunFailed(f"cannot make the run's credentials: {_errno_text(exc)}") from None
    try:
        return _launch(cfg_path, run_id, out_dir, timeout_s, echo, max_restarts, restarts, credentials, live, rate,
                       summary_context)
    finally:
        if private is not None:
            shutil.rmtree(private, ignore_errors=True)  # our own temporary directory


def _launch(cfg_path: Path, run_id: str, out_dir: Path, timeout_s: float, echo: Callable[[str], None] | None,
            max_restarts: int, restarts: list[Restart], credentials: Path | None,
            live: tuple[str, int] | None = None, rate: float | None = None,
            summary_context: Mapping[str, Any] | None = None) -> dict[str, int]:
    ports = free_tcp_ports(len(ROLES))
    proto = "tcp" if credentials is None else "tls"
    eps = {r: f"{proto}/127.0.0.1:{p}" for r, p in zip(ROLES, ports)}
    env = dict(os.environ, PYTHONUNBUFFERED="1", **supervisor_env())
    children: list[Child] = []
    interrupted = threading.Event()
    old = {s: signal.signal(s, lambda *_: interrupted.set()) for s in (signal.SIGINT, signal.SIGTERM)}
    wall0 = time.monotonic()

    def start(role: str, extra: tuple[str, ...] = (), log_name: str | None = None) -> Child:
        proc = subprocess.Popen([*_command(role, cfg_path, run_id, out_dir, eps, credentials, live, rate, summary_context),
                                 *extra], stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, text=True, env=env,
                                start_new_session=True)
        child = Child(role, proc, out_dir / (log_name or f"{role}.log"))
        child.thread = threading.Thread(target=_pump, args=(child, proc.stdout, echo if role == "fsw" else None),
                                        daemon=True)
        child.thread.start()
        return child

    try:
        for role in ROLES:
            children.append(start(role))
        deadline = time.monotonic() + timeout_s
        while True:
            codes = {c.role: c.proc.poll() for c in children}
            failed = [c for c in children if codes[c.role] not in (None, 0)]
            for c in failed:
                if c.thread:
                    c.thread.join(timeout=2)  # its last words are read before they are judged
            restartable = [c for c in failed if c.role in RESTARTABLE and _died(c) and not interrupted.is_set()
                           and sum(r.process == c.role for r in restarts) < max_restarts
                           and (c.role != "fsw" or (out_dir / CHECKPOINT).is_file())]
            if restartable:
                c = restartable[0]
                restarts.append(_restart_record(c, out_dir / CHECKPOINT, time.monotonic() - wall0))
                n = sum(r.process == c.role for r in restarts)
                if echo is not None:
                    echo(f"navbank run: the {c.role} process exited with code {c.proc.returncode} "
                         f"({last_words(c.tail)}); restarting it (restart {n} of at most {max_restarts})")
                children[children.index(c)] = start(c.role, _restart_arguments(c.role, out_dir, n), f"{c.role}.restart{n}.log")
                continue
            if failed:
                c = failed[0]
                _stop(children)
                for ch in children:
                    if ch.thread:
                        ch.thread.join(timeout=2)
                why = last_words(c.tail)
                log = f"{c.log_path} (not written: {c.log_error})" if c.log_error else str(c.log_path)
                n = sum(r.process == c.role for r in restarts)
                after = f" after {n} restart(s)" if n else ""
                raise RunFailed(f"the {c.role} process exited with code {codes[c.role]} ({why}){after}; "
                                f"the others were stopped. Log: {log}")
            if all(code == 0 for code in codes.values()):
                break
            if interrupted.is_set():
                _stop(children)
                raise KeyboardInterrupt
            if time.monotonic() > deadline:
                _stop(children)
                waiting = ", ".join(c.role for c in children if codes[c.role] is None)
                raise RunFailed(f"the run did not end within {timeout_s:g} s (still running: {waiting}); all stopped")
            time.sleep(POLL_S)
        for c in children:
            if c.thread:
                c.thread.join(timeout=5)
        return {c.role: c.proc.returncode for c in children}
    finally:
        for s, h in old.items():
            signal.signal(s, h)
        for c in children:
            if c.proc.poll() is None:
                c.proc.kill()


def write_summary(summary: dict, out_dir: Path) -> Path:
    return write_json(summary, out_dir / "summary.json")
