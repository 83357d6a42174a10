"""A planning run's clock: progress reports, the one time budget, and what the run records.

The time limit bounds the whole run. :class:`Clock` holds its deadline; every solve asks it what
is left (:meth:`Clock.remaining`), the finishing solves (step 2, a completion, the assembly of
parts) with a small grace (``budget.grace_share``, ``budget.grace_max_seconds``), and the effort
floors of a model stop at a share of it (``model.floors_share``). The clock also sums the time spent building models and keeps every
confirmation of an infeasible verdict (:mod:`stlplan.planner.confirm`).
"""

from __future__ import annotations

import contextlib
import math
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Literal

from stlplan.planner.config import PlannerConfig
from stlplan.result import Confirmation

Phase = Literal["build", "step1", "step2", "polish", "done"]


@dataclass(frozen=True)
class Progress:
    """A progress report while planning.

    Attributes
    ----------
    phase
        ``build`` (encoding), ``step1`` (MILP), ``step2`` (effort), ``polish``, ``done``.
    elapsed
        Seconds since planning started.
    incumbent, bound, gap
        Best objective found, best bound and relative gap of the MILP (None when unknown).
    round
        Lazy round of step 1 (1, 2, ...), None outside step 1.
    """

    phase: Phase
    elapsed: float
    incumbent: float | None = None
    bound: float | None = None
    gap: float | None = None
    round: int | None = None


ProgressCallback = Callable[[Progress], None]


@dataclass
class Clock:
    """One run's time budget and records.

    Planning start time and deadline (``time.perf_counter`` seconds), the user's progress
    callback with its first error, the lazy round, the time spent building models, and every
    confirmation of an infeasible verdict (:mod:`stlplan.planner.confirm`).
    """

    start: float
    progress: ProgressCallback | None
    error: BaseException | None = None
    round: int | None = None
    deadline: float = math.inf
    grace: float = 0.0
    build_seconds: float = 0.0
    confirmations: list[Confirmation] = field(default_factory=list)

    @classmethod
    def started(
        cls, config: PlannerConfig, progress: ProgressCallback | None, deadline: float | None = None
    ) -> Clock:
        """A clock started now whose budget ends after ``solver.time_limit`` s (or at
        ``deadline``), with the grace of ``budget``."""
        now, limit, budget = time.perf_counter(), config.solver.time_limit, config.budget
        end = now + limit if deadline is None else min(deadline, now + limit)
        grace = min(budget.grace_max_seconds, budget.grace_share * limit)
        return cls(now, progress, deadline=end, grace=grace)

    def elapsed(self) -> float:
        """Seconds since planning started."""
        return time.perf_counter() - self.start

    def share(self, fraction: float) -> float:
        """The ``time.perf_counter()`` time when ``fraction`` of the remaining budget is spent."""
        now = time.perf_counter()
        return now + fraction * max(0.0, self.deadline - now)

    def remaining(self, finishing: bool = False) -> float:
        """Seconds left of the budget (with the grace of finishing solves when ``finishing``)."""
        return self.deadline + (self.grace if finishing else 0.0) - time.perf_counter()

    @contextlib.contextmanager
    def building(self) -> Iterator[None]:
        """Count the block's wall time as building (encoding a model, loading it into HiGHS)."""
        tick = time.perf_counter()
        try:
            yield
        finally:
            self.build_seconds += time.perf_counter() - tick

    def report(
        self,
        phase: Phase,
        incumbent: float | None = None,
        bound: float | None = None,
        gap: float | None = None,
    ) -> None:
        if self.progress is None or self.error is not None:
            return
        step_round = self.round if phase == "step1" else None
        try:
            self.progress(Progress(phase, self.elapsed(), incumbent, bound, gap, step_round))
        except Exception as exc:  # re-raised once HiGHS has returned
            self.error = exc
