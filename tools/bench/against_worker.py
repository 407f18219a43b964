"""One side of ``navbank bench --against``: an FSW core of whichever ``fsw`` package this process
imports, fed a measurement stream in chunks when the driver says so (:mod:`tools.bench.against`).

Run as a script by path, with ``PYTHONPATH`` naming the tree whose ``fsw`` it is to run: it
imports the standard library and that ``fsw`` only (never ``tools`` or ``sim``, which are the
working tree's), so the same file drives the working tree's core and a past revision's. It uses
what every revision since the architecture step offers: the ICD codec and typed decoder, and
``FswCore(config, emit, run_id=...)`` with ``start``, ``ingest`` and ``finish``.

Protocol: one JSON object per line on stdin, one reply per line on stdout (anything the code
under test prints goes to stderr instead):

* ``{"load": CONFIG_FILE, "stream": STREAM_FILE}`` — the FSW configuration (JSON of the typed
  encoding) and the measurements (one ICD JSON payload per line); reply ``{"measurements": n}``;
* ``{"start": true}`` — a new core, started; reply ``{"cpu_s": ..., "kernel_cache": ...}``, the
  latter the directory numba keeps this ``fsw``'s compiled kernels in (null if it cannot tell);
* ``{"run": [i, j]}`` — ingest measurements i..j−1; reply ``{"cpu_s": ...}``, the thread CPU of
  the ingests alone;
* ``{"finish": true, "keep": PATH}`` — end of stream; reply ``{"cpu_s": ..., "digest": ...,
  "messages": n}``, the digest a SHA-256 of the topics and ICD JSON of every message the core
  emitted but its budget reports and statuses (which hold CPU figures), those lines also written
  to PATH if given;
* ``{"quit": true}``.
"""

from __future__ import annotations

import gc
import hashlib
import json
import os
import sys
import time


def _pin_to_last_cpu() -> None:
    # both sides on one processor: a difference between two processors is not a difference of code
    if hasattr(os, "sched_getaffinity"):
        cpus = sorted(os.sched_getaffinity(0))
        os.sched_setaffinity(0, {cpus[-1]})


def _kernel_cache_dir() -> str | None:
    """Where numba keeps the compiled kernels of the ``fsw`` this process runs (they are loaded
    once a core is built); None if this ``fsw`` or numba does not say."""
    try:
        from fsw.kernels import joseph_update

        return str(getattr(joseph_update.joseph_update, "_cache")._cache_path)
    except Exception:  # a revision without that kernel, or a numba that keeps it elsewhere
        return None


def main() -> int:
    # run by path, the script's directory leads sys.path: its modules (core, filters, decode, ...)
    # must not stand in for anything the FSW or its libraries import
    here = os.path.dirname(os.path.abspath(__file__))
    sys.path[:] = [p for p in sys.path if os.path.abspath(p or os.curdir) != here]
    replies = sys.stdout
    sys.stdout = sys.stderr
    _pin_to_last_cpu()
    from fsw.config import FswConfig
    from fsw.core.fswcore import FswCore
    from fsw.interface import codec, messages, typed

    measurements: list[messages.Measurement] = []
    config: FswConfig | None = None
    core: FswCore | None = None
    emitted: list[tuple[str, object]] = []

    def sink(topic: str, msg: object) -> None:
        emitted.append((topic, msg))

    for line in sys.stdin:
        request = json.loads(line)
        if "load" in request:
            with open(request["load"], encoding="utf-8") as text:
                config = typed.decode(FswConfig, json.load(text))
            with open(request["stream"], "rb") as stream:
                measurements = [codec.from_json(messages.Measurement, row) for row in stream.read().splitlines()]
            answer: dict[str, object] = {"measurements": len(measurements)}
        elif "start" in request and config is not None:
            emitted.clear()
            gc.collect()
            gc.disable()  # as the in-process runner holds it: no collection inside the timed ingests
            t0 = time.thread_time()
            core = FswCore(config, sink, run_id="bench-against")
            core.start()
            answer = {"cpu_s": time.thread_time() - t0, "kernel_cache": _kernel_cache_dir()}
        elif "run" in request and core is not None:
            i, j = request["run"]
            ingest = core.ingest
            batch = measurements[i:j]
            t0 = time.thread_time()
            for meas in batch:
                ingest(meas)
            answer = {"cpu_s": time.thread_time() - t0}
        elif "finish" in request and core is not None:
            t0 = time.thread_time()
            core.finish()
            cpu = time.thread_time() - t0
            digest = hashlib.sha256()
            n = 0
            keep = open(request["keep"], "wb") if request.get("keep") else None
            for topic, msg in emitted:
                if "budget" in topic or "status" in topic:
                    continue
                row = topic.encode() + b"\0" + codec.to_json(msg) + b"\n"
                digest.update(row)
                if keep is not None:
                    keep.write(row)
                n += 1
            if keep is not None:
                keep.close()
            answer = {"cpu_s": cpu, "digest": digest.hexdigest(), "messages": n}
            emitted.clear()
            core = None
            gc.enable()
        elif "quit" in request:
            return 0
        else:  # unknown, or out of order (a run before a start, a start before a load)
            answer = {"error": f"cannot serve {sorted(request)} now"}
        replies.write(json.dumps(answer) + "\n")
        replies.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
