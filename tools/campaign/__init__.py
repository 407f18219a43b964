"""Fault-injection campaigns: matrices of scenarios x faults x gating networks x seeds.

``spec`` (the campaign file), ``plan`` (expansion into runs with stable ids), ``worker`` (one
run in a worker process), ``executors`` (local spawn pool, dask), ``store`` (the JSONL of
results), ``runner`` (resume, failures, Ctrl-C), ``stats`` and ``report`` (the statistics).
``navbank campaign`` and ``navbank calibrate`` are built on them.
"""
