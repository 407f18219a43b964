"""The campaign file: a matrix of scenarios x fault cases x gating-network variants x seeds.

A campaign file (YAML) is validated like a scenario file, so a mistake is one line
``FILE:LINE: key.path: expected …, got …`` and exit code 2::

    name: optical-bias
    description: the three optical-bias presets and a nominal case
    seeds: {count: 3, base: 1}          # seeds base .. base+count-1 in every cell
    onset_day: 20.0                     # onset of every preset case that gives none of its own
    overrides:                          # applied to every run (dotted or nested scenario keys)
      sim.trajectory.span_days: 45.0
      fsw.budget: {mode: work-units}
    matrix:                             # one or more blocks; each is a full cross product
      - scenarios: [insight-approach]   # built-in names or paths (relative to this file)
        faults:                         # preset names, or custom cases
          - none
          - optical-bias-small
          - {preset: optical-bias-large, onset_day: 10.0}
          - name: range-100m
            faults: [{type: range-bias, onset_day: 15.0, range_m: 100.0}]
        networks:                       # gating-network variants (default: the scenario's own)
          - default
          - chi2                        # detector on chi2 (added to the gating list if absent)
          - name: chi2-sw0.1
            detector: chi2
            params: {chi2: {sigma_w: 0.1}}
            calibration: detector-chi2.yaml   # a `navbank calibrate --out` file
          - name: three-networks        # one run, three detectors: chi2 onboard, two replayed
            detector: chi2
            calibration: detector-chi2.yaml
            monitors: {magill: detector-magill.yaml, chi2-two-sided: detector-chi2-two-sided.yaml}

A monitor is a second (third, ...) anomaly detector on the same run: every gating network reads
the same bank records and a detector is a pure function of its network's weight stream, so the
statistics of several detectors come from one set of runs (each counts as its own detector
variant, labelled ``<variant> / <network>``).

Blocks exist because some fault cases only make sense with some banks (Lubey & Ely 2022 Table 4 pairs
each dynamics fault with its own six-filter bank).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any, Literal

from fsw.config import GatingEntry
from fsw.interface import typed
from fsw.interface.typed import spec
from fsw.interface.yamlconfig import ConfigError, load_data, parse_yaml, read_config_text
from sim.faults.config import FaultConfig
from sim.faults.presets import FAULT_PRESETS


@dataclass(frozen=True)
class FaultCase:
    """One row of the fault axis: a preset (by name) or a custom list of faults.

    In YAML a bare string is a preset name: ``- optical-bias-small``.
    """

    name: str = spec("", doc="label of the case in tables (default: the preset name)")
    preset: str | None = spec(None, doc="fault preset name (`navbank scenarios` lists them); 'none' is nominal")
    faults: tuple[FaultConfig, ...] = spec((), doc="custom faults (instead of a preset)")
    onset_day: float | None = spec(
        None, doc="onset of the preset's faults (default: the campaign's onset_day, else the preset's)", unit="day", ge=0.0
    )

    def __post_init__(self) -> None:
        if self.preset is not None and self.faults:
            raise ValueError("a fault case takes either preset or faults, not both")
        if self.preset is None and not self.faults:
            raise ValueError("a fault case needs a preset (e.g. 'none') or a list of faults")
        if self.preset is not None and self.preset not in FAULT_PRESETS:
            raise ValueError(f"unknown fault preset {self.preset!r}{typed.did_you_mean(self.preset, FAULT_PRESETS)}; "
                             f"known: {', '.join(FAULT_PRESETS)}")
        if self.preset is None and not self.name:
            raise ValueError("a custom fault case needs a name")
        if self.faults and self.onset_day is not None:
            raise ValueError("onset_day applies to presets; custom faults carry their own onset_day")

    @property
    def label(self) -> str:
        return self.name or str(self.preset)

    @classmethod
    def _typed_decode(cls, data: Any, path: str) -> "FaultCase":
        if isinstance(data, str):
            data = {"preset": data}
        return typed.decode(cls, data, path)

    def _typed_encode(self, drop_defaults: bool) -> Any:
        return typed.encode(self, drop_defaults=drop_defaults)

    @classmethod
    def _typed_schema(cls) -> dict:
        return {"anyOf": [{"type": "string", "enum": list(FAULT_PRESETS)}, typed.json_schema(cls, top=False)]}


@dataclass(frozen=True)
class NetworkVariant:
    """One column of the gating axis: which networks run, with which parameters, and which one
    drives the anomaly detector. In YAML a bare string ``NAME`` means ``{name: NAME, detector:
    NAME}`` (and ``default`` keeps the scenario's gating and detector as they are)."""

    name: str = spec(doc="label of the variant in tables")
    gating: tuple[GatingEntry, ...] = spec((), doc="replace the scenario's gating list (empty: keep it)")
    params: dict[str, dict[str, Any]] = spec(
        default_factory=dict, doc="per-network parameter changes, e.g. {chi2: {sigma_w: 0.1, batch_size: 500}}"
    )
    detector: str | None = spec(
        None, doc="network driving the anomaly detector (added to the gating list with defaults if absent)"
    )
    calibration: str | None = spec(
        None, doc="detector calibration file (`navbank calibrate --out`), relative to the campaign file"
    )
    overrides: dict[str, Any] = spec(default_factory=dict, doc="scenario keys changed for this variant only")
    monitors: dict[str, str] = spec(
        default_factory=dict,
        doc="more detectors evaluated on the same runs: gating network -> its calibration file (relative to the "
        "campaign file); each network is added to the gating list with defaults if absent, and its weight "
        "stream is replayed through its own detector after the run (summary.monitors.<network>)",
    )

    def __post_init__(self) -> None:
        for net, cal in self.monitors.items():
            if not net or not cal:
                raise ValueError("a monitor needs a network name and a calibration file")

    @classmethod
    def _typed_decode(cls, data: Any, path: str) -> "NetworkVariant":
        if isinstance(data, str):
            data = {"name": data} if data == "default" else {"name": data, "detector": data}
        return typed.decode(cls, data, path)

    def _typed_encode(self, drop_defaults: bool) -> Any:
        return typed.encode(self, drop_defaults=drop_defaults)

    @classmethod
    def _typed_schema(cls) -> dict:
        return {"anyOf": [{"type": "string"}, typed.json_schema(cls, top=False)]}


DEFAULT_VARIANT = NetworkVariant(name="default")


@dataclass(frozen=True)
class MatrixBlock:
    """A full cross product scenarios x faults x networks."""

    scenarios: tuple[str, ...] = spec(doc="built-in scenario names or scenario files (relative to the campaign file)")
    faults: tuple[FaultCase, ...] = spec(doc="fault cases: preset names or {name, faults: [...]}")
    networks: tuple[NetworkVariant, ...] = spec((DEFAULT_VARIANT,), doc="gating-network variants")

    def __post_init__(self) -> None:
        for axis, labels in (("scenarios", list(self.scenarios)), ("faults", [f.label for f in self.faults]),
                             ("networks", [v.name for v in self.networks])):
            if not labels:
                raise ValueError(f"{axis} must not be empty")
            dup = sorted({x for x in labels if labels.count(x) > 1})
            if dup:
                raise ValueError(f"{axis} labels must be unique, repeated: {', '.join(dup)}")


@dataclass(frozen=True)
class SeedPlan:
    """Seeds of every cell: base, base+1, …, base+count-1 (the same seeds in every cell, so
    cells are compared on common random numbers)."""

    count: int = spec(1, doc="runs per cell", ge=1)
    base: int = spec(1, doc="first seed", ge=0)

    def seeds(self) -> range:
        return range(self.base, self.base + self.count)


KeepMcap = Literal["none", "failed", "detected", "all"]
KEEP_MCAP_DOC = ("runs that keep an MCAP recording (mcap/<id>.mcap), for navbank report and replay --rerun: none; "
                 "failed (the detector missed the injected fault, declared a false alarm or the wrong class); "
                 "detected (an anomaly was declared); all")


@dataclass(frozen=True)
class CampaignConfig:
    """A fault-injection campaign."""

    name: str = spec(doc="campaign name")
    matrix: tuple[MatrixBlock, ...] = spec(doc="blocks of scenarios x faults x networks")
    description: str = spec("", doc="one line shown in the report")
    seeds: SeedPlan = spec(default_factory=SeedPlan, doc="seeds per cell")
    onset_day: float | None = spec(None, doc="default onset of preset faults", unit="day", ge=0.0)
    overrides: dict[str, Any] = spec(default_factory=dict, doc="scenario keys changed in every run (dotted or nested)")
    keep_mcap: KeepMcap = spec("none", doc=KEEP_MCAP_DOC)
    keep_weights: tuple[str, ...] = spec(
        (), doc="gating networks whose weight histories every run stores (weights/<network>/<id>.npz); "
        "each is added to the gating list with defaults if absent"
    )

    def __post_init__(self) -> None:
        if not self.matrix:
            raise ValueError("matrix needs at least one block")


@dataclass
class LoadedCampaign:
    """A validated campaign with where it came from (for relative paths and error lines)."""

    config: CampaignConfig
    file: str
    base_dir: Path
    lines: dict[str, int] = field(default_factory=dict)
    text: str = ""

    def error(self, path: str, expected: str, got: str) -> ConfigError:
        """A one-line error pointing at ``path`` (or its nearest ancestor) in the campaign file."""
        probe = path
        while probe and probe not in self.lines:
            cut = max(probe.rfind("."), probe.rfind("["))
            probe = probe[:cut] if cut > 0 else ""
        return ConfigError(self.file, self.lines.get(probe), path, expected, got)


def builtin_dir():
    return resources.files("tools").joinpath("campaigns")


def builtin_names() -> list[str]:
    """Names of the built-in campaigns (``tools/campaigns/*.yaml``)."""
    return sorted(p.name.removesuffix(".yaml") for p in builtin_dir().iterdir() if p.name.endswith(".yaml"))


def load_campaign_text(text: str, file: str, base_dir: Path) -> LoadedCampaign:
    data, lines = parse_yaml(text, file)
    cfg = load_data(CampaignConfig, data, lines, file)
    return LoadedCampaign(cfg, file, base_dir, lines, text)


def load_campaign(name_or_path: str) -> LoadedCampaign:
    """A built-in campaign by name, or a campaign YAML file by path."""
    path = Path(name_or_path)
    if name_or_path.endswith((".yaml", ".yml")) or path.is_file():
        text = read_config_text(path)
        return load_campaign_text(text, str(path), path.resolve().parent)
    res = builtin_dir().joinpath(f"{name_or_path}.yaml")
    if not res.is_file():
        raise ConfigError(name_or_path, None, "", "a built-in campaign (" + ", ".join(builtin_names()) + ") or a YAML file",
                          "unknown name" + typed.did_you_mean(name_or_path, builtin_names()))
    return load_campaign_text(res.read_text(encoding="utf-8"), f"<built-in campaign {name_or_path}>",
                              Path(str(builtin_dir())))
