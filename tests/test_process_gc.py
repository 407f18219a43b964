"""A navbank process's own command line keeps the collector off start-up and off what start-up
made (tools.process_gc); a caller of tools.cli.main in its own process keeps its collector."""

from __future__ import annotations

import gc
import json
import subprocess
import sys
from pathlib import Path

from tools import process_gc
from tools.cli import main

ROOT = Path(__file__).resolve().parents[1]

# The command line of a process: main() without argv, as `python -m tools.cli` and the console
# script call it. What the collector did is read back after the command ran.
PROBE = """
import gc, json, sys
passes = []
gc.callbacks.append(lambda phase, info: phase == "start" and passes.append(info["generation"]))
sys.argv = ["navbank", "scenarios"]
from tools.cli import main
rc = main()
print(json.dumps({"rc": rc, "enabled": gc.isenabled(), "frozen": gc.get_freeze_count(),
                  "threshold": gc.get_threshold(), "full_passes": passes.count(2)}))
"""


def test_a_process_command_line_freezes_its_start_up_and_collects_less_often():
    out = subprocess.run([sys.executable, "-c", PROBE], cwd=ROOT, capture_output=True, text=True, timeout=120,
                         check=True).stdout.strip().splitlines()[-1]
    got = json.loads(out)
    assert got["rc"] == 0
    assert got["enabled"] is True
    assert got["threshold"][0] == process_gc.YOUNG_THRESHOLD
    # the command's imports (the project, numpy, yaml) are frozen: thousands of objects
    assert got["frozen"] > 10_000
    # no full pass over the imports while they were made
    assert got["full_passes"] == 0


def test_main_with_an_argv_leaves_the_callers_collector_alone(capsys):
    threshold, frozen, enabled = gc.get_threshold(), gc.get_freeze_count(), gc.isenabled()
    assert main(["scenarios"]) == 0
    assert (gc.get_threshold(), gc.get_freeze_count(), gc.isenabled()) == (threshold, frozen, enabled)
    assert "insight-approach" in capsys.readouterr().out


def test_started_after_starting_resumes_collection_with_the_young_threshold():
    code = ("import gc; from tools import process_gc as p; p.starting(); a = gc.isenabled(); p.started(); "
            "print(a, gc.isenabled(), gc.get_threshold()[0], gc.get_freeze_count() > 0)")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=60,
                         check=True).stdout.split()
    assert out == ["False", "True", str(process_gc.YOUNG_THRESHOLD), "True"]
