"""Hierarchical gating in run reports: both weight levels recovered from FilterWeights messages,
their bank membership (given, from config.yaml or the MCAP attachment, or inferred), the figure
and the before/after table of ``navbank report``.

The messages are built from known top-level and in-bank weights (softmax of random logits), so
the recovered g_j|i are checked against the numbers they were made from, not against a second
division done the same way.
"""

from __future__ import annotations

import argparse
import math
import random
import struct

import numpy as np
import pytest

from fsw.interface import messages as m, topics
from ground.report.run_data import extract, hierarchical_history, hierarchy_groups_from_config, hierarchy_means

T0 = 600_000_000.0
DAY = 86400.0
S = m.Stamp(sec=1_700_000_000, nsec=0)
GROUPS = {"bank1": ("kf1_1", "kf2_1"), "bank2": ("kf1_2", "kf2_2", "kf3_2"), "bank3": ("kf1_3",)}
# bank order differs from the published filter order, so membership cannot come from positions
FILTERS = ("kf2_2", "kf1_1", "kf1_3", "kf3_2", "kf2_1", "kf1_2")
N_UPDATES = 40
ONSET_K = 25  # the fault starts at the epoch of update 25


def _softmax(x: np.ndarray) -> np.ndarray:
    e = np.exp(x - x.max())
    return e / e.sum()


def _levels(n: int = N_UPDATES, seed: int = 3) -> tuple[np.ndarray, list[dict[str, float]]]:
    """Top-level weights (n, 3) and in-bank weights per update, made independently."""
    rng = np.random.default_rng(seed)
    top = np.array([_softmax(rng.normal(size=len(GROUPS))) for _ in range(n)])
    cond = []
    for _ in range(n):
        c: dict[str, float] = {}
        for members in GROUPS.values():
            c.update(zip(members, _softmax(rng.normal(size=len(members)))))
        cond.append(c)
    return top, cond


def _epoch(k: int) -> float:
    return T0 + 3600.0 * (k + 1)


def _weights_messages(top: np.ndarray, cond: list[dict[str, float]], network: str = "hierarchical") -> list[m.FilterWeights]:
    banks = list(GROUPS)
    bank_of = {f: banks.index(b) for b, fs in GROUPS.items() for f in fs}
    return [m.FilterWeights(t_s=_epoch(k), timestamp=S, network=network, batch=k, filters=FILTERS,
                            weights=tuple(float(top[k, bank_of[f]] * cond[k][f]) for f in FILTERS),
                            groups={b: float(top[k, i]) for i, b in enumerate(banks)})
            for k in range(len(top))]


def _messages(top, cond) -> list[tuple[str, object]]:
    msgs: list[tuple[str, object]] = [
        (topics.SIM_STATUS, m.RunStatus(t_s=T0, timestamp=S, run_id="hier", source="sim", state="start")),
        (topics.SIM_FAULTS, m.FaultEvent(t_s=_epoch(ONSET_K), timestamp=S, fault_id="f0", fault_type="nga-level",
                                         event="start", fault_class="dynamics", magnitude={"sigma": 7e-12})),
    ]
    msgs += [(f"/{topics.FSW_WEIGHTS}/hierarchical", w) for w in _weights_messages(top, cond)]
    msgs += [(f"{topics.FSW_WEIGHTS}/chi2", m.FilterWeights(t_s=_epoch(k), timestamp=S, network="chi2", batch=k,
                                                             filters=FILTERS, weights=(1 / 6,) * 6)) for k in range(5)]
    random.Random(11).shuffle(msgs)  # receive order, not epoch order
    return msgs


# --- hierarchical_history ---------------------------------------------------------------------

def test_history_recovers_both_levels_from_shuffled_messages():
    top, cond = _levels()
    h = hierarchical_history(_messages(top, cond), GROUPS)  # the chi2 network carries no banks: ignored
    assert h.network == "hierarchical" and h.groups_from == "given"
    assert h.banks == ("bank1", "bank2", "bank3")
    assert h.t_s == pytest.approx([_epoch(k) for k in range(N_UPDATES)])
    assert h.top.shape == (N_UPDATES, 3) and h.top == pytest.approx(top, rel=1e-12)
    assert h.members == GROUPS
    for b, members in GROUPS.items():
        want = [[cond[k][f] for f in members] for k in range(N_UPDATES)]
        assert h.in_bank[b].shape == (N_UPDATES, len(members))
        assert h.in_bank[b] == pytest.approx(np.array(want), rel=1e-9)
    assert h.in_bank["bank3"] == pytest.approx(np.ones((N_UPDATES, 1)))  # a one-filter bank is always 1


