"""The flight software's core (see :mod:`fsw.core.fswcore`): intake, the stage pipeline, ICD
telemetry (:mod:`fsw.core.telemetry`) and telecommands (:mod:`fsw.core.commands`).

The names below are imported on first use (PEP 562): the core pulls in the filter bank and its
compiled kernels (~0.7 s), and the ground tools that only read :mod:`fsw.core.counters` (the run
summary, written by ``navbank run`` once its processes have ended) must not pay for them.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from fsw.core.commands import CommandRejected
    from fsw.core.fswcore import FswCore
    from fsw.core.telemetry import AnomalyReporter, DeclarationClock, Emit, FswMessage, stamp

#: name -> the submodule that defines it
_LAZY = {"CommandRejected": "commands", "FswCore": "fswcore", "AnomalyReporter": "telemetry",
         "DeclarationClock": "telemetry", "Emit": "telemetry", "FswMessage": "telemetry", "stamp": "telemetry"}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        # also how ``from fsw.core import checkpoint`` finds that it must import the submodule
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


__all__ = ["AnomalyReporter", "CommandRejected", "DeclarationClock", "Emit", "FswCore", "FswMessage", "stamp"]
