"""The core's counters: what it refused, what failed, and what it emitted per topic.

They go out in every ``RunStatus`` and in the reply to the ``status`` telecommand. The per-topic
counts of emitted messages are announced in the end-of-run status so the ground logger can
confirm it has received everything; the core counts what it hands to its ``emit`` callback,
which are exactly the messages the FSW process's publishers put.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Callable

if TYPE_CHECKING:  # annotations only: the ground reads the status keys below without the bank's kernels
    from fsw.executive import FrameExecutive
    from fsw.filters.bank import FilterBank
    from fsw.ingest import SequenceGuard

#: Key prefix of a status counter holding a stage label's measured CPU in microseconds (mode cpu).
STAGE_CPU_PREFIX = "stage_cpu_us_"

#: Counters a driver adds to the core's own (e.g. refused topics, transport gaps).
ExtraCounters = Callable[[], dict[str, int]]


@dataclass(slots=True)  # slotted: see fsw.executive.FrameExecutive
class CoreCounters:
    decode_errors: int = 0
    bank_rejected: Counter[str] = field(default_factory=Counter)
    gating_errors: int = 0
    commands_ok: int = 0
    commands_rejected: int = 0
    commands_malformed: int = 0  # payloads that did not decode as a Telecommand
    emitted: Counter[str] = field(default_factory=Counter)  # messages per topic, in first-emit order


def status_counts(counters: CoreCounters, guard: SequenceGuard, bank: FilterBank, executive: FrameExecutive,
                  extra: ExtraCounters | None = None) -> dict[str, int]:
    """The counters of a ``RunStatus``: intake, bank rejections by reason, processing, errors,
    telecommands, backlog, the CPU of each stage label (budget mode cpu); ``rejected`` totals
    every measurement not processed for a reason."""
    c = guard.counters.as_dict()
    c["decode_errors"] = counters.decode_errors
    c["bank_rejected"] = sum(counters.bank_rejected.values())
    for reason, n in sorted(counters.bank_rejected.items()):
        c[f"bank_rejected_{reason}"] = n
    c["processed"] = int(bank.processed_count)
    c["gating_errors"] = counters.gating_errors
    c["stage_errors"] = len(executive.errors)
    c["commands_ok"] = counters.commands_ok
    c["commands_rejected"] = counters.commands_rejected
    c["commands_malformed"] = counters.commands_malformed
    c["backlog"] = int(executive.backlog)
    c["pending"] = int(executive.pending_jobs)  # queued, due or not yet due
    c["rejected"] = c.get("rejected", 0) + c["decode_errors"] + c["bank_rejected"]
    c.update(bank.adaptive_counts())  # FLR LPs, failures, fallbacks, CPU (only with adaptive filters)
    # budget mode cpu: the thread CPU measured in each stage label so far, in whole microseconds
    # (where the core's CPU goes, stage by stage; nothing in mode work-units)
    for label, (_, cpu_s) in executive.stage_cpu().items():
        c[STAGE_CPU_PREFIX + label] = int(round(cpu_s * 1e6))
    if extra is not None:
        c.update(extra())
    return c


def stage_cpu_by_label(counts: dict[str, int]) -> dict[str, float]:
    """CPU seconds per stage label from a ``RunStatus``'s counts (empty if the run measured none)."""
    n = len(STAGE_CPU_PREFIX)
    return {key[n:]: value * 1e-6 for key, value in counts.items() if key.startswith(STAGE_CPU_PREFIX)}