def test_history_infers_the_banks_without_a_configuration():
    top, cond = _levels()
    h = hierarchical_history(_weights_messages(top, cond))  # bare messages work too
    assert h.groups_from == "inferred"
    assert {b: set(fs) for b, fs in h.members.items()} == {b: set(fs) for b, fs in GROUPS.items()}
    assert h.members["bank2"] == ("kf2_2", "kf3_2", "kf1_2")  # in the published filter order
    assert h.in_bank["bank2"][:, 0] == pytest.approx([c["kf2_2"] for c in cond], rel=1e-9)


def test_history_leaves_the_banks_unknown_when_the_weights_do_not_fix_them():
    top, cond = _levels(n=4)  # 4 updates cannot separate 6 filters
    h = hierarchical_history(_weights_messages(top, cond))
    assert h.groups_from == "unknown" and h.in_bank == {} and h.members == {}
    assert h.top == pytest.approx(top)


def test_history_rejects_banks_that_do_not_describe_the_weights():
    top, cond = _levels()
    msgs = _weights_messages(top, cond)
    swapped = {"bank1": ("kf1_1", "kf1_2"), "bank2": ("kf2_1", "kf2_2", "kf3_2"), "bank3": ("kf1_3",)}
    with pytest.raises(ValueError, match="do not reproduce"):
        hierarchical_history(msgs, swapped)
    with pytest.raises(ValueError, match="do not match"):
        hierarchical_history(msgs, {"bank1": GROUPS["bank1"]})
    with pytest.raises(ValueError, match="never appear"):
        hierarchical_history(msgs, {**GROUPS, "bank3": ("kf1_3", "kf9_9")})
    with pytest.raises(ValueError, match="no hierarchical"):
        hierarchical_history([(f"{topics.FSW_WEIGHTS}/chi2", msgs[0].__class__(
            t_s=T0, timestamp=S, network="chi2", batch=0, filters=("a",), weights=(1.0,)))])
    two = msgs + _weights_messages(top, cond, network="other")
    with pytest.raises(ValueError, match="several"):
        hierarchical_history(two)
    assert hierarchical_history(two, GROUPS, network="other").network == "other"


def test_history_bank_with_zero_weight_gives_nan_in_bank_weights():
    top, cond = _levels(n=8)
    top[3] = (0.0, 0.7, 0.3)
    h = hierarchical_history(_weights_messages(top, cond), GROUPS)
    assert np.all(np.isnan(h.in_bank["bank1"][3]))
    assert h.in_bank["bank2"][3] == pytest.approx([cond[3][f] for f in GROUPS["bank2"]])


def test_means_before_and_after_the_onset():
    top, cond = _levels()
    h = hierarchical_history(_messages(top, cond), GROUPS)
    mean = hierarchy_means(h, _epoch(ONSET_K))
    assert mean["updates"] == {"all": N_UPDATES, "before": ONSET_K, "after": N_UPDATES - ONSET_K}
    for i, b in enumerate(GROUPS):
        assert mean["top_before"][b] == pytest.approx(sum(top[:ONSET_K, i]) / ONSET_K)
        assert mean["top_after"][b] == pytest.approx(sum(top[ONSET_K:, i]) / (N_UPDATES - ONSET_K))
    assert mean["in_bank_after"]["bank2"]["kf3_2"] == pytest.approx(
        sum(c["kf3_2"] for c in cond[ONSET_K:]) / (N_UPDATES - ONSET_K))
    assert set(hierarchy_means(h, None)) == {"split_s", "updates", "top_all", "in_bank_all"}


def test_groups_from_config_text():
    text = """
name: x
fsw:
  gating:
  - network: chi2
  - network: hierarchical
    eta_top: 1.0
    groups:
      bank1: [kf1_1, kf2_1]
      bank2: [kf1_2, kf2_2, kf3_2]
      bank3: [kf1_3]
"""
    assert hierarchy_groups_from_config(text) == {"hierarchical": GROUPS}
    for bad in ("fsw: [1, 2", "just text", "fsw:\n  gating:\n  - network: hierarchical\n    groups: {b: 3}", ""):
        assert hierarchy_groups_from_config(bad) == {}


def test_extract_keeps_weights_and_sets_aside_a_stale_configuration():
    top, cond = _levels()
    stale = {"hierarchical": {"bank1": ("kf1_1",), "bank2": ("kf2_1", "kf1_2", "kf2_2", "kf3_2"), "bank3": ("kf1_3",)}}
    data = extract(_messages(top, cond), groups=stale)
    assert set(data.weights) == {"chi2", "hierarchical"} and set(data.hierarchy) == {"hierarchical"}
    assert data.hierarchy["hierarchical"].groups_from == "inferred"
    assert set(data.hierarchy["hierarchical"].members["bank2"]) == set(GROUPS["bank2"])


