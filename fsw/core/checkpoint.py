"""Checkpoints of the flight software: everything a restarted FSW needs to go on as if it had not died.

What a checkpoint holds (and nothing else):

* the :class:`~fsw.core.FswCore` — the filter bank, every gating network, the anomaly detector and
  its reporter, the frame executive with its backlog, the sequence guard (re-order window, lost
  ranges), the counters and the telemetry cadences — pickled whole, minus what belongs to the
  process around it: its emit callback and the driver's extra counters (``FswCore.__getstate__``),
  and the executive's lock (``FrameExecutive.__getstate__``);
* ``measurements_taken``: how many measurement samples the process had taken from the transport
  (its next expected publisher sequence number: the producer resends from there);
* ``published``: each telemetry publisher's sequence counter, so telemetry emitted again after a
  restart carries the numbers it carried the first time and the logger drops it as duplicates;
* ``producer_end``: the producer's end-of-run status, once it has arrived;
* ``accepted_nonces``: the telecommand nonces already served (a run with credentials), so a
  restarted FSW refuses a captured command replayed at it just as the first one would have. The
  FSW checkpoints right after serving a telecommand, so neither a command's effect nor its nonce
  falls between two checkpoints.

The file is one JSON header line (format, version, ICD schema version, run id, a hash of the FSW
configuration, the payload's length and SHA-256, and the position in the stream) followed by the
pickle. :func:`read` refuses, with one line, a file of another format or version, of another run
or configuration, or whose payload does not match its hash — it never unpickles those. Writing is
atomic (:func:`write`: temporary file, fsync, rename, fsync of the directory): a process killed
while writing leaves the previous checkpoint intact.

Pickle executes code on load, and the SHA-256 guards against truncation, not against forgery.
In a run with credentials the header therefore also carries an HMAC-SHA256 of the payload under
the run's key (``payload_hmac``), and :func:`read` given the key refuses a file without a valid
one before unpickling: only a holder of the run's key can hand the FSW a checkpoint. Without
credentials a checkpoint is trusted input, like the rest of the run's directory.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import os
import pickle
from dataclasses import dataclass, field
from collections.abc import Callable
from pathlib import Path
from typing import Any

from fsw.config import FswConfig
from fsw.core.fswcore import FswCore
from fsw.core.telemetry import Emit
from fsw.interface import codec, typed
from fsw.interface.messages import SCHEMA_VERSION, RunStatus

FORMAT = "navbank-fsw-checkpoint"
#: Bumped whenever what is pickled changes shape: an older file is refused, not misread.
VERSION = 12  # 12: the executive's stage queue keeps lanes only while two or more jobs are
# outstanding (None otherwise); 11: the chi-square network keeps its batch sums as one (4, N) array; 10: the core
# holds the records of the residuals not yet sent, not their samples; 9:
# the CPU meter keeps each stage label's measured CPU; 8: the core and the objects
# it runs per measurement are slotted (their pickles carry slots, not instance dictionaries); 7: the
# filter stack keeps the drivers' columns for the compiled steps; 6: the telemetry not yet
# published; 5: the filter stack keeps work arrays for range predictions; 4: the ephemeris
# environment pickles its table span and station nodes compactly; 3: the core holds the residuals of
# the current batch and the B-plane cadence
#: The header line is read before anything else; a longer one is not a checkpoint.
MAX_HEADER_BYTES = 4096


class CheckpointError(ValueError):
    """A checkpoint that cannot be used; the message is one line naming the file."""


@dataclass
class Checkpoint:
    """A restartable FSW: its core and where it stood on the bus."""

    core: FswCore
    measurements_taken: int
    published: dict[str, int] = field(default_factory=dict)
    producer_end: RunStatus | None = None
    # telecommand nonces already served: a restarted FSW must not serve a captured command again
    accepted_nonces: list[str] = field(default_factory=list)
    # what the core had emitted but the process not yet published, (topic, message) oldest first:
    # a restart publishes it first (``published`` counts what had been)
    unpublished: list[tuple[str, Any]] = field(default_factory=list)


@dataclass(frozen=True)
class Header:
    """The checkpoint's first line: what it is, whose it is, and where the FSW stood."""

    run_id: str
    config_sha256: str
    measurements_taken: int
    t_s: float  # epoch of the newest measurement handled (mission time)
    payload_bytes: int
    payload_sha256: str
    producer_ended: bool


