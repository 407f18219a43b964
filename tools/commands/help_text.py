"""Help texts in plain words: docstrings written for the API reference read well in ``--help``
once their reStructuredText markup is gone."""

from __future__ import annotations

import argparse
import re
from importlib import metadata

# :func:`~pkg.mod.name` -> name, :class:`pkg.Name` -> pkg.Name (the role's target as written)
_ROLE = re.compile(r":[a-z]+:`(~?)([^`<]+?)(?:\s*<[^>]*>)?`")
_LITERAL = re.compile(r"``([^`]+)``")


def _role(match: re.Match[str]) -> str:
    target = match.group(2).strip()
    return "`" + (target.rsplit(".", 1)[-1] if match.group(1) else target) + "`"


def plain(text: str) -> str:
    """``text`` without reStructuredText roles (``:func:`~a.b```) and with ````x```` as `x`."""
    return _LITERAL.sub(r"`\1`", _ROLE.sub(_role, text))


class PlainHelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Descriptions keep their line breaks (they are laid out by hand); markup is removed from
    descriptions, epilogs and option help alike."""

    def _format_text(self, text: str) -> str:
        return super()._format_text(plain(text))

    def _expand_help(self, action: argparse.Action) -> str:
        return plain(super()._expand_help(action))


def version_text() -> str:
    """``navbank X.Y.Z``: the installed distribution's version."""
    try:
        return f"navbank {metadata.version('navbank')}"
    except metadata.PackageNotFoundError:
        return "navbank (not installed: version unknown)"
