"""Commands are part of the record: a commanded run re-runs IDENTICAL.

A one-day run flown through the FSW core with telecommands served mid-stream (a parameter
change, a filter disabled and enabled again, a reset, a status query, a malformed payload) is
written to an MCAP file the way the ground logger writes one, then `navbank replay --rerun`'s
code re-flies it: every /fsw message, the command records included, must come out identical;
without the recorded commands the re-run must differ.
"""

from __future__ import annotations

import json

from fsw.core import FswCore
from fsw.interface import codec, messages as m, topics
from ground.mcap_io.recorder import McapRecorder
from ground.replay.regression import rerun_and_compare
from ground.replay.rerun import recorded_commands, recorded_measurement_stream, rerun_fsw
from ground.report.run_summary import summarize
from sim.stream import generate
from tools.scenario import load_text_scenario, resolve, to_yaml
from tools.summary import describe

SCENARIO = """\
name: commanded
seed: 3
sim:
  trajectory: {span_days: 1.0}
fsw:
  budget: {mode: work-units}
  gating:
    - {network: chi2, batch_size: 100}
    - {network: magill}
"""

COMMANDS = {  # served before the measurement of this index (the run has ~600)
    100: m.Telecommand(id="p", command="set-param", network="chi2", param="sigma_w", value=0.1),
    200: m.Telecommand(id="d", command="disable-filter", filter="optical"),
    250: m.Telecommand(id="bad", command="set-param", network="chi2", param="sigma_w", value=-1.0),
    300: m.Telecommand(id="r", command="reset-gating", network="all"),
    350: m.Telecommand(id="s", command="status"),
    450: m.Telecommand(id="e", command="enable-filter", filter="optical"),
}
MALFORMED_AT = 400


def _commanded_run(tmp_path):
    cfg, seed = resolve(load_text_scenario(SCENARIO))
    sim = generate(cfg.sim, seed=seed)
    out: list[tuple[str, object]] = []
    core = FswCore(cfg.fsw, lambda topic, msg: out.append((topic, msg)), run_id="commanded")
    core.start()
    for i, meas in enumerate(sim.measurements):
        if i in COMMANDS:
            core.command(COMMANDS[i])
        if i == MALFORMED_AT:
            core.command_payload(b'{"id": "x", "command": "self-destruct"}')
        out.append((topics.SIM_MEASUREMENTS, meas))
        core.ingest(meas)
    core.finish()
    path = tmp_path / "run.mcap"
    seqs: dict[str, int] = {}
    with McapRecorder(path) as rec:
        rec.add_attachment("config.yaml", to_yaml(cfg).encode(), "application/yaml")
        rec.add_metadata("navbank.run", {"run_id": "commanded"})
        for k, (topic, msg) in enumerate(out):
            seqs[topic] = seqs.get(topic, -1) + 1
            rec.write(topic, codec.to_json(msg), 1_700_000_000_000_000_000 + k, None, seqs[topic])
    return cfg, sim, out, path


def test_a_commanded_run_reruns_identical_and_only_with_its_commands(tmp_path):
    cfg, sim, out, path = _commanded_run(tmp_path)
    records = [msg for t, msg in out if t == topics.FSW_COMMANDS]
    assert [r.reply.id for r in records] == ["p", "d", "bad", "r", "s", "", "e"]
    assert [r.reply.ok for r in records] == [True, True, False, True, True, False, True]
    assert records[5].telecommand is None and json.loads(records[5].payload)["command"] == "self-destruct"
    assert [r.taken for r in records] == [100, 200, 250, 300, 350, 400, 450]

    result = rerun_and_compare(path)
    assert result.identical, result.comparison.to_dict()
    assert result.comparison.topics["/fsw/commands"].recorded == 7

    # the commands matter: without them the same measurements give other weights
    stream, _ = recorded_measurement_stream(path)
    assert len(recorded_commands(path)) == 7
    bare = rerun_fsw(cfg.fsw, stream)
    weights = [codec.to_json(msg) for t, msg in out if t == "fsw/weights/chi2"]
    assert [codec.to_json(msg) for t, msg in bare.outputs if t == "fsw/weights/chi2"] != weights


def test_the_summary_lists_the_commands(tmp_path):
    cfg, sim, out, _ = _commanded_run(tmp_path)
    s = summarize(out, scenario=cfg.name, seed=cfg.seed, fault=None, t0=sim.t_start)
    assert s.commands is not None and [c.command for c in s.commands] == [
        "set-param", "disable-filter", "set-param", "reset-gating", "status", "malformed", "enable-filter"]
    assert s.commands[0].param == "sigma_w" and s.commands[0].value == 0.1 and s.commands[2].ok is False
    assert "commands" in s.to_json() and json.loads(json.dumps(s.to_json()))["commands"][1]["filter"] == "optical"
    text = describe(s)
    assert "telecommands: 7 served, 4 changed the FSW, 2 refused" in text
    assert "disable-filter filter optical" in text


def test_an_uncommanded_summary_has_no_commands_key(tmp_path):
    cfg, sim = resolve(load_text_scenario(SCENARIO))[0], None
    run = generate(cfg.sim, seed=cfg.seed)
    out: list[tuple[str, object]] = []
    core = FswCore(cfg.fsw, lambda topic, msg: out.append((topic, msg)))
    for meas in run.measurements[:200]:
        core.ingest(meas)
    core.finish()
    s = summarize(out, scenario=cfg.name, seed=cfg.seed, fault=None, t0=run.t_start)
    assert s.commands is None and "commands" not in s.to_json()
