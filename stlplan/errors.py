"""One hierarchy of user-facing errors, rendered by the command line."""

from __future__ import annotations


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