def config_digest(config: FswConfig) -> str:
    """SHA-256 of the FSW configuration's canonical JSON: a checkpoint resumes only the same FSW.

    The configuration is frozen and a process writes a checkpoint every few hundred measurements
    of the same one: the last digest is kept for it (its encoding cost ~0.8 ms a checkpoint)."""
    last = _last_digest[0]
    if last is not None and last[0] is config:
        return last[1]
    text = json.dumps(typed.encode(config), sort_keys=True, separators=(",", ":"))
    digest = hashlib.sha256(text.encode()).hexdigest()
    _last_digest[0] = (config, digest)
    return digest


_last_digest: list[tuple[FswConfig, str] | None] = [None]


#: Signs checkpoint bytes under the run's key (hex digest), e.g.
#: :meth:`fsw.interface.auth.MessageAuthenticator.file_tag`.
Signer = Callable[[bytes], str]


def dumps(ckpt: Checkpoint, signer: Signer | None = None) -> bytes:
    """The checkpoint file's bytes (header line + pickle).

    With ``signer`` (a run with credentials) the header carries an HMAC of the payload, and
    :func:`read` with the same key unpickles nothing that lacks it: unpickling runs code, so a
    checkpoint edited by anyone without the run's key must be refused before it is loaded."""
    payload = pickle.dumps(
        {"core": ckpt.core, "measurements_taken": int(ckpt.measurements_taken),
         "published": dict(ckpt.published),
         "producer_end": None if ckpt.producer_end is None else codec.to_json(ckpt.producer_end),
         "accepted_nonces": list(ckpt.accepted_nonces), "unpublished": list(ckpt.unpublished)},
        protocol=pickle.HIGHEST_PROTOCOL)
    header = {
        "format": FORMAT, "version": VERSION, "schema_version": SCHEMA_VERSION,
        "run_id": ckpt.core.run_id, "config_sha256": config_digest(ckpt.core.config),
        "measurements_taken": int(ckpt.measurements_taken), "t_s": float(ckpt.core.t_last),
        "payload_bytes": len(payload), "payload_sha256": hashlib.sha256(payload).hexdigest(),
        "producer_ended": ckpt.producer_end is not None,
    }
    if signer is not None:
        header["payload_hmac"] = signer(payload)
    return json.dumps(header, sort_keys=True).encode() + b"\n" + payload


