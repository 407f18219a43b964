"""The simulated stream is bit-identical to the one recorded before the simulator was sped up.

Digests were taken from the simulator as it was before its vectorised light-time, Earth
orientation, time-scale and message-building paths: every message (topic and repr, which prints
floats exactly), the true reception times and every array of the radiometric and optical data.
A deliberate change of the simulated stream must update these digests and say why.

The truth integration and the geometry go through small matrix products, which numpy hands to
OpenBLAS, and OpenBLAS rounds them differently on different CPUs (its Haswell and SkylakeX
kernels differ in the last bits: 9e-12 relative in a truth position after the integration, 1e-10
in a Doppler value). numpy's own float64 loops do too: with AVX-512 it dispatches to other loops
than with AVX2 (the first digests, made where AVX-512 was on, differed in every case on an AMD
EPYC without it, OpenBLAS's kernel the same). The digests are of the stream on the BLAS kernel
and numpy targets of ``golden/recorded-with.json`` (Haswell, AVX-512 targets off: what an AVX2
machine runs natively) and are checked in a subprocess forced onto them; on this machine's own
kernel and targets the stream must be the same messages with every number within
``NATIVE_RTOL``.
"""

import dataclasses
import hashlib
import math
import pickle
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from blas_kernel import RECORDED_WITH, blas_core, recorded_kernel_env

from sim.faults.presets import preset
from sim.stream import SimRun, generate
from tools.scenario import load_scenario, resolve

DIGESTS = {
    ("insight-approach", 1, None): "5b79396ac56d4f7a3f7b8165d48a2745140b2ef4dce324b88768e162bacb8601",
    ("insight-approach", 7, None): "43331df45b6ed15080848c1443fb618ed9fcc39e3d39a5e72d11014612b67792",
    ("insight-thrusters", 1, None): "a2bb82929fd1a69eed381d25cd4fba91ed422cc70fc00d6dc1d4359429d2fb52",
    ("insight-thrusters", 7, None): "e388410b9c9f8ff233b3e42916e8aa81ea488cb49a1f34388e87ac4592dc49cb",
    ("pathfinder-cruise", 1, None): "fd6e3ee194e2f7b6062b8ef677b7707b22b39a6d620a92a59c200c92309f27cb",
    ("pathfinder-cruise", 7, None): "bdb0c426f3a069f7cf1f7e3129c1ec01c8702b58500a9aef19ebb97cedb3f284",
    ("leo-injection", 1, None): "b8cd9e70cb6d550e2599303c31253d75e5e5e816640e449dcfa5ead388c219d3",
    ("leo-injection", 7, None): "675f76554c6ec87f36efb1514dc6f3b05e43db169b27b6b714458024f04143b2",
    ("insight-approach", 3, "clock-bias"): "1f47fd33bb78105037651497f0293832c05146cec322b254230fee73c49b6b07",
    ("pathfinder-cruise", 2, "radio-bias-medium"): "3d34d850437b2f378d31037b1945690c5286455f033b3d51f4fafcef23081c38",
}
FAST = {("insight-approach", 1, None), ("pathfinder-cruise", 7, None), ("leo-injection", 1, None),
        ("insight-approach", 3, "clock-bias")}


def stream_digest(run: SimRun) -> str:
    """SHA-256 over every message in time order and the run's measurement arrays."""
    h = hashlib.sha256()
    for topic, msg in run.iter_messages():
        h.update(topic.encode())
        h.update(repr(msg).encode())
    h.update(np.ascontiguousarray(run.t_true).tobytes())
    for data in (run.radio, run.optical):
        if data is None:
            continue
        for name, value in sorted(vars(data).items()):
            a = np.asarray(value)
            h.update(name.encode())
            h.update(repr(a.tolist()).encode() if a.dtype == object else a.tobytes())
    return h.hexdigest()


def flown(name: str, seed: int, fault: str | None) -> SimRun:
    cfg, seed = resolve(load_scenario(name), seed)
    return generate(cfg.sim, faults=preset(fault) if fault else None, seed=seed)


HERE = Path(__file__).resolve().parent
#: Largest relative difference a number of the stream may show on another BLAS kernel than the
#: recordings' (measured between Haswell and SkylakeX: 1.3e-10 in a Doppler value).
NATIVE_RTOL = 1e-9


def fly_on_recorded_kernel(case: tuple, out: Path) -> str:
    """The case's digest flown in a subprocess on the recordings' BLAS kernel; its messages
    pickled to ``out``."""
    code = ("import pickle, sys; sys.path.insert(0, sys.argv[1]); "
            "from test_sim_stream_identity import flown, stream_digest; "
            "run = flown(sys.argv[2], int(sys.argv[3]), sys.argv[4] or None); "
            "pickle.dump(list(run.iter_messages()), open(sys.argv[5], 'wb')); print(stream_digest(run))")
    name, seed, fault = case
    proc = subprocess.run([sys.executable, "-c", code, str(HERE), name, str(seed), fault or "", str(out)],
                          env=recorded_kernel_env(), capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc.stdout.split()[-1]


def assert_close(a: object, b: object, path: str) -> None:
    """Same structure and values, floats within NATIVE_RTOL relative (exact zeros equal)."""
    if isinstance(a, float) and isinstance(b, float):
        assert math.isclose(a, b, rel_tol=NATIVE_RTOL, abs_tol=0.0) or a == b, (path, a, b)
    elif dataclasses.is_dataclass(a) and not isinstance(a, type):
        assert type(a) is type(b), path
        for f in dataclasses.fields(a):
            assert_close(getattr(a, f.name), getattr(b, f.name), f"{path}.{f.name}")
    elif isinstance(a, (tuple, list)):
        assert isinstance(b, (tuple, list)) and len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            assert_close(x, y, f"{path}[{i}]")
    else:
        assert a == b, (path, a, b)


@pytest.mark.parametrize("case", [pytest.param(c, marks=() if c in FAST else pytest.mark.slow,
                                               id="-".join(str(v) for v in c if v is not None)) for c in DIGESTS])
def test_stream_is_bit_identical_to_the_recorded_one(case, tmp_path):
    assert fly_on_recorded_kernel(case, tmp_path / "stream.pkl") == DIGESTS[case]


def test_stream_on_this_machine_s_kernel_differs_from_the_recorded_one_in_rounding_only(tmp_path):
    case = ("insight-approach", 1, None)
    fly_on_recorded_kernel(case, tmp_path / "stream.pkl")
    with open(tmp_path / "stream.pkl", "rb") as f:
        recorded = pickle.load(f)
    native = list(flown(*case).iter_messages())
    print(f"BLAS kernel {blas_core()!r}, recorded with {RECORDED_WITH['blas_core']!r}")
    assert len(native) == len(recorded)
    for i, ((topic, msg), (topic_r, msg_r)) in enumerate(zip(native, recorded)):
        assert topic == topic_r, i
        assert_close(msg, msg_r, f"{i}:{topic}")
