"""The core's counters: what it refused, what failed, and what it emitted per topic.

They go out in every ``RunStatus`` and in the reply to the ``status`` telecommand. The per-topic
counts of emitted messages are announced in the end-of-run status so the ground logger can
confirm it has received everything; the core counts what it hands to its ``emit`` callback,
which are exactly the messages the FSW process's publishers put.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Callable

from fsw.executive import FrameExecutive
from fsw.filters.bank import FilterBank
from fsw.ingest import SequenceGuard

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
    telecommands, backlog; ``rejected`` totals every measurement not processed for a reason."""
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
    if extra is not None:
        c.update(extra())
    return c
