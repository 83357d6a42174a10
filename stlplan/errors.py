"""One hierarchy of user-facing errors, rendered by the command line, and message helpers.

Every error a user may see derives from :class:`StlplanError`, whose ``exit_code`` tells kinds
apart and whose message is prefixed by the file (``source``) and the place in it (``where``).
The helpers at the end phrase the common parts of such messages: a did-you-mean suggestion and
an undefined name with the names that are defined.
"""

from __future__ import annotations

from difflib import get_close_matches
from typing import NoReturn


class StlplanError(Exception):
    """Base of every error stlplan reports to a user; ``exit_code`` tells kinds apart."""

    exit_code = 2

    def __init__(self, message: str, *, source: str | None = None, where: str | None = None):
        super().__init__(message)
        self.message = message
        self.source = source
        self.where = where

    def __str__(self) -> str:
        prefix = ": ".join(p for p in (self.source, self.where) if p)
        return f"{prefix}: {self.message}" if prefix else self.message


class UsageError(StlplanError):
    """A command-line option or path that cannot be used."""

    exit_code = 2


class MissionError(StlplanError):
    """A mission file that cannot be read or is inconsistent."""

    exit_code = 3


class FormulaError(StlplanError):
    """A formula that does not parse or does not fit its mission."""

    exit_code = 3


class TrajectoryError(StlplanError):
    """A trajectory file that cannot be read or does not fit its mission."""

    exit_code = 3


class InfeasibleError(StlplanError):
    """The mission's tasks and constraints cannot be met together."""

    exit_code = 4


class SolverError(StlplanError):
    """The solver failed, or produced a plan the monitor rejects."""

    exit_code = 6


def fail(message: str, where: str, source: str | None) -> NoReturn:
    """Raise a :class:`MissionError` with ``message`` at field path ``where``."""
    raise MissionError(message, source=source, where=where)


def did_you_mean(name: str, options: list[str]) -> str:
    """`` (did you mean 'x'?)`` for the option closest to ``name``, or nothing."""
    close = get_close_matches(name, options, n=1)
    return f" (did you mean '{close[0]}'?)" if close else ""


def undefined(kind: str, name: str, options: list[str]) -> str:
    """The message for a ``kind`` named ``name`` that is not among the defined ``options``."""
    known = ", ".join(options) if options else "none"
    return f"undefined {kind} '{name}'{did_you_mean(name, options)}; defined: {known}"
