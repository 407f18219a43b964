"""The simulated stream is bit-identical to the one recorded before the simulator was sped up.

Digests were taken from the simulator as it was before its vectorised light-time, Earth
orientation, time-scale and message-building paths: every message (topic and repr, which prints
floats exactly), the true reception times and every array of the radiometric and optical data.
A deliberate change of the simulated stream must update these digests and say why.

The truth integration and the geometry go through small matrix products, which numpy hands to
OpenBLAS, and OpenBLAS rounds them differently on different CPUs (its Haswell and SkylakeX
kernels differ in the last bits: 9e-12 relative in a truth position after the integration, 1e-10
in a Doppler value). The digests are of the stream on the kernel the recordings were made with
(``golden/recorded-with.json``) and are checked in a subprocess forced onto that kernel; on this
machine's own kernel the stream must be the same messages with every number within
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
    ("insight-approach", 1, None): "3c12172e3b18ea9ef9586c2c792bfeac283aab6898706230401aa892f02d60b8",
    ("insight-approach", 7, None): "519e04ced070c0f16dcc1b74f84b4b70ce0867a79d28f74de6f0f03daaddc4bd",
    ("insight-thrusters", 1, None): "cd1c854bd1c3418fc808f14f500d20722f0ffaf4fcc7955e3e225f0f56220c43",
    ("insight-thrusters", 7, None): "ffce9f0f6dff466833ccffc534236bf47ccdd08e55b9dee685e2711163f4bdd1",
    ("pathfinder-cruise", 1, None): "20114d9aad4859735c666b8d7fc26a1d8ea7aad4ab57c205b08b9be991947617",
    ("pathfinder-cruise", 7, None): "bbaa3d04423c1b12a6296cef298f6bb75f51c436181122a34858a6e64218cbd8",
    ("leo-injection", 1, None): "6f8dd24ce520c06830c2fa0d719748abcd550383ab98b081b6b397beb2bbd23b",
    ("leo-injection", 7, None): "d0f517ccc4f537c51f988c1f4d17da4927f3ec826ae053a50d689ef18dc4b4f6",
    ("insight-approach", 3, "clock-bias"): "4f7dce95da1bfdef57689683d6f43da0a25e23cabdb1091d9cfc5bb35d669a69",
    ("pathfinder-cruise", 2, "radio-bias-medium"): "b709249dec1378ef3666ce22c510cc15b31bf4d336bcd8d2b9c7127367252597",
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
