"""Every command that takes --run-id checks it with one argparse type (a run id is one Zenoh key
chunk): a bad one is one line on stderr and exit code 2, before anything starts."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

COMMANDS = {
    "run": ["run"],
    "sim": ["sim"],
    "fsw": ["fsw"],
    "ground log": ["ground", "log", "--out", "x.mcap"],
    "replay": ["replay", "x.mcap"],
}


def _navbank(*argv: str, cwd: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "tools.cli", *argv], capture_output=True, text=True, timeout=120,
                          cwd=cwd, env=env)


@pytest.mark.parametrize("bad", ["a/b*", "", "x" * 65, "a b", "**"])
@pytest.mark.parametrize("command", list(COMMANDS))
def test_bad_run_id_is_one_line_exit_2(tmp_path, command, bad):
    proc = _navbank(*COMMANDS[command], "--run-id", bad, cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith(f"navbank {command}: error: argument --run-id: run id {bad!r}: expected 1-64 characters")
    assert "Traceback" not in proc.stderr
    assert list(tmp_path.iterdir()) == []  # nothing started, nothing written


def test_one_type_for_every_command():
    """The commands share tools.commands.arg_types.run_id_arg (no local copies to drift apart)."""
    from tools.cli import build_parser
    from tools.commands.arg_types import run_id_arg

    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    seen = []
    for name, p in sub.choices.items():
        parsers = [p]
        for a in p._actions:
            if a.dest == "ground_command":
                parsers = list(a.choices.values())
        for q in parsers:
            for a in q._actions:
                if "--run-id" in a.option_strings:
                    assert a.type is run_id_arg, name
                    seen.append(name)
    assert sorted(seen) == sorted(["run", "sim", "fsw", "ground", "replay", "command"])


def test_good_run_id_passes_the_check():
    from tools.cli import build_parser

    args = build_parser().parse_args(["ground", "log", "--run-id", "run-1.a_B", "--out", "x.mcap"])
    assert args.run_id == "run-1.a_B"
