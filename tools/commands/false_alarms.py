"""``navbank false-alarms``: when nominal runs false-alarm — declaration epochs over nominal seeds.

Flies the scenario without its fault for each seed (in-process, a spawn pool of ``--workers``),
replays the scenario's chi2 detector on each run's weights with and without a closing partial batch
shorter than half a batch, and writes a JSON summary with the declaration epochs and their
histogram over the arc. A 45-day ``insight-approach`` run takes ~20 s of one core.
``navbank validation-report`` reads it from ``campaigns/false-alarm-epochs.json``.
Exit codes: 0 written, 2 bad arguments.
"""

from __future__ import annotations

from tools.commands.consistency import _positive
from tools.commands.outputs import check_output_file, emit_json

NAME = "false-alarms"
HELP = "declaration epochs of the chi2 detector over nominal seeds (JSON summary)"
DESCRIPTION = __doc__.split("\n", 2)[2] if __doc__ else HELP


def add_arguments(p) -> None:
    p.add_argument("--seeds", type=_positive, default=100, help="number of nominal runs (default 100)")
    p.add_argument("--first-seed", type=int, default=1, help="seed of the first run (default 1)")
    p.add_argument("--workers", type=_positive, default=2, help="processes flying runs in parallel (default 2)")
    p.add_argument("--scenario", default="insight-approach", help="scenario name or file (default insight-approach)")
    p.add_argument("--out", metavar="FILE", default=None, help="write the JSON summary here too")


def run(args) -> int:
    from tools.validation.false_alarm_epochs import measure

    if args.out:
        check_output_file(args.out)
    emit_json(measure(args.seeds, args.first_seed, args.workers, args.scenario), args.out)
    return 0
