"""The scenario and fault reference, ``docs/scenarios.md``, generated from the declarations.

Every key, type, unit, range, default and meaning comes from the ``spec(...)`` of its field;
fault types from :mod:`sim.faults.config`, gating networks from their registry, presets and
built-ins from where they are defined. ``navbank scenarios --reference`` prints it and
``tests/test_scenario_reference.py`` fails when the committed file is stale.
"""

from __future__ import annotations

import dataclasses

from fsw.gating.registry import NETWORKS
from fsw.interface.describe import FieldDoc, describe, flow
from fsw.interface.typed import encode
from sim.faults.config import ALLOWED, FAULT_CLASS, FAULT_TYPES, REQUIRED, FaultConfig
from sim.faults.presets import DEFAULT_ONSET_DAY, FAULT_PRESETS
from tools.campaign.spec import CampaignConfig
from tools.campaign.spec import builtin_names as campaign_names
from tools.campaign.spec import load_campaign
from tools.scenario import ScenarioConfig, builtin_names, load_scenario

REGENERATE = "navbank scenarios --reference > docs/scenarios.md"


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ") if text else ""


def _code(text: str) -> str:
    return f"`{text}`" if text else ""


def _table(rows: list[FieldDoc]) -> list[str]:
    out = ["| key | type | unit | range | default | meaning |", "|---|---|---|---|---|---|"]
    for r in rows:
        out.append(f"| {_code(r.path)} | {_cell(r.type)} | {_cell(r.unit)} | {_cell(r.range)} | "
                   f"{_cell(_code(r.default) if not r.default.startswith('(') else r.default)} | {_cell(r.doc)} |")
    return out


def _first_line(doc: str | None) -> str:
    return " ".join((doc or "").strip().split("\n\n")[0].split())


def _fault_field(name: str) -> str:
    f = {f.name: f for f in dataclasses.fields(FaultConfig)}[name]
    unit = f.metadata.get("unit")
    return f"`{name}` [{unit}]" if unit and unit != "1" else f"`{name}`"


def _faults_section() -> list[str]:
    out = ["## Faults", "",
           "A fault is one entry of `sim.faults` (keys `sim.faults[].…` above): its `type`, `onset_day`, optional "
           "`end_day` and `id`, and exactly the magnitude fields its type takes; a field of another type is "
           "refused (it is almost always a typo). The anomaly class is what a perfect diagnosis would report.", "",
           "| type | takes | anomaly class |", "|---|---|---|"]
    for t in FAULT_TYPES:
        required = REQUIRED[t]
        allowed = ALLOWED[t]
        if required:
            takes = ", ".join(_fault_field(n) for n in required) + " (all required)"
        else:
            takes = " and/or ".join(_fault_field(n) for n in allowed) + " (at least one)"
        out.append(f"| `{t}` | {takes} | {FAULT_CLASS[t]} |")
    out += ["", "### Fault presets", "",
            f"`navbank run --fault NAME` replaces the scenario's faults by a preset; each starts on day "
            f"{DEFAULT_ONSET_DAY:g} unless `--onset-day` is given, and lasts to the end of the run.", "",
            "| preset | what | faults |", "|---|---|---|"]
    for name, (desc, faults) in FAULT_PRESETS.items():
        text = "; ".join(flow(encode(f, drop_defaults=True)) for f in faults) or "none"
        out.append(f"| `{name}` | {_cell(desc)} | {_cell(_code(text) if faults else text)} |")
    return out


def _gating_section() -> list[str]:
    out = ["## Gating networks", "",
           "Each entry of `fsw.gating` is `{network: NAME, <parameters>…}`; the parameters not given keep "
           "the defaults below. The same parameters are what the `set-param` telecommand changes.", ""]
    for name, cls in NETWORKS.items():
        out += [f"### `{name}`", "", _first_line(cls.__doc__), ""]
        rows = describe(cls.params_type)
        out += _table(rows) if rows else ["No parameters."]
        out.append("")
    return out


def _builtins_section() -> list[str]:
    out = ["## Built-in scenarios", "",
           "`navbank scenarios --show NAME` prints one in full, with a comment on every key.", "",
           "| scenario | trajectory | days | filters | gating networks | faults | description |",
           "|---|---|---|---|---|---|---|"]
    for name in builtin_names():
        cfg = load_scenario(name)
        filters = ", ".join(f.name for f in cfg.fsw.bank.filters)
        gating = ", ".join(g.network for g in cfg.fsw.gating)
        faults = ", ".join(f"{f.type} from day {f.onset_day:g}" for f in cfg.sim.faults) or "none"
        out.append(f"| `{name}` | {cfg.sim.trajectory_kind} | {cfg.sim.span_days:.3g} | {_cell(filters)} | "
                   f"{_cell(gating)} | {_cell(faults)} | {_cell(cfg.description)} |")
    out += ["", "## Built-in campaigns", "", "`navbank campaign NAME` runs one.", "",
            "| campaign | description |", "|---|---|"]
    for name in campaign_names():
        out.append(f"| `{name}` | {_cell(load_campaign(name).config.description)} |")
    return out


def reference_markdown() -> str:
    """The text of ``docs/scenarios.md``."""
    out = ["# Scenario and fault reference", "",
           f"Generated from the declarations by `{REGENERATE}`; do not edit by hand "
           "(`tests/test_scenario_reference.py` fails when this file is stale).", "",
           "A scenario file is YAML: a name, a description, the default seed, `sim:` (truth, sensors, faults) and "
           "`fsw:` (bank, gating networks, detector, budget). Every key is optional unless its default says "
           "`(required)`; a key not given keeps its default, and `(section)` means the key holds the keys listed "
           "after it. `x[]` is each entry of the list `x`. A bad file gives one line `FILE:LINE: key.path: "
           "expected …, got …` and exit code 2. The defaults of `fsw.bank` are the nominal three-filter bank "
           "(radio, optical, fused) of Lubey & Ely 2022 Table 1.", "",
           "Contents: [scenario keys](#scenario-keys), [gating networks](#gating-networks), [faults](#faults), "
           "[built-in scenarios](#built-in-scenarios), [campaign keys](#campaign-keys).", "",
           "## Scenario keys", ""]
    out += _table(describe(ScenarioConfig))
    out.append("")
    out += _gating_section()
    out += _faults_section()
    out.append("")
    out += _builtins_section()
    out += ["", "## Campaign keys", "",
            "A campaign file (`navbank campaign FILE`) crosses scenarios, fault cases and gating-network variants "
            "over a set of seeds. A fault case may be a preset name, a network variant a network name.", ""]
    out += _table(describe(CampaignConfig))
    return "\n".join(out) + "\n"
