"""Whole reports: figures plus ``report.md`` for a run (MCAP file or run directory) or a campaign.

A run directory holds ``run.mcap`` and usually ``summary.json``; a campaign directory holds
``runs.jsonl`` (and ``summary.json``). :func:`classify` tells which a path is.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from fsw.interface.yamlconfig import ConfigError, read_config_text
from ground.report import campaign_data as C
from ground.report.campaign_plots import write_campaign_figures
from ground.report.figure import figure_class
from ground.report.markdown import campaign_markdown, run_markdown, write_markdown
from ground.report.run_data import extract, hierarchy_groups_from_config
from ground.report.run_facts import run_facts
from ground.report.run_plots import write_run_figures

RUN_MCAP = "run.mcap"
RUN_SUMMARY = "summary.json"
RUN_CONFIG = "config.yaml"  # the run's complete scenario, also attached to run.mcap
REPORT_DIR = "report"


class ReportInputError(ValueError):
    """A path that is neither an MCAP file, a run directory nor a campaign directory."""


@dataclass(frozen=True)
class ReportInput:
    kind: Literal["run", "campaign"]
    path: Path  # the MCAP file (run) or the campaign directory
    summary: Path | None  # summary.json beside the MCAP file (run)
    default_out: Path


def classify(path: str | Path) -> ReportInput:
    """What ``path`` is and where its report goes by default."""
    p = Path(path)
    if p.is_file():
        if p.suffix != ".mcap":
            raise ReportInputError(f"{p}: expected an .mcap file, a run directory or a campaign directory")
        summary = p.parent / RUN_SUMMARY
        # a summary.json beside a file not called run.mcap may belong to another run
        use = summary if summary.is_file() and (p.name == RUN_MCAP or not (p.parent / RUN_MCAP).exists()) else None
        out = p.parent / REPORT_DIR if p.name == RUN_MCAP else p.with_name(p.stem + "-report")
        return ReportInput("run", p, use, out)
    if p.is_dir():
        if (p / C.RUNS_FILE).is_file():
            return ReportInput("campaign", p, None, p / REPORT_DIR)
        if (p / RUN_MCAP).is_file():
            summary = p / RUN_SUMMARY
            return ReportInput("run", p / RUN_MCAP, summary if summary.is_file() else None, p / REPORT_DIR)
        raise ReportInputError(f"{p}: neither a run directory ({RUN_MCAP}) nor a campaign directory ({C.RUNS_FILE})")
    raise ReportInputError(f"{p}: no such file or directory")


def report_run_messages(messages: Iterable[Any], out_dir: str | Path, *, summary: dict | None = None,
                        source: str = "in-memory run", t0: float | None = None,
                        groups: Mapping[str, Mapping[str, Sequence[str]]] | None = None) -> list[Path]:
    """Figures and report.md of a run given as ``(topic, message)`` pairs; returns the paths written.
    ``groups``: the banks of its hierarchical gating networks (network -> bank -> filters)."""
    figure_class()  # fail before reading anything if matplotlib is missing
    out = Path(out_dir)
    data = extract(messages, t0=t0, groups=groups)
    figures = write_run_figures(data, out)
    facts = summary if summary is not None else run_facts(data)
    facts_from = "summary.json" if summary is not None else "the recorded messages"
    md = write_markdown(run_markdown(facts, figures, out, source=source, facts_from=facts_from, data=data), out)
    return figures + [md]


def run_config_groups(mcap_path: str | Path) -> dict[str, dict[str, tuple[str, ...]]]:
    """Banks of the run's hierarchical gating networks: from ``config.yaml`` beside the MCAP file
    (when it belongs to it, as for summary.json), else from the file's config.yaml attachment;
    empty when neither is readable."""
    p = Path(mcap_path)
    beside = p.parent / RUN_CONFIG
    if beside.is_file() and (p.name == RUN_MCAP or not (p.parent / RUN_MCAP).exists()):
        try:
            return hierarchy_groups_from_config(read_config_text(beside))
        except ConfigError:
            pass
    from ground.mcap_io.reader import read_attachments

    try:
        _, data = read_attachments(p).get(RUN_CONFIG, ("", b""))
        return hierarchy_groups_from_config(data.decode("utf-8")) if data else {}
    except (OSError, ValueError):  # a damaged file: the weights alone then tell the banks
        return {}


def report_run(mcap_path: str | Path, out_dir: str | Path, *, summary_path: str | Path | None = None) -> list[Path]:
    """Figures and report.md of a recorded run (complete or cut-short MCAP file)."""
    from ground.mcap_io.reader import read_messages

    figure_class()
    summary = None
    if summary_path is not None:
        try:
            summary = json.loads(Path(summary_path).read_text(encoding="utf-8"))
        except (OSError, ValueError):
            summary = None  # fall back to the facts in the messages
        if not isinstance(summary, dict):
            summary = None
    return report_run_messages(read_messages(mcap_path, strict=False), out_dir, summary=summary, source=Path(mcap_path).name,
                               groups=run_config_groups(mcap_path))


def report_campaign(campaign_dir: str | Path, out_dir: str | Path) -> list[Path]:
    """Figures and report.md of a campaign directory."""
    figure_class()
    camp = C.load_campaign(campaign_dir)
    out = Path(out_dir)
    figures = write_campaign_figures(camp, out)
    md = write_markdown(campaign_markdown(camp, figures, out), out)
    return figures + [md]


def report(path: str | Path, out_dir: str | Path | None = None) -> list[Path]:
    """Report whatever ``path`` is (see :func:`classify`)."""
    what = classify(path)
    out = Path(out_dir) if out_dir is not None else what.default_out
    if what.kind == "campaign":
        return report_campaign(what.path, out)
    return report_run(what.path, out, summary_path=what.summary)
