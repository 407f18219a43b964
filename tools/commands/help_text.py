"""Help texts in plain words: docstrings written for the API reference read well in ``--help``
once their reStructuredText markup is gone."""

from __future__ import annotations

import argparse
import re

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
    # imported here: the metadata machinery costs every process ~15 ms to import, and only
    # --version reads it
    from importlib import metadata

    try:
        return f"navbank {metadata.version('navbank')}"
    except metadata.PackageNotFoundError:
        return "navbank (not installed: version unknown)"


class VersionAction(argparse.Action):
    """``--version``: prints :func:`version_text` and exits 0, looking the version up only then (the
    stock action takes the string when the parser is built, in every process a run starts)."""

    def __init__(self, option_strings: list[str], dest: str = argparse.SUPPRESS,
                 default: str = argparse.SUPPRESS, help: str = "show the version and exit") -> None:
        super().__init__(option_strings=option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: object,
                 option_string: str | None = None) -> None:
        print(version_text())
        parser.exit()
