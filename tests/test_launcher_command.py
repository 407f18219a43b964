"""The command lines the launcher starts its processes with."""

from __future__ import annotations

from pathlib import Path

from tools.launcher import PEER_START_S, ROLES, _command


def _commands(tmp_path: Path) -> dict[str, list[str]]:
    eps = {r: f"tcp/127.0.0.1:{7400 + i}" for i, r in enumerate(ROLES)}
    return {r: _command(r, tmp_path / "config.yaml", "run-1", tmp_path, eps) for r in ROLES}


def test_a_process_waits_for_the_earlier_ones_as_long_as_a_first_compilation_takes(tmp_path):
    cmds = _commands(tmp_path)
    assert "--connect" not in cmds["ground"] and "--connect-timeout" not in cmds["ground"]
    for role in ("fsw", "sim"):
        cmd = cmds[role]
        # each connects to every role started before it ...
        want = [ep for r in ROLES[:ROLES.index(role)] for ep in ("--connect", f"tcp/127.0.0.1:{7400 + ROLES.index(r)}")]
        got = [a for i, a in enumerate(cmd) if a == "--connect" or (i and cmd[i - 1] == "--connect")]
        assert got == want
        # ... and waits for them longer than the kernels' first compilation (the default is 10 s)
        assert float(cmd[cmd.index("--connect-timeout") + 1]) == PEER_START_S >= 120.0
