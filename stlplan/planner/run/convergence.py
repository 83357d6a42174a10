"""The whole problem's incumbent and bound over step 1 (``summary.json``'s ``convergence``).

Problem (step1) maximizes ``t - beta * sum s (+ w * r)``: an incumbent bounds its optimum from
below, a bound from above, and a point of the record holds only figures of the whole problem
(every agent, every requirement), each known by the point's time.

The whole team's model is step 1's model of every agent (:func:`stlplan.planner.core.lazy.solve_step1`),
or a part that merges every part (:mod:`stlplan.planner.core.components`): the same problem.

Incumbents: the objective of a plan that meets every requirement of the whole problem.

* The plans the watch of the whole team's lazy model keeps (:class:`~stlplan.planner.core.watch.Watch`):
  HiGHS's improving plans that violate no requirement left out of the model, and the plans
  offered to it by a repair in turn or a completion. Those may come from trial solves: a trial
  holds agents near a plan or fixes binaries, which restricts the problem and relaxes none of
  its requirements, so a plan it finds that the watch accepts is a plan of the whole problem.
* HiGHS's improving plans of the whole team's model holding every requirement (no lazy rounds).
* The plan step 1 ends with, and with parts, the parts' plans assembled in one model of the whole
  team (:func:`stlplan.planner.core.assembly.assemble`). The sum of the parts' objectives before
  that is not recorded: a part's plan may meet its decisions only within HiGHS's tolerances, and
  the assembly then fails.

Bounds: a proven upper bound on the whole problem's optimum.

* HiGHS's dual bound while the whole team's model is solved, outside trials: a lazy round's model
  holds a subset of the requirements, so it is a relaxation and its bound bounds the whole
  optimum (:mod:`stlplan.planner.core.lazy`); a solve confirming an infeasible verdict solves the same
  model. The bound each lazy round ends with, recorded at the round's end.
* The sum of the parts' bounds once every part has one: the objective is a sum of one term per
  part, and the whole problem's plans restricted to a part are plans of that part (the requirements
  between parts only remove plans), so the whole optimum is at most the sum of the parts' optima
  (:mod:`stlplan.planner.core.components`). Recorded at the end of every round of a part, each part
  counting the least bound of its rounds so far (each a relaxation of the part, or for a merged
  part before its first round the sum of the bounds of the parts it merges), and whenever the
  parts' results are combined.
* The bound step 1 ends with (its ``bound`` in ``summary.json``).

Never recorded: the bound of a trial solve (:attr:`stlplan.planner.backend.session.HighsSession.trial`:
a repair in turn or a held repair holds agents near a plan, a completion fixes binaries) nor of
the assembly's solve (its states held near the parts' plans): each bounds a restricted problem
only. Nor a part's own bound or plan alone, HiGHS's incumbent of a lazy model (it may violate a
requirement left out), or any figure of the continuous stage (another objective, decisions fixed).

A strict retry of step 1 (:mod:`stlplan.planner.solve`) solves the problem again because the
first plan met its decisions only within HiGHS's integrality tolerance: the incumbent starts
over (the bounds still hold), and the last point holds the plan the run reports.

The record is thinned: a point at every new incumbent, at every end of a round of the whole
team, at the end of step 1, and for a tighter bound alone at most one every
:data:`THIN_SECONDS`; a figure better by round-off only (:data:`ROUND_OFF`) adds none. Each
point holds the best incumbent and bound known at its time (up to that round-off), the last
one exactly step 1's plan and its least bound.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TypeGuard

from stlplan.planner.tolerances import ROUND_OFF
from stlplan.result import ConvergencePoint

THIN_SECONDS = 0.5
"""Least time between two points that record a tighter bound alone (and between two progress
reports of HiGHS's search without a new incumbent)."""

LARGEST = 1e30
"""HiGHS's figures at or beyond this size are infinite (no incumbent or bound yet)."""


def known(value: float | None) -> TypeGuard[float]:
    """Whether ``value`` is a finite figure (HiGHS writes ``inf`` or ``1e30`` for none)."""
    return value is not None and math.isfinite(value) and abs(value) < LARGEST


def beyond(value: float, than: float | None) -> bool:
    """Whether ``value`` exceeds ``than`` (any value exceeds None) by more than round-off."""
    return than is None or value - than > ROUND_OFF * max(1.0, abs(than))


@dataclass
class Convergence:
    """The record of the module docstring: the best incumbent and bound so far, and the points.

    Attributes
    ----------
    points
        The points recorded, in time order.
    incumbent, bound
        The best incumbent and the least bound known (None: none yet).
    """

    points: list[ConvergencePoint] = field(default_factory=list)
    incumbent: float | None = None
    bound: float | None = None
    _pending: ConvergencePoint | None = None
    """A tighter bound thinned out, written before the next point."""

    def tighter(self, bound: float | None) -> bool:
        """Whether ``bound`` is known and below the least bound so far (beyond round-off)."""
        return known(bound) and (self.bound is None or beyond(-bound, -self.bound))

    def found(self, at: float, objective: float | None) -> None:
        """A plan of the whole problem with ``objective`` found at ``at``: a point when better
        (beyond round-off)."""
        if known(objective) and beyond(objective, self.incumbent):
            self.incumbent = objective
            self._add(at)

    def bounded(self, at: float, bound: float | None, force: bool = False) -> None:
        """A bound of the whole problem at ``at``: a point when tighter and the last point is
        :data:`THIN_SECONDS` old, or when ``force`` (the end of a round)."""
        if self.tighter(bound):
            self.bound = bound
            last = self.points[-1].at if self.points else -math.inf
            if not force and at - last < THIN_SECONDS:
                self._pending = self._point(at)
                return
            self._pending = None
            self._add(at)
        elif force:
            self._add(at)

    def restart(self, at: float) -> None:
        """Forget the incumbent (a strict retry: module docstring); the bound stays."""
        if self.incumbent is not None:
            self.incumbent = None
            self._add(at)

    def ended(self, at: float, objective: float | None, bound: float | None) -> None:
        """Step 1 ended with a plan of ``objective`` (None: none) and ``bound``: the last point
        holds that plan's objective and the least bound."""
        if known(bound) and (self.bound is None or bound < self.bound):
            self.bound = bound
        self.incumbent = objective if known(objective) else None
        self._add(at)

    def _point(self, at: float) -> ConvergencePoint:
        return ConvergencePoint(at, self.incumbent, self.bound)

    def _add(self, at: float) -> None:
        """Write the pending point, then one at ``at`` (none with neither figure known)."""
        if self._pending is not None:
            self.points.append(self._pending)
            self._pending = None
        if self.incumbent is not None or self.bound is not None:
            self.points.append(self._point(at))
