"""The error a command raises for a bad command-line value (``navbank`` reports it as one line
and exits with code 2); commands import it from here, not from the entry point."""


class UsageError(Exception):
    """A bad command-line value: reported as one line, exit code 2."""
