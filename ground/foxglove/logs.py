"""Status, anomaly, fault and telecommand events as ``foxglove.Log`` (the Log panel)."""

from __future__ import annotations

from typing import Any

from foxglove import messages as fm

from ground.foxglove.records import ChannelSchema, FoxgloveRecord, well_known

LOG_TOPIC = "/foxglove/log"
LOG_SCHEMA: ChannelSchema = well_known(fm.Log)


def _ts(ns: int) -> fm.Timestamp:
    return fm.Timestamp(ns // 1_000_000_000, ns % 1_000_000_000)


class LogBuilder:
    """One ``foxglove.Log`` per event worth reading: a process changing state (periodic
    ``running`` statuses are left out), an anomaly declared, re-classified or cleared, a fault
    starting or ending, a telecommand served."""

    def __init__(self) -> None:
        self._anomaly: tuple[Any, ...] | None = None

    def _log(self, log_ns: int, level: Any, name: str, text: str) -> list[FoxgloveRecord]:
        msg = fm.Log(timestamp=_ts(log_ns), level=level, message=text, name=name)
        return [FoxgloveRecord(LOG_TOPIC, LOG_SCHEMA, msg.encode(), log_ns)]

    def status(self, msg: dict[str, Any], log_ns: int) -> list[FoxgloveRecord]:
        state = msg.get("state")
        if state == "running":
            return []
        level = fm.LogLevel.Error if state == "error" else fm.LogLevel.Info
        detail = f": {msg['message']}" if msg.get("message") else ""
        return self._log(log_ns, level, str(msg.get("source", "")), f"{msg.get('source')} {state}{detail}")

    def anomaly(self, msg: dict[str, Any], log_ns: int) -> list[FoxgloveRecord]:
        key = (msg.get("flag"), msg.get("anomaly_class"), msg.get("declared_s"))
        if key == self._anomaly:
            return []
        first = self._anomaly is None
        self._anomaly = key
        if msg.get("flag"):
            text = (f"ANOMALY declared by {msg.get('network')}: {msg.get('anomaly_class')} "
                    f"(confidence {float(msg.get('confidence', 0.0)):.2f}, statistic {float(msg.get('statistic', 0.0)):.3g} "
                    f"> {float(msg.get('threshold', 0.0)):.3g})")
            return self._log(log_ns, fm.LogLevel.Warning, "fsw/fdir", text)
        if first:
            return []
        return self._log(log_ns, fm.LogLevel.Info, "fsw/fdir", f"anomaly cleared ({msg.get('network')})")

    def fault(self, msg: dict[str, Any], log_ns: int) -> list[FoxgloveRecord]:
        mag = ", ".join(f"{k} {v:g}" for k, v in (msg.get("magnitude") or {}).items())
        text = f"fault {msg.get('fault_id')} ({msg.get('fault_type')}) {msg.get('event')}" + (f": {mag}" if mag else "")
        return self._log(log_ns, fm.LogLevel.Warning, "sim/faults", text)

    def command(self, msg: dict[str, Any], log_ns: int) -> list[FoxgloveRecord]:
        tc = msg.get("telecommand") or {}
        reply = msg.get("reply") or {}
        ok = bool(reply.get("ok"))
        text = f"telecommand {tc.get('command', '(malformed)')} {tc.get('id', '')}: " + ("ok" if ok else f"rejected: {reply.get('error', '')}")
        return self._log(log_ns, fm.LogLevel.Info if ok else fm.LogLevel.Warning, "fsw/commands", text)
