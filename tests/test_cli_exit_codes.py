"""Exit codes a supervisor can trust: a broken output pipe is not a success."""

from __future__ import annotations

import subprocess
import sys


def test_a_broken_output_pipe_is_a_non_zero_exit():
    proc = subprocess.Popen([sys.executable, "-m", "tools.cli", "scenarios", "--show", "pathfinder-cruise"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()  # the reader is gone before the command writes, as a killed launcher's pipe is
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 141, err  # the shell's code for SIGPIPE
    assert b"Traceback" not in err
