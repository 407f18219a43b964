"""Telecommands to the FSW core: each is validated completely before anything changes."""

from __future__ import annotations

import copy
import dataclasses
import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fsw.core import FswCore
from fsw.core.commands import COMMANDS
from fsw.interface import messages as m, topics
from tools.scenario import load_scenario, load_text_scenario, resolve

SCENARIO = """\
name: commands
sim:
  trajectory: {span_days: 1.0}
fsw:
  gating:
    - {network: chi2, batch_size: 100}
    - {network: magill}
    - {network: chi2-two-sided}
"""


def _core(text: str = SCENARIO, detector: bool = False) -> tuple[FswCore, list[tuple[str, object]]]:
    cfg, _ = resolve(load_text_scenario(text), 1)
    fsw = cfg.fsw
    if detector:
        cal = load_scenario("insight-approach").fsw.detector.calibration
        fsw = dataclasses.replace(fsw, detector=dataclasses.replace(fsw.detector, network="chi2", calibration=cal))
    out: list[tuple[str, object]] = []
    return FswCore(fsw, lambda topic, msg: out.append((topic, msg))), out


def _states(core: FswCore) -> dict[str, dict]:
    return {name: copy.deepcopy(net.state_dict()) for name, net in core.networks.items()}


def _tc(command: str, **fields) -> m.Telecommand:
    return m.Telecommand(id=command, command=command, **fields)  # type: ignore[arg-type]


def test_the_table_has_one_entry_per_icd_telecommand():
    assert set(COMMANDS) == set(m.TELECOMMANDS)


def test_a_rejected_set_param_on_one_network_changes_nothing():
    core, _ = _core()
    before = _states(core)
    # 1e-200 passes the declared range (> 0) but its square underflows: W̄ = σ_W² I is singular
    for value in (1e-200, -1.0, float("nan")):
        reply = core.command(_tc("set-param", network="chi2", param="sigma_w", value=value))
        assert not reply.ok and reply.error
    assert core.networks["chi2"].params.sigma_w == 0.05
    assert _states(core) == before
    assert core.counters.commands_rejected == 3 and core.counters.commands_ok == 0


@pytest.mark.parametrize("param, value, valid_for", [
    ("batch_size", 50.0, "chi2"),  # chi2 (first) has it, magill does not
    ("lower_bound", 0.01, "magill"),  # magill has it, both chi-square networks do not
])
def test_a_set_param_for_all_networks_changes_none_unless_all_accept_it(param, value, valid_for):
    core, _ = _core()
    # the value alone is acceptable to the network that has the parameter ...
    core.networks[valid_for].validate_param(param, value)
    before = _states(core)
    # ... but not to every network addressed
    for network in ("all", "*", ""):
        reply = core.command(_tc("set-param", network=network, param=param, value=value))
        assert not reply.ok
    assert _states(core) == before


def test_an_accepted_set_param_for_all_networks_changes_every_one():
    core, _ = _core(SCENARIO.replace("    - {network: magill}\n", ""))
    reply = core.command(_tc("set-param", network="all", param="sigma_w", value=0.1))
    assert reply.ok, reply.error
    assert reply.status == {"sigma_w": 0.1} and reply.detail == {"network": "all"}
    assert {n: net.params.sigma_w for n, net in core.networks.items()} == {"chi2": 0.1, "chi2-two-sided": 0.1}


def test_validate_param_leaves_the_network_alone():
    core, _ = _core()
    net = core.networks["chi2"]
    before = copy.deepcopy(net.state_dict())
    params = net.validate_param("batch_size", 7)
    assert params.batch_size == 7 and net.params.batch_size == 100
    assert net.state_dict() == before
    net.install_params(params)
    assert net.params.batch_size == 7


