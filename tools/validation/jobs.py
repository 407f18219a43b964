"""The validation report's experiments that fly their own runs, as independent jobs.

The Chaer et al. 1997 jobs take ``run``, a replacement for their experiment (tests hand in small
ones; the report then computes those sections in its own process).

Each job computes one section of ``docs/validation.md`` (its runs, figures and claims) from
nothing but the figure and document directories, so ``navbank validation-report --workers N``
spreads them over N processes; the document keeps its fixed section order whatever order they
finish in. Jobs are listed longest first so that the pool is not left waiting on one long job.
"""

from __future__ import annotations

import multiprocessing
from pathlib import Path
from typing import Any, Callable, Iterable

from tools.validation.section import Section


def chaer1997(fig_dir: Path, doc_dir: Path, run: Callable[[], Any] | None = None) -> list[Section]:
    from tools.validation.chaer1997 import plot_experiment_3, run_chaer1997
    from tools.validation.document import CHAER1997_DISCUSSION, chaer1997_section

    results = (run or run_chaer1997)()
    s = chaer1997_section(results, plot_experiment_3(results, fig_dir / "chaer1997-experiment3.png"), doc_dir)
    s.discussion = CHAER1997_DISCUSSION
    return [s]


def chaer1997_ga(fig_dir: Path, doc_dir: Path, run: Callable[[], Any] | None = None) -> list[Section]:
    from tools.validation.chaer1997_ga import GA_DISCUSSION, ga_section, run_campaign

    s = ga_section((run or run_campaign)(), fig_dir, doc_dir)
    s.discussion = GA_DISCUSSION
    return [s]


def chaer1997_rqp(fig_dir: Path, doc_dir: Path, run: Callable[[], Any] | None = None) -> list[Section]:
    from tools.validation import chaer1997_rqp as rqp

    exp4 = (run or rqp.run_experiment_4)()
    s = rqp.experiment4_section(exp4, rqp.plot_experiment_4(exp4, fig_dir / "chaer1997-experiment4-rqp.png"), doc_dir)
    s.discussion = rqp.EXPERIMENT4_DISCUSSION
    return [s]


def hanlon2000(fig_dir: Path, doc_dir: Path) -> list[Section]:
    from tools.validation import hanlon2000 as hm

    out = []
    for case in hm.CASES:
        r = hm.run_hanlon2000(case)
        out.append(hm.hanlon2000_section(r, hm.plot_hanlon2000(r, fig_dir / f"hanlon2000-{case}-identification.png"),
                                         doc_dir))
    out[-1].discussion = hm.HANLON2000_DISCUSSION
    return out


def garhwal(fig_dir: Path, doc_dir: Path) -> list[Section]:
    from tools.validation import garhwal as g

    return [g.build_section(fig_dir, doc_dir)]


def chaer1998(fig_dir: Path, doc_dir: Path) -> list[Section]:
    from tools.validation.chaer1998 import chaer1998_section
    from tools.validation.document import CHAER1998_DISCUSSION

    s = chaer1998_section(fig_dir, doc_dir)
    s.discussion = CHAER1998_DISCUSSION
    return [s]


def chaer1998_em(fig_dir: Path, doc_dir: Path) -> list[Section]:
    from tools.validation.chaer1998_em import EM_DISCUSSION, em_section

    s = em_section(None, fig_dir, doc_dir)
    s.discussion = EM_DISCUSSION
    return [s]


def optical(fig_dir: Path, doc_dir: Path) -> list[Section]:
    from tools.validation.document import OPTICAL_DISCUSSION
    from tools.validation.optical_nav import optical_nav_section

    s = optical_nav_section()
    s.discussion = OPTICAL_DISCUSSION
    return [s]


#: name -> job, longest first (measured: the optical camera runs, the cruise seeds, EM, Garhwal's seeds)
JOBS: dict[str, Callable[..., list[Section]]] = {
    "optical": optical, "chaer1998": chaer1998, "chaer1998-em": chaer1998_em, "garhwal": garhwal,
    "chaer1997-ga": chaer1997_ga, "hanlon2000": hanlon2000, "chaer1997-rqp": chaer1997_rqp, "chaer1997": chaer1997,
}


def _run(args: tuple[str, Path, Path]) -> tuple[str, list[Section]]:
    name, fig_dir, doc_dir = args
    return name, JOBS[name](fig_dir, doc_dir)


def run_jobs(names: Iterable[str], fig_dir: Path, doc_dir: Path, workers: int = 1) -> dict[str, list[Section]]:
    """The sections of the named jobs, computed on ``workers`` processes (1: here, in order)."""
    todo = [(n, fig_dir, doc_dir) for n in JOBS if n in set(names)]
    if workers <= 1 or len(todo) <= 1:
        return dict(map(_run, todo))
    with multiprocessing.get_context("spawn").Pool(min(workers, len(todo))) as pool:
        return dict(pool.imap_unordered(_run, todo, chunksize=1))
