"""A real Dask cluster on loopback: ``dask scheduler`` and ``dask worker`` as separate processes.

What an existing cluster looks like to ``navbank campaign --executor dask --scheduler ADDR``,
started here for the benchmark and the tests (a ``LocalCluster`` runs its scheduler inside the
client's process, so it does not show that the campaign works against one it did not start).

The scheduler picks a free port itself (``--port 0``) and writes its address to a scheduler
file, which the workers read, so there is no port race. Every wait is bounded; on exit (or any
error) the workers and then the scheduler get SIGTERM, and SIGKILL if they are still there after
a grace period. Workers run without a nanny (one process each, single-threaded) and import
:mod:`tools.campaign.warm` at start, so the first run a worker gets pays no imports; they need
the project importable: the ``cwd`` given (default: the directory holding ``tools/``) goes on
their ``PYTHONPATH``.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from types import TracebackType

PROJECT_ROOT = Path(__file__).resolve().parents[2]


def dask_cli() -> list[str]:
    """The command that runs the ``dask`` CLI of this interpreter's environment."""
    exe = Path(sys.executable).with_name("dask")
    if exe.exists():
        return [str(exe)]
    found = shutil.which("dask")
    if found:
        return [found]
    raise RuntimeError("the 'dask' command was not found (pip install navbank[dask] installs distributed)")


class LoopbackCluster:
    """Context manager: a scheduler and ``workers`` worker processes on 127.0.0.1; ``address``
    is the scheduler's ``tcp://127.0.0.1:PORT`` once entered."""

    def __init__(self, workers: int = 2, *, cwd: str | Path | None = None, start_timeout_s: float = 60.0,
                 stop_timeout_s: float = 10.0, preload: str | None = "tools.campaign.warm"):
        self.workers = workers
        self.cwd = Path(cwd) if cwd is not None else PROJECT_ROOT
        self.start_timeout_s = start_timeout_s
        self.stop_timeout_s = stop_timeout_s
        self.preload = preload
        self.address = ""
        self._tmp: tempfile.TemporaryDirectory[str] | None = None
        self._scheduler: subprocess.Popen[bytes] | None = None
        self._workers: list[subprocess.Popen[bytes]] = []

    def _env(self) -> dict[str, str]:
        env = dict(os.environ)
        path = env.get("PYTHONPATH", "")
        env["PYTHONPATH"] = str(self.cwd) + (os.pathsep + path if path else "")
        return env

    def _log(self, name: str):
        assert self._tmp is not None
        return open(Path(self._tmp.name) / f"{name}.log", "wb")

    def logs(self) -> str:
        """The tail of every process's log (for an error message)."""
        if self._tmp is None:
            return ""
        parts = []
        for p in sorted(Path(self._tmp.name).glob("*.log")):
            parts.append(f"--- {p.name}\n" + p.read_text(errors="replace")[-1500:])
        return "\n".join(parts)

    def __enter__(self) -> "LoopbackCluster":
        try:
            self._start()
        except BaseException:
            self.close()
            raise
        return self

    def _start(self) -> None:
        cli = dask_cli()
        self._tmp = tempfile.TemporaryDirectory(prefix="navbank-dask-")
        sched_file = Path(self._tmp.name) / "scheduler.json"
        env = self._env()
        with self._log("scheduler") as log:
            self._scheduler = subprocess.Popen(
                [*cli, "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                 "--scheduler-file", str(sched_file), "--idle-timeout", "3600"],
                cwd=self.cwd, env=env, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
        deadline = time.monotonic() + self.start_timeout_s
        while True:
            if self._scheduler.poll() is not None:
                raise RuntimeError(f"dask scheduler exited with {self._scheduler.returncode}\n{self.logs()}")
            try:
                self.address = json.loads(sched_file.read_text())["address"]
                break
            except (OSError, ValueError, KeyError):
                pass
            if time.monotonic() > deadline:
                raise TimeoutError(f"dask scheduler did not start in {self.start_timeout_s} s\n{self.logs()}")
            time.sleep(0.1)
        for i in range(self.workers):
            cmd = [*cli, "worker", "--scheduler-file", str(sched_file), "--host", "127.0.0.1", "--nthreads", "1",
                   "--no-nanny", "--no-dashboard", "--name", f"navbank-{i}", "--death-timeout", "60",
                   "--local-directory", self._tmp.name]
            if self.preload:
                cmd += ["--preload", self.preload]
            with self._log(f"worker-{i}") as log:
                self._workers.append(subprocess.Popen(cmd, cwd=self.cwd, env=env, stdout=log,
                                                      stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL))
        self._wait_for_workers(deadline)

    def _wait_for_workers(self, deadline: float) -> None:
        import distributed

        with distributed.Client(self.address, timeout=max(1.0, deadline - time.monotonic())) as client:
            while len(client.nthreads()) < self.workers:
                dead = [w.returncode for w in self._workers if w.poll() is not None]
                if dead:
                    raise RuntimeError(f"a dask worker exited with {dead[0]}\n{self.logs()}")
                if time.monotonic() > deadline:
                    raise TimeoutError(f"{len(client.nthreads())} of {self.workers} dask workers joined in "
                                       f"{self.start_timeout_s} s\n{self.logs()}")
                time.sleep(0.1)

    def processes(self) -> list[subprocess.Popen[bytes]]:
        return [*self._workers, *([self._scheduler] if self._scheduler is not None else [])]

    def close(self) -> None:
        """Stop the workers, then the scheduler (SIGTERM, then SIGKILL after the grace period)."""
        for group in (self._workers, [self._scheduler] if self._scheduler is not None else []):
            for p in group:
                if p.poll() is None:
                    p.terminate()
            deadline = time.monotonic() + self.stop_timeout_s
            for p in group:
                try:
                    p.wait(timeout=max(0.1, deadline - time.monotonic()))
                except subprocess.TimeoutExpired:
                    p.kill()
                    p.wait(timeout=self.stop_timeout_s)
        if self._tmp is not None:
            self._tmp.cleanup()
            self._tmp = None

    def __exit__(self, et: type[BaseException] | None, ev: BaseException | None, tb: TracebackType | None) -> None:
        self.close()


__all__ = ["LoopbackCluster", "dask_cli", "PROJECT_ROOT"]