def test_unknown_commands_networks_and_filters_are_rejected_and_counted():
    core, _ = _core()
    before = _states(core)
    active = core.bank.active.copy()
    replies = [
        core.command(_tc("self-destruct")),
        core.command(_tc("reset-gating", network="nope")),
        core.command(_tc("set-param", network="nope", param="sigma_w", value=0.1)),
        core.command(_tc("set-param", network="chi2", param="no_such_parameter", value=1.0)),
        core.command(_tc("disable-filter", filter="nope")),
        core.command(_tc("enable-filter", filter="nope")),
    ]
    assert [r.ok for r in replies] == [False] * 6
    assert "unknown command" in replies[0].error and "nope" in replies[1].error
    assert core.counters.commands_rejected == 6 and core.counters.commands_ok == 0
    assert _states(core) == before and (core.bank.active == active).all()
    malformed = core.command_payload(b'{"id": "x", "command": "set-param"}')
    assert not malformed.ok and malformed.error.startswith("malformed telecommand")
    assert core.counters.commands_rejected == 6 and core.counters.commands_malformed == 1


def test_filters_are_disabled_and_enabled_but_never_the_last_one():
    core, _ = _core()
    first, second, third = core.filters
    assert core.command(_tc("disable-filter", filter=first)).detail == {first: "disabled"}
    assert core.command(_tc("disable-filter", filter=second)).ok
    last = core.command(_tc("disable-filter", filter=third))
    assert not last.ok and "last enabled" in last.error
    assert list(core.bank.active) == [False, False, True]
    assert core.command(_tc("disable-filter", filter=first)).ok  # already disabled: not the last one
    assert core.command(_tc("enable-filter", filter=first)).detail == {first: "enabled"}
    assert list(core.bank.active) == [True, False, True]
    assert core.counters.commands_ok == 4 and core.counters.commands_rejected == 1


def test_status_reports_counters_filters_networks_and_the_detector():
    core, _ = _core(detector=True)
    reply = core.command(_tc("status"))
    assert reply.ok
    assert reply.status["processed"] == 0.0 and reply.status["t_s"] == core.t0
    assert reply.detail == {"filters": ",".join(core.filters), "enabled": ",".join(core.filters),
                            "networks": "chi2,magill,chi2-two-sided", "anomaly": "none"}
    # the status command itself is counted once it is done
    assert core.command(_tc("status")).status["commands_ok"] == 1.0


def test_reset_gating_restarts_the_detector_only_with_its_network():
    core, out = _core(detector=True)
    assert core.command(_tc("reset-gating", network="magill")).detail == {"reset": "magill"}
    assert not [t for t, _ in out if t == topics.FSW_ANOMALY]
    for network in ("chi2", "all"):
        assert core.command(_tc("reset-gating", network=network)).ok
    reports = [msg for t, msg in out if t == topics.FSW_ANOMALY]
    assert len(reports) == 2 and all(isinstance(r, m.AnomalyReport) and not r.flag for r in reports)
    assert reports[0].t_s == core.t0  # no batch yet: dated by the newest epoch the core knows


_FIELDS = {
    "id": st.text(max_size=8),
    "command": st.sampled_from([*m.TELECOMMANDS, "self-destruct", ""]),
    "network": st.one_of(st.none(), st.sampled_from(["chi2", "magill", "chi2-two-sided", "all", "*", "nope", ""])),
    "filter": st.one_of(st.none(), st.sampled_from(["radio", "optical", "fused", "nope"])),
    "param": st.one_of(st.none(), st.sampled_from(["sigma_w", "batch_size", "lower_bound", "memory_matrix", "x"])),
    "value": st.one_of(st.none(), st.floats(allow_nan=False, allow_infinity=False), st.integers(-10**6, 10**6),
                       st.text(max_size=4)),
}


@settings(max_examples=200, deadline=None)
@given(st.lists(st.one_of(st.fixed_dictionaries({}, optional=_FIELDS).map(lambda d: json.dumps(d).encode()),
                          st.binary(max_size=40)), max_size=12))
def test_any_telecommand_sequence_is_answered_counted_and_never_raises(payloads):
    """Whatever arrives on the command queryable: a reply for each, every one counted exactly
    once, the bank always left with an enabled filter, and every network's weights a
    distribution (a network learns of a disabled filter with the next bank record)."""
    core, _ = _core()
    for payload in payloads:
        reply = core.command_payload(payload)
        assert isinstance(reply, m.TelecommandReply) and (reply.ok or reply.error)
    c = core.counters
    assert c.commands_ok + c.commands_rejected + c.commands_malformed == len(payloads)
    assert core.bank.active.any()
    for net in core.networks.values():
        w = np.asarray(net.weights)
        assert np.all(w >= 0.0) and abs(w.sum() - 1.0) < 1e-9
