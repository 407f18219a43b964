"""Argument types shared by the commands: a bad value is refused by argparse itself, as one line
with exit code 2, before anything is started.

This module imports nothing heavy, so the processes ``navbank run`` starts (``navbank ground log``
above all) do not pay for the scenario machinery just to check an option.
"""

from __future__ import annotations

import argparse

from fsw.interface import topics


def run_id_arg(value: str) -> str:
    """``--run-id``: one Zenoh key chunk (:func:`fsw.interface.topics.check_run_id`)."""
    try:
        return topics.check_run_id(value)
    except ValueError as exc:
        # argparse reports ArgumentTypeError's message as is, under the option's name
        raise argparse.ArgumentTypeError(str(exc)) from None