def test_figure_draws_the_in_bank_weights():
    pytest.importorskip("matplotlib")
    from ground.report.run_plots import plot_hierarchy

    top, cond = _levels()
    data = extract(_messages(top, cond), groups={"hierarchical": GROUPS})
    fig = plot_hierarchy(data, "hierarchical")
    assert len(fig.axes) == 1 + len(GROUPS)
    lines = {ln.get_label(): ln for ln in fig.axes[0].lines}
    assert np.asarray(lines["bank2"].get_ydata(), float) == pytest.approx(top[:, 1])
    assert np.asarray(lines["bank2"].get_xdata(), float) == pytest.approx([(k + 1) / 24.0 for k in range(N_UPDATES)])
    assert "fault onset day 1.08 (nga-level)" in lines
    bank2 = {ln.get_label(): ln for ln in fig.axes[2].lines}
    assert np.asarray(bank2["kf3_2"].get_ydata(), float) == pytest.approx([c["kf3_2"] for c in cond])
    onsets = [ln for ln in fig.axes[2].lines if np.allclose(ln.get_xdata(), (ONSET_K + 1) / 24.0)]
    assert onsets, "every panel marks the fault onset"


# --- navbank report on a recorded run ----------------------------------------------------------

CONFIG = """name: tiny-hierarchy
fsw:
  gating:
  - network: hierarchical
    groups:
      bank1: [kf1_1, kf2_1]
      bank2: [kf1_2, kf2_2, kf3_2]
      bank3: [kf1_3]
  - network: chi2
"""


def _record(path, msgs, attach: bool = False) -> None:
    from ground.mcap_io import McapRecorder

    with McapRecorder(path) as rec:
        for i, (topic, msg) in enumerate(msgs):
            rec.write_message(topic, msg, 1_700_000_000_000_000_000 + 1000 * i)
        if attach:
            rec.add_attachment("config.yaml", CONFIG.encode(), "application/yaml")


def _report(argv: list[str]) -> int:
    from tools.commands import report as cmd

    p = argparse.ArgumentParser()
    cmd.add_arguments(p)
    return cmd.run(p.parse_args(argv))


def _png_height(path) -> int:
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", data[16:24])[1]


@pytest.mark.parametrize("config_from", ["run directory", "attachment"])
def test_navbank_report_on_a_recorded_hierarchical_run(tmp_path, capsys, config_from):
    pytest.importorskip("matplotlib")
    top, cond = _levels()
    run = tmp_path / "run"
    run.mkdir()
    _record(run / "run.mcap", _messages(top, cond), attach=config_from == "attachment")
    if config_from == "run directory":
        (run / "config.yaml").write_text(CONFIG)
    assert _report([str(run)]) == 0
    printed = capsys.readouterr().out.split()
    fig = run / "report" / "hierarchy_hierarchical.png"
    assert str(fig) in printed and str(run / "report" / "weights_hierarchical.png") in printed
    assert not (run / "report" / "hierarchy_chi2.png").exists()
    assert fig.stat().st_size > 10_000 and _png_height(fig) > 600  # four panels
    md = (run / "report" / "report.md").read_text()
    assert "## Hierarchical gating 'hierarchical': mean bank weights" in md
    assert "Banks: the run's configuration." in md
    assert f"{ONSET_K} weight updates before the first fault onset (day 1.08) and the {N_UPDATES - ONSET_K} from it on" in md
    row = next(line for line in md.splitlines() if line.startswith("| bank2 |"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[1] == "kf1_2, kf2_2, kf3_2"
    assert float(cells[2]) == pytest.approx(np.mean(top[:ONSET_K, 1]), abs=5e-4)
    assert float(cells[3]) == pytest.approx(np.mean(top[ONSET_K:, 1]), abs=5e-4)
    kf3 = float(cells[5].split("kf3_2 ")[1])
    assert kf3 == pytest.approx(np.mean([c["kf3_2"] for c in cond[ONSET_K:]]), abs=5e-3)
    assert "](hierarchy_hierarchical.png)" in md


def test_navbank_report_without_configuration_shows_the_top_level(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    top, cond = _levels(n=4)  # too few updates to infer the banks
    run = tmp_path / "run"
    run.mkdir()
    _record(run / "run.mcap", _messages(top, cond))
    assert _report([str(run)]) == 0
    assert (run / "report" / "hierarchy_hierarchical.png").is_file()
    md = (run / "report" / "report.md").read_text()
    assert "Banks: unknown" in md
    row = next(line for line in md.splitlines() if line.startswith("| bank1 |"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[1] == "–" and math.isclose(float(cells[2]), float(np.mean(top[:, 0])), abs_tol=5e-4)
