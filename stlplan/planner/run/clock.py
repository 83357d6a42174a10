"""A planning run's clock: progress reports and what the run records.

The run's time is shared out by :class:`stlplan.planner.run.budget.Budget`. :class:`Clock` reports
progress, records the lazy rounds, sums the time spent building models, keeps every
confirmation of an infeasible verdict (:mod:`stlplan.planner.backend.confirm`), how far step 1 got
(:class:`stlplan.planner.run.reached.Reached`) and the whole problem's incumbent and bound over time
(:mod:`stlplan.planner.run.convergence`).
"""

from __future__ import annotations

import contextlib
import math
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

from stlplan.planner.run.convergence import Convergence
from stlplan.planner.run.reached import Reached
from stlplan.planner.run.trace import Incumbent, Trace
from stlplan.result import Confirmation
from stlplan.words import agent_names

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
    """One run's records.

    Planning start time (``time.perf_counter`` seconds), the user's progress callback with its
    first error, the lazy round under way, the time spent building models, every confirmation
    of an infeasible verdict (:mod:`stlplan.planner.backend.confirm`), the lazy rounds' records, how
    far step 1 got, and the whole problem's incumbent and bound over time.
    """

    start: float
    progress: ProgressCallback | None
    error: BaseException | None = None
    round: int | None = None
    """The number the lazy round under way will have in :attr:`round_log` (progress reports)."""
    build_seconds: float = 0.0
    confirmations: list[Confirmation] = field(default_factory=list)
    round_log: list[dict[str, Any]] = field(default_factory=list)
    """One record per lazy round (a solve of step 1's model), in the order they ran (parts one
    after another): its number, the part (its agents in a few words, and how many), the stage
    of that part, when it ended, how long it took, HiGHS's termination, its bound, the best plan
    meeting every requirement so far, and the lazy requirements its model held by kind
    (:meth:`record_round`)."""
    first_plan: float | None = None
    """Seconds from the start until step 1 first held a plan of the whole problem that meets
    every requirement (None: none yet)."""
    convergence: Convergence = field(default_factory=Convergence)
    """The whole problem's incumbent and bound over time (:mod:`stlplan.planner.run.convergence`
    says which figures count)."""
    reached: Reached = field(default_factory=Reached)
    """How far step 1 got: the part, its stage, the counts."""
    reporting: threading.Lock = field(default_factory=threading.Lock, repr=False, compare=False)
    """Parts solved side by side report one at a time: the progress callback is never called
    from two threads at once."""

    @property
    def trace(self) -> Trace:
        """Every incumbent credited to its stage, and each stage's seconds."""
        return self.reached.trace

    def plan_found(
        self, objective: float | None, stage: str | None = None, parts: dict[str, int] | None = None
    ) -> None:
        """Note that step 1 holds a plan of the whole problem with ``objective`` (the first time
        is the first plan's), found by ``stage`` (default: the calling thread's part's) from the
        plans of ``parts`` (an assembly: how many of them each stage found)."""
        at = self.elapsed()
        if self.first_plan is None:
            self.first_plan = at
        self.convergence.found(at, objective)
        if objective is not None:
            track = self.reached.track
            part = agent_names(track.part, self.reached.order or track.part)
            found = Incumbent(at, objective, stage or track.stage, part, parts or {})
            self.trace.credit(found)

    def bound_found(self, bound: float | None, force: bool = False) -> None:
        """Note a bound of the whole problem (``force``: a point even when it is not tighter)."""
        if force or self.convergence.tighter(bound):
            self.convergence.bounded(self.elapsed(), bound, force)

    def next_round(self) -> None:
        """A lazy round starts: it will be the next record of :attr:`round_log`."""
        self.round = len(self.round_log) + 1

    def record_round(self, agents: Sequence[str], seconds: float, ended: str,
                     bound: float | None, best: float | None, held: dict[str, int],
                     nodes: int | None = None) -> None:  # fmt: skip
        """Add a lazy round's record to :attr:`round_log` (the round of the part of ``agents``,
        in the stage :attr:`reached` says; ``nodes``: HiGHS's branch-and-bound nodes)."""
        finite = bound if bound is not None and math.isfinite(bound) else None
        part = agent_names(agents, self.reached.order or agents)
        self.round_log.append(
            {"round": len(self.round_log) + 1, "part": part, "stage": self.reached.stage,
             "agents": len(agents), "at": self.elapsed(), "seconds": seconds, "ended": ended,
             "bound": finite, "best": best, "held": held, "nodes": nodes}
        )  # fmt: skip
        self.reached.round_done(sum(held.values()))

    @classmethod
    def started(cls, progress: ProgressCallback | None) -> Clock:
        """A clock started now."""
        return cls(time.perf_counter(), progress)

    def elapsed(self) -> float:
        """Seconds since planning started."""
        return time.perf_counter() - self.start

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
            with self.reporting:
                self.progress(Progress(phase, self.elapsed(), incumbent, bound, gap, step_round))
        except Exception as exc:  # re-raised once HiGHS has returned
            self.error = exc
