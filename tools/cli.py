"""``navbank``: the command-line entry point.

Each subcommand lives in its own module under :mod:`tools.commands` exposing ``NAME``, ``HELP``,
``add_arguments(parser)`` and ``run(args) -> int``. Configuration errors become one line on
stderr and exit code 2, never a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys
from typing import Any, NoReturn

from fsw.interface.yamlconfig import ConfigError
from tools.commands.errors import UsageError
from tools.commands.help_text import PlainHelpFormatter, VersionAction
from tools.supervision import watch_supervisor_from_env
from tools.commands.outputs import write_error_line
from tools import blas_threads, process_gc

#: Subcommand modules, in the order ``navbank --help`` lists them.
COMMANDS = (
    "tools.commands.run",
    "tools.commands.validate",
    "tools.commands.scenarios",
    "tools.commands.sim",
    "tools.commands.fsw",
    "tools.commands.ground",
    "tools.commands.replay",
    "tools.commands.command",
    "tools.commands.recover",
    "tools.commands.credentials",
    "tools.commands.bench",
    "tools.commands.report",
    "tools.commands.campaign",
    "tools.commands.calibrate",
    "tools.commands.tune",
    "tools.commands.validation_report",
    "tools.commands.consistency",
    "tools.commands.false_alarms",
)


class OneLineParser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (exit code 2), as for a bad configuration
    file: argparse's default prints the whole usage block before the one line that matters."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        # also the class of every sub-parser, so every --help is plain text
        kwargs.setdefault("formatter_class", PlainHelpFormatter)
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


#: Subcommand name -> its module (each module's ``NAME`` is its module name with ``-`` for ``_``;
#: ``tests/test_cli_help.py`` checks it).
BY_NAME: dict[str, str] = {m.rsplit(".", 1)[1].replace("_", "-"): m for m in COMMANDS}


def _requested(argv: list[str]) -> tuple[str, ...]:
    """The command modules a command line needs: the named command's alone (every process of a
    run starts with a command line, and importing all eighteen commands — plotting, campaigns,
    the launcher — cost each of them about a second of CPU), or all of them for the top-level
    help, the version and an unknown command (whose error lists them)."""
    if argv and argv[0] in BY_NAME:
        return (BY_NAME[argv[0]],)
    return COMMANDS


def build_parser(commands: tuple[str, ...] = COMMANDS) -> argparse.ArgumentParser:
    parser = OneLineParser(
        prog="navbank",
        description="Flight-software-in-the-loop simulator for autonomous deep-space navigation "
        "with filter-bank anomaly detection.",
    )
    parser.add_argument("--version", action=VersionAction)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for module_name in commands:
        module = importlib.import_module(module_name)
        p = sub.add_parser(module.NAME, help=module.HELP, description=getattr(module, "DESCRIPTION", module.HELP))
        module.add_arguments(p)
        p.set_defaults(_run=module.run, _name=module.NAME)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the command ``argv`` (default: this process's command line, which then also sets up the
    process: one BLAS thread, :mod:`tools.blas_threads`, and the garbage collector,
    :mod:`tools.process_gc`)."""
    watch_supervisor_from_env()
    own_process = argv is None
    if own_process:
        blas_threads.one_blas_thread()  # before the command's imports load numpy
        process_gc.starting()
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(_requested(argv))
    args = parser.parse_args(argv)
    if own_process:
        process_gc.started()
    if not getattr(args, "_run", None):
        parser.print_help()
        return 2
    try:
        return int(args._run(args) or 0)
    except (ConfigError, UsageError) as exc:
        print(f"navbank {args._name}: {exc}" if isinstance(exc, UsageError) else str(exc), file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"navbank {args._name}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # our output's reader went away (e.g. `| head`, or a killed launcher): the work may not
        # be done, so not a success — the shell's code for a broken pipe; silence the flush at
        # exit too
        sys.stdout = open(os.devnull, "w")
        return 128 + signal.SIGPIPE
    except OSError as exc:  # after BrokenPipeError, one of its kind
        # a file error no command anticipated (most are named where they happen): still one line
        # naming the file and the errno, never a traceback
        print(f"navbank {args._name}: {write_error_line(exc)}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