def write(path: str | os.PathLike[str], ckpt: Checkpoint, signer: Signer | None = None) -> int:
    """Write ``ckpt`` to ``path`` atomically (temporary file, fsync, rename, fsync of the
    directory); returns the bytes written. The previous checkpoint stays until the rename."""
    path = Path(path)
    data = dumps(ckpt, signer)
    tmp = path.with_name(path.name + ".tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    try:
        view = memoryview(data)
        while view:
            view = view[os.write(fd, view):]
        os.fsync(fd)
    finally:
        os.close(fd)
    os.replace(tmp, path)
    dfd = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(dfd)  # the rename itself survives a crash
    finally:
        os.close(dfd)
    return len(data)


def _split(path: Path, data: bytes) -> tuple[dict[str, Any], bytes]:
    end = data.find(b"\n", 0, MAX_HEADER_BYTES)
    try:
        if end < 0:
            raise ValueError("no header line")
        header = json.loads(data[:end])
        if not isinstance(header, dict):
            raise ValueError("header is not an object")
    except ValueError:
        raise CheckpointError(f"{path}: not a navbank FSW checkpoint") from None
    if header.get("format") != FORMAT:
        raise CheckpointError(f"{path}: not a navbank FSW checkpoint")
    if header.get("version") != VERSION or header.get("schema_version") != SCHEMA_VERSION:
        raise CheckpointError(f"{path}: checkpoint version {header.get('version')} (ICD v{header.get('schema_version')}); "
                              f"this FSW reads version {VERSION} (ICD v{SCHEMA_VERSION}) only")
    return header, data[end + 1:]


def _header(header: dict[str, Any]) -> Header:
    return Header(run_id=str(header["run_id"]), config_sha256=str(header["config_sha256"]),
                  measurements_taken=int(header["measurements_taken"]), t_s=float(header["t_s"]),
                  payload_bytes=int(header["payload_bytes"]), payload_sha256=str(header["payload_sha256"]),
                  producer_ended=bool(header["producer_ended"]))


def read_header(path: str | os.PathLike[str]) -> Header:
    """Only the header (what the launcher records of a restart); :class:`CheckpointError` if unusable."""
    path = Path(path)
    try:
        with open(path, "rb") as f:
            head = f.read(MAX_HEADER_BYTES)
    except OSError as exc:
        raise CheckpointError(f"{path}: {exc.strerror or exc}") from None
    header, _ = _split(path, head)
    try:
        return _header(header)
    except (KeyError, TypeError, ValueError):
        raise CheckpointError(f"{path}: checkpoint header is incomplete") from None


def read(path: str | os.PathLike[str], config: FswConfig, run_id: str, emit: Emit,
         signer: Signer | None = None) -> Checkpoint:
    """The checkpoint at ``path``, its core emitting through ``emit``.

    Refused with :class:`CheckpointError` (one line) unless it is this format and version, of run
    ``run_id``, of exactly ``config``, its payload is whole, and — with ``signer`` — its payload
    carries the run key's HMAC (checked before anything is unpickled)."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise CheckpointError(f"{path}: {exc.strerror or exc}") from None
    raw, payload = _split(path, data)
    try:
        header = _header(raw)
    except (KeyError, TypeError, ValueError):
        raise CheckpointError(f"{path}: checkpoint header is incomplete") from None
    if header.run_id != run_id:
        raise CheckpointError(f"{path}: checkpoint of run {header.run_id!r}, not {run_id!r}")
    if header.config_sha256 != config_digest(config):
        raise CheckpointError(f"{path}: checkpoint of another FSW configuration")
    if len(payload) != header.payload_bytes or hashlib.sha256(payload).hexdigest() != header.payload_sha256:
        raise CheckpointError(f"{path}: checkpoint is truncated or damaged ({len(payload)} of "
                              f"{header.payload_bytes} bytes, or its hash differs)")
    if signer is not None:
        tag = raw.get("payload_hmac")
        if not isinstance(tag, str) or not hmac.compare_digest(tag, signer(payload)):
            raise CheckpointError(f"{path}: checkpoint is not signed with this run's key")
    state = pickle.loads(payload)
    core = state["core"]
    if not isinstance(core, FswCore):
        raise CheckpointError(f"{path}: checkpoint holds no FSW core")
    core.attach(emit)
    end = state["producer_end"]
    return Checkpoint(core=core, measurements_taken=int(state["measurements_taken"]),
                      published=dict(state["published"]),
                      producer_end=None if end is None else codec.from_json(RunStatus, end),
                      accepted_nonces=[str(n) for n in state.get("accepted_nonces", [])],
                      unpublished=[(str(t), msg) for t, msg in state.get("unpublished", [])])


class Schedule:
    """When the next checkpoint is due: every ``every_measurements`` taken or ``every_s`` of
    mission time, whichever comes first (a zero turns that limit off)."""

    def __init__(self, every_measurements: int, every_s: float, taken: int = 0, t_s: float = 0.0):
        self.every_measurements, self.every_s = every_measurements, every_s
        self.mark(taken, t_s)

    def mark(self, taken: int, t_s: float) -> None:
        """A checkpoint was written at ``taken`` measurements, mission time ``t_s``."""
        self._taken, self._t_s = taken, t_s

    def due(self, taken: int, t_s: float) -> bool:
        return ((self.every_measurements > 0 and taken - self._taken >= self.every_measurements)
                or (self.every_s > 0 and t_s - self._t_s >= self.every_s))
