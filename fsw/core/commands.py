"""Telecommands: one table entry per command, validated completely before anything changes.

Each entry of :data:`COMMANDS` is a validator: it checks a telecommand against the running FSW
and returns a plan, or raises; only then is the plan applied. So a command the FSW cannot carry
out — an unknown filter or network, the last enabled filter, a parameter value one of the
addressed networks refuses — changes nothing, however many networks it addresses. Every command
is counted as carried out or rejected.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable, Protocol

from fsw.filters.errors import UnknownFilter
from fsw.gating.base import GatingError, GatingNetwork
from fsw.interface import messages as m

if TYPE_CHECKING:
    from fsw.core.fswcore import FswCore

#: What a command returns: numeric status and textual detail of the reply.
Reply = tuple[dict[str, float], dict[str, str]]

#: Network names that address every running gating network.
ALL_NETWORKS = (None, "", "*", "all")


class CommandRejected(ValueError):
    """A telecommand that is well-formed but cannot be carried out (unknown filter, bad value)."""


class Plan(Protocol):
    """A validated telecommand, ready to be carried out."""

    def apply(self, core: FswCore) -> Reply: ...


def _addressed(core: FswCore, name: str | None) -> tuple[str, ...]:
    if name in ALL_NETWORKS:
        return tuple(core.networks)
    if name not in core.networks:
        raise CommandRejected(f"unknown gating network {name!r}; running: {', '.join(core.networks)}")
    return (name,)


# -- status ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Status:
    def apply(self, core: FswCore) -> Reply:
        counts = {k: float(v) for k, v in core.status_counts().items()}
        counts["t_s"] = float(core.t_last)
        for name, upd in core.latest.items():
            for f, w in zip(upd.filters, upd.weights):
                counts[f"weight.{name}.{f}"] = float(w)
        detail = {
            "filters": ",".join(core.filters),
            "enabled": ",".join(f for f, a in zip(core.filters, core.bank.active) if a),
            "networks": ",".join(core.networks),
        }
        if core.reporter is not None:
            st = core.reporter.state
            detail["anomaly"] = f"{st.anomaly_class}" if st.flag else "none"
        return counts, detail


def validate_status(core: FswCore, tc: m.Telecommand) -> Status:
    return Status()


# -- reset-gating ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class ResetGating:
    networks: tuple[str, ...]
    detector: bool  # the detector watches one of them: it restarts too
    label: str

    def apply(self, core: FswCore) -> Reply:
        for name in self.networks:
            core.networks[name].reset()
        if self.detector:
            core.reset_detector()
        return {}, {"reset": self.label}


def validate_reset_gating(core: FswCore, tc: m.Telecommand) -> ResetGating:
    names = _addressed(core, tc.network)
    detector = core.reporter is not None and (tc.network in ALL_NETWORKS or tc.network == core.reporter.network)
    return ResetGating(names, detector, tc.network or "all")


# -- enable-filter / disable-filter ---------------------------------------------------------------
@dataclass(frozen=True)
class SetEnabled:
    filter: str
    enabled: bool

    def apply(self, core: FswCore) -> Reply:
        core.bank.set_enabled(self.filter, self.enabled)
        return {}, {self.filter: "enabled" if self.enabled else "disabled"}


def _known_filter(core: FswCore, tc: m.Telecommand) -> str:
    if tc.filter not in core.filters:
        raise CommandRejected(f"unknown filter {tc.filter!r}; bank: {', '.join(core.filters)}")
    return tc.filter


def validate_enable_filter(core: FswCore, tc: m.Telecommand) -> SetEnabled:
    return SetEnabled(_known_filter(core, tc), True)


def validate_disable_filter(core: FswCore, tc: m.Telecommand) -> SetEnabled:
    name = _known_filter(core, tc)
    if int(core.bank.active.sum()) <= 1 and core.bank.active[core.bank.index(name)]:
        raise CommandRejected("cannot disable the last enabled filter")
    return SetEnabled(name, False)


# -- set-param ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SetParam:
    param: str
    value: float
    installs: tuple[tuple[GatingNetwork, object], ...]  # each network with its validated parameters
    label: str

    def apply(self, core: FswCore) -> Reply:
        for net, params in self.installs:
            net.install_params(params)
        return {self.param: self.value}, {"network": self.label}


def validate_set_param(core: FswCore, tc: m.Telecommand) -> SetParam:
    if tc.param is None or tc.value is None:
        raise CommandRejected("set-param needs a parameter name and a value")
    installs = tuple((core.networks[name], core.networks[name].validate_param(tc.param, tc.value))
                     for name in _addressed(core, tc.network))
    return SetParam(tc.param, float(tc.value), installs, tc.network or "all")


# -- set-rqp --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SetRqp:
    enabled: bool | None
    every: int | None

    def apply(self, core: FswCore) -> Reply:
        core.rqp.set(enabled=self.enabled, every=self.every)
        return {"enabled": float(core.rqp.enabled), "every": float(core.rqp.every)}, {}


def validate_set_rqp(core: FswCore, tc: m.Telecommand) -> SetRqp:
    """RQP adaptation on/off (param 'enabled', value 1 or 0) or its window P (param 'every')."""
    if tc.param == "enabled" and tc.value in (0.0, 1.0):
        return SetRqp(bool(tc.value), None)
    if tc.param == "every" and tc.value is not None and float(tc.value).is_integer() and 2 <= tc.value <= 1000:
        return SetRqp(None, int(tc.value))
    raise CommandRejected("set-rqp takes param 'enabled' with value 1 or 0, or 'every' with an integer 2..1000")


#: The telecommand table: command name -> validator returning the plan to apply.
COMMANDS: dict[str, Callable[[FswCore, m.Telecommand], Plan]] = {
    "status": validate_status,
    "reset-gating": validate_reset_gating,
    "enable-filter": validate_enable_filter,
    "disable-filter": validate_disable_filter,
    "set-param": validate_set_param,
    "set-rqp": validate_set_rqp,
}

#: Everything a validator or a plan raises for a command that cannot be carried out.
REJECTIONS = (CommandRejected, GatingError, UnknownFilter, KeyError, ValueError, TypeError)


def execute(core: FswCore, tc: m.Telecommand) -> m.TelecommandReply:
    """Validate ``tc`` completely, then carry it out; anything that cannot be done is an error
    reply. Both outcomes are counted (``commands_ok``, ``commands_rejected``)."""
    try:
        validator = COMMANDS.get(tc.command)
        if validator is None:
            raise CommandRejected(f"unknown command {tc.command!r}")
        status, detail = validator(core, tc).apply(core)
    except REJECTIONS as exc:
        core.counters.commands_rejected += 1
        return m.TelecommandReply(id=tc.id, ok=False, error=str(exc) or exc.__class__.__name__)
    core.counters.commands_ok += 1
    return m.TelecommandReply(id=tc.id, ok=True, status=status, detail=detail)
