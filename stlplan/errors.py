"""One hierarchy of user-facing errors, rendered by the command line, and message helpers.

Every error a user may see derives from :class:`StlplanError`, whose ``exit_code`` tells kinds
apart and whose message is prefixed by the file (``source``) and the place in it (``where``).
The helpers at the end phrase the common parts of such messages: a did-you-mean suggestion and
an undefined name with the names that are defined.
"""

from __future__ import annotations

import unicodedata
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


class EventError(StlplanError):
    """A replan's step or events that do not fit the mission (a step past the horizon, an
    unknown or repeated agent or region, every agent lost)."""

    exit_code = 3


class SimulationError(StlplanError):
    """A simulation's settings that cannot be run: a disturbance bound that is not a number
    ``>= 0``, fewer than one run, an unknown replanning policy (its events are
    :class:`EventError`)."""

    exit_code = 3


class SolverError(StlplanError):
    """The solver failed, or produced a plan the monitor rejects."""

    exit_code = 6


def fail(message: str, where: str, source: str | None) -> NoReturn:
    """Raise a :class:`MissionError` with ``message`` at field path ``where``."""
    raise MissionError(message, source=source, where=where)


def unusual_characters(text: str) -> str:
    """The characters of ``text`` beyond printable ASCII, by code point and name, such as
    ``U+200B ZERO WIDTH SPACE at position 3`` (empty when there is none)."""
    found = [
        f"U+{ord(c):04X} {unicodedata.name(c, 'CONTROL CHARACTER')} at position {i + 1}"
        for i, c in enumerate(text)
        if not (c.isascii() and c.isprintable())
    ]
    return ", ".join(found[:3]) + (f" and {len(found) - 3} more" if len(found) > 3 else "")


def did_you_mean(name: str, options: list[str]) -> str:
    """`` (did you mean 'x'?)`` for the option closest to ``name``, or nothing; when either name
    holds characters that may print like others (homoglyphs, zero-width spaces), their code
    points are shown instead of a suggestion that may look identical."""
    close = get_close_matches(name, options, n=1)
    if not close:
        return ""
    odd = [f"'{n}' holds {u}" for n in (name, close[0]) if (u := unusual_characters(n))]
    if odd:
        return f" (the closest name is '{close[0]}'; {'; '.join(odd)})"
    return f" (did you mean '{close[0]}'?)"


def undefined(kind: str, name: str, options: list[str]) -> str:
    """The message for a ``kind`` named ``name`` that is not among the defined ``options``."""
    known = ", ".join(options) if options else "none"
    return f"undefined {kind} '{name}'{did_you_mean(name, options)}; defined: {known}"
