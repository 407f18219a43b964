"""The flight software's core (see :mod:`fsw.core.fswcore`): intake, the stage pipeline, ICD
telemetry (:mod:`fsw.core.telemetry`) and telecommands (:mod:`fsw.core.commands`)."""

from fsw.core.commands import CommandRejected
from fsw.core.fswcore import FswCore
from fsw.core.telemetry import AnomalyReporter, DeclarationClock, Emit, FswMessage, stamp

__all__ = ["AnomalyReporter", "CommandRejected", "DeclarationClock", "Emit", "FswCore", "FswMessage", "stamp"]
