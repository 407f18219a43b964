"""`navbank recover` on a recording whose writer was killed: a complete file plain readers open."""

from __future__ import annotations

import subprocess
import sys
import time

import pytest
from mcap.reader import make_reader

WRITER = """
import sys, time
from fsw.interface import messages as m
from ground.mcap_io.recorder import McapRecorder
rec = McapRecorder(sys.argv[1], flush_interval_s=0.05)
rec.add_metadata("navbank.run", {"run_id": "killed"})
k = 0
while True:
    msg = m.RunStatus(t_s=float(k), timestamp=m.Stamp(sec=k, nsec=0), run_id="killed", source="sim", state="running",
                      counts={"k": k})
    rec.write_message("sim/status", msg, log_time_ns=1_700_000_000_000_000_000 + k)
    k += 1
    if k == 3000:
        print("written", flush=True)
    if k >= 3000:
        time.sleep(0.001)
"""


def _navbank(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "tools.cli", *args], capture_output=True, text=True, timeout=120)


def _plain_read(path) -> int:
    with open(path, "rb") as f:
        return sum(1 for _ in make_reader(f).iter_messages())


def test_a_killed_recording_is_recovered_into_a_file_plain_readers_open(tmp_path):
    src = tmp_path / "run.mcap"
    writer = subprocess.Popen([sys.executable, "-c", WRITER, str(src)], stdout=subprocess.PIPE, text=True)
    try:
        assert writer.stdout.readline().strip() == "written"
        time.sleep(0.3)  # a few more flushed chunks
    finally:
        writer.kill()
        writer.wait(30)
    with pytest.raises(Exception):
        _plain_read(src)  # no footer: the seeking reader refuses the whole file

    proc = _navbank("recover", str(src))
    assert proc.returncode == 0, proc.stderr
    dst = tmp_path / "run.recovered.mcap"
    assert "incomplete" in proc.stdout and str(dst) in proc.stdout and "/sim/status" in proc.stdout
    assert _plain_read(dst) >= 3000

    again = _navbank("recover", str(dst))
    assert again.returncode == 0 and "already complete" in again.stdout


def test_recover_refuses_what_is_not_an_mcap_file_in_one_line(tmp_path):
    bad = tmp_path / "notes.mcap"
    bad.write_text("not an mcap file")
    proc = _navbank("recover", str(bad))
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1 and "not an MCAP file" in proc.stderr
    assert "Traceback" not in proc.stderr
