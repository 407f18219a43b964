"""Replay of recorded runs: republish over Zenoh (live displays, a second logger) or re-run the FSW.

* :func:`ground.replay.republish.republish` sends a recorded run's payloads again under a new
  run id, paced by the original receive times scaled by a rate;
* :func:`ground.replay.regression.rerun_and_compare` feeds the recorded measurements to a fresh
  in-process FSW built from the configuration stored in the run and diffs its telemetry against
  the recorded telemetry.

The submodules are imported where used: republishing needs no FSW code, re-running needs it all.
"""
