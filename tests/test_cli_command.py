"""Processes started by hand with credentials: `navbank fsw --credentials` commanded by `navbank command`,
finding each other by run id (no endpoint options)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import pytest

from tools.credentials import make_credentials

pytestmark = pytest.mark.slow

SCENARIO = """\
name: by-hand
seed: 5
sim:
  trajectory: {span_days: 1.0}
fsw:
  gating:
    - {network: chi2, batch_size: 50}
"""


def test_only_the_operator_with_the_run_key_commands_a_fsw_started_by_hand(tmp_path):
    xdg = tmp_path / "xdg"
    xdg.mkdir(mode=0o700)
    env = dict(os.environ, XDG_RUNTIME_DIR=str(xdg))

    def _navbank(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "tools.cli", *args], capture_output=True, text=True,
                              timeout=timeout, env=env)

    creds = tmp_path / "creds"
    assert _navbank("credentials", str(creds)).returncode == 0
    scen = tmp_path / "s.yaml"
    scen.write_text(SCENARIO)
    fsw = subprocess.Popen([sys.executable, "-m", "tools.cli", "fsw", "--scenario", str(scen), "--run-id", "by-hand",
                            "--consumers", "", "--credentials", str(creds), "--quiet"],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        deadline = time.monotonic() + 60
        while not (announced := list((xdg / "navbank" / "by-hand").glob("fsw-*.json"))):
            assert time.monotonic() < deadline and fsw.poll() is None, "the FSW never announced itself"
            time.sleep(0.1)
        ep = json.loads(announced[0].read_text())["endpoint"]
        assert ep.startswith("tls/127.0.0.1:")  # with credentials it listens on TLS only
        port = ep.rsplit(":", 1)[1]
        while True:  # until the FSW answers; no endpoint options: the command finds it by run id
            ok = _navbank("command", "status", "--run-id", "by-hand", "--credentials", str(creds))
            if ok.returncode == 0 or time.monotonic() > deadline or fsw.poll() is not None:
                break
            time.sleep(0.3)
        assert ok.returncode == 0, ok.stderr
        net = ("--run-id", "by-hand", "--connect", ep, "--connect-timeout", "2")
        reply = json.loads(ok.stdout)
        assert reply["ok"] and reply["status"]["refused_commands"] == 0
        # the ground's certificate of the same run: the FSW's access-control list drops the query
        wrong_role = _navbank("command", "disable-filter", "--filter", "radio", *net, "--credentials", str(creds),
                              "--role", "ground", "--timeout", "1")
        assert wrong_role.returncode == 1 and "no FSW of run by-hand answered" in wrong_role.stderr, wrong_role.stderr
        # no certificate at all: no link
        plain = _navbank("command", "reset-gating", "--network", "chi2", "--run-id", "by-hand", "--connect",
                         f"tcp/127.0.0.1:{port}", "--connect-timeout", "1")
        assert plain.returncode == 1 and "cannot open Zenoh session" in plain.stderr, plain.stderr
        again = json.loads(_navbank("command", "status", *net, "--credentials", str(creds)).stdout)
        # nothing else reached it: one more command carried out, none refused
        assert again["ok"] and again["status"]["refused_commands"] == 0
        assert again["status"]["commands_ok"] == reply["status"]["commands_ok"] + 1
    finally:
        fsw.send_signal(signal.SIGTERM)
        try:
            fsw.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            fsw.kill()
            fsw.communicate()
