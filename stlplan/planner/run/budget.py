"""The run's time, shared out: one :class:`Budget` handed to every stage and strategy.

A run's time limit (``solver.time_limit``) bounds the whole run. The run's budget ends at its
deadline; a stage or strategy that shares its time out hands each piece a child budget:

* :meth:`Budget.share`: a fraction of what is left (a repair between lazy rounds, the repair of
  a merged part, the effort floors of a model);
* :meth:`Budget.seconds`: at most so many seconds (the assembly of parts);
* :meth:`Budget.split`: equal shares of what is left but a reserve, each taken when it starts, so
  that what one piece leaves goes to the next (the parts' first solves, the turns of a repair);
* :meth:`Budget.finishing`: to the run's deadline plus its grace, for the solves that turn a
  plan already found into the one written (step 2, a completion, the assembly).

A child never ends after its parent. Every solve runs at least one least solve
(:func:`least_solve`: ``budget.min_solve_seconds``, or the grace when a short time limit's is
smaller, so that a run ends within its time limit and grace; :meth:`Budget.limit`); :meth:`Budget.expired` says when less than that is left. The budgets of
one run share a ledger of the seconds each stage spent (:meth:`Budget.stage`), which
``summary.json`` records.
"""

from __future__ import annotations

import contextlib
import dataclasses
import time
from collections.abc import Iterator
from dataclasses import dataclass, field

from stlplan.planner.config import BudgetConfig, PlannerConfig
from stlplan.runtime import signals


def grace_of(config: PlannerConfig) -> float:
    """How long the finishing solves may run past the deadline: ``budget.grace_share`` of the
    time limit, at most ``budget.grace_max_seconds``."""
    settings = config.budget
    return min(settings.grace_max_seconds, settings.grace_share * config.solver.time_limit)


def least_solve(config: PlannerConfig) -> float:
    """The least time limit of one solve: ``budget.min_solve_seconds``, or the grace when it is
    smaller (a time limit under ``min_solve_seconds / grace_share``, 10 s by default), so that no
    solve started at the deadline runs past the grace."""
    return min(config.budget.min_solve_seconds, grace_of(config))


@dataclass(frozen=True)
class Budget:
    """Time to a deadline (``time.perf_counter`` seconds), within one run's.

    Attributes
    ----------
    deadline
        When this budget ends.
    grace_end
        When the run's finishing solves must end (the run's deadline plus its grace).
    min_solve
        The least time limit of one solve, s.
    ledger
        Seconds spent per stage, shared by every budget of the run.
    """

    deadline: float
    grace_end: float
    min_solve: float = BudgetConfig().min_solve_seconds
    ledger: dict[str, float] = field(default_factory=dict, compare=False, repr=False)

    @classmethod
    def for_run(cls, config: PlannerConfig, deadline: float | None = None) -> Budget:
        """The budget of a run starting now: ``solver.time_limit`` (or to ``deadline`` when
        earlier), with the grace of ``budget.grace_share`` and ``budget.grace_max_seconds``."""
        now, limit = time.perf_counter(), config.solver.time_limit
        end = now + limit if deadline is None else min(deadline, now + limit)
        return cls(end, end + grace_of(config), least_solve(config))

    @classmethod
    def of_seconds(cls, seconds: float, config: PlannerConfig | None = None) -> Budget:
        """A budget of ``seconds`` from now, no grace (a solve outside a planning run)."""
        end = time.perf_counter() + seconds
        return cls(end, end, least_solve(config or PlannerConfig()))

    def remaining(self) -> float:
        """Seconds left (negative once the deadline has passed).

        Raises
        ------
        stlplan.runtime.signals.LeftBehind
            In a search a replan's deadline left behind (:func:`stlplan.runtime.signals.leave_behind`).
        """
        if signals.left_behind():
            raise signals.LeftBehind
        return self.deadline - time.perf_counter()

    def expired(self) -> bool:
        """Whether less than one least solve is left."""
        return self.remaining() < self.min_solve

    def limit(self) -> float:
        """The time limit of a solve started now: what is left, at least one least solve."""
        return max(self.min_solve, self.remaining())

    def until(self, deadline: float) -> Budget:
        """This budget ended at ``deadline`` when that is earlier."""
        return dataclasses.replace(self, deadline=min(self.deadline, deadline))

    def share(self, fraction: float) -> Budget:
        """``fraction`` of what is left, from now."""
        now = time.perf_counter()
        return self.until(now + fraction * max(0.0, self.deadline - now))

    def seconds(self, seconds: float) -> Budget:
        """At most ``seconds`` from now."""
        return self.until(time.perf_counter() + seconds)

    def finishing(self) -> Budget:
        """To the run's deadline plus its grace (a solve that turns a found plan into the one
        written)."""
        return dataclasses.replace(self, deadline=self.grace_end)

    def split(self, pieces: int, reserve: float = 0.0) -> Iterator[Budget]:
        """``pieces`` budgets, each an equal share of what is left when it is taken, but
        ``reserve`` of what is left now; unspent time carries over to the next."""
        now = time.perf_counter()
        end = self.deadline - reserve * max(0.0, self.deadline - now)
        for i in range(pieces):
            now = time.perf_counter()
            yield self.until(now + (end - now) / (pieces - i))

    @contextlib.contextmanager
    def stage(self, name: str) -> Iterator[None]:
        """Add the block's wall time to the ledger under ``name``."""
        tick = time.perf_counter()
        try:
            yield
        finally:
            self.ledger[name] = self.ledger.get(name, 0.0) + time.perf_counter() - tick
