"""What a lazy round's plans violate, and the watch that keeps the best plan of the full problem.

A lazy model (:mod:`stlplan.planner.core.lazy`) leaves step requirements out; a plan of it is a plan
of the full problem only when it violates none of those left out. The checks here read the
plan's trajectory with numpy (:func:`stlplan.planner.encoding.deferred.violated`); the
:class:`Watch` applies them to every improving plan HiGHS reports while a round runs.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Mapping
from dataclasses import dataclass

import numpy as np
from pyomo.core.base.var import VarData
from pyomo.environ import value

from stlplan.planner.backend.progress import Searching
from stlplan.planner.backend.values import ColumnKeys, load_values, plan_of
from stlplan.planner.encoding.alphas import violated
from stlplan.planner.encoding.deferred import best_side
from stlplan.planner.encoding.model import PlanModel, assign_side
from stlplan.planner.run.outcome import Plan, VarKey, lowest
from stlplan.planner.tolerances import FEASIBILITY


def trajectory_states(pm: PlanModel) -> dict[str, np.ndarray]:
    """States ``x_p(0..H)`` of the loaded solution, agent name to an (H+1, n) array."""
    return {
        a.name: np.array([[float(value(v)) for v in row] for row in pm.states(a)])
        for a in pm.problem.agents
    }


def least_margin(pm: PlanModel) -> float:
    """The spatial margin ``r`` of ``pm`` (its lower bound when the margin is maximized)."""
    return pm.margin if isinstance(pm.margin, float) else float(pm.margin.lb)


def pending_violations(pm: PlanModel) -> list[int]:
    """Lazy requirements not in the model that the loaded plan violates (indices)."""
    assert pm.deferral is not None
    states = trajectory_states(pm)
    found = violated(pm.deferral.lazy, states, float(value(pm.margin)), FEASIBILITY)
    return [n for n in found if n not in pm.added]


def load_plan(pm: PlanModel, values: Mapping[VarKey, float], added_then: Collection[int]) -> None:
    """Load ``values``, a plan found while ``pm`` held the requirements ``added_then``; those
    added since take the side the plan meets best, so every decision agrees with it."""
    assert pm.deferral is not None
    load_values(pm.model, values)
    states = trajectory_states(pm)
    for n in set(pm.added) - set(added_then):
        assign_side(pm, n, best_side(pm.deferral.lazy[n], states))


def loaded_plan(pm: PlanModel) -> Plan | None:
    """The plan loaded in ``pm`` as a value, when it meets every requirement left out of the
    model (None otherwise)."""
    if pending_violations(pm):
        return None
    return plan_of(pm.model, pm.model.step1, pm.added)


@dataclass(eq=False)
class Watch:
    """Checks HiGHS's improving plans against the lazy requirements while a round runs.

    Attributes
    ----------
    best
        The best plan feasible for the full problem (met every requirement left out).
    abs_gap
        An absolute gap that also closes the loop (None: the relative gap only).
    ceiling
        A bound of the full problem known from elsewhere (None: HiGHS's bound only).
    stopped
        Whether the watch interrupted the round (the best plan is within the gap, or is the
        first plan and ``first`` asks for no more).
    first
        Stop at the first plan that meets every requirement.
    found
        Called with the objective of every plan kept (the run's clock, for a model of the whole
        problem).
    """

    pm: PlanModel
    columns: ColumnKeys
    gap: float
    best: Plan | None = None
    abs_gap: float | None = None
    ceiling: float | None = None
    stopped: bool = False
    first: bool = False
    found: Callable[[float], None] | None = None
    """Called with a kept plan's objective (a plan of the whole problem: the clock records it)."""
    also: Callable[[dict[str, np.ndarray]], bool] | None = None
    """A further check of a plan's states before it is kept (a repair around other parts'
    published plans: the requirements with them, :mod:`stlplan.planner.first_plan.published`)."""

    def states(self, x: np.ndarray) -> dict[str, np.ndarray]:
        """Agent states of HiGHS's column vector ``x`` (fixed states keep their value)."""
        by_id = self.columns.columns()
        out = {}
        for agent in self.pm.problem.agents:
            rows = [[_value(v, x, by_id) for v in row] for row in self.pm.states(agent)]
            out[agent.name] = np.array(rows)
        return out

    def on_plan(self, news: Searching) -> None:
        """An improving plan: keep it when it violates no requirement left out of the model."""
        assert self.pm.deferral is not None and news.objective is not None
        assert news.point is not None
        objective = news.objective
        if self.best is None or objective > self.best.objective:
            x = news.point
            margin = self.pm.margin
            by_id = self.columns.columns()
            r = margin if isinstance(margin, float) else _value(margin, x, by_id)
            states = self.states(x)
            bad = violated(self.pm.deferral.lazy, states, r, FEASIBILITY)
            if all(n in self.pm.added for n in bad) and (self.also is None or self.also(states)):
                values = self.columns.values(x)
                self.offer(Plan(objective, values, frozenset(self.pm.added)))
        self.maybe_stop(news)

    def closed(self, bound: float | None) -> bool:
        """Whether the best full plan is within the gap (relative, or absolute) of ``bound``."""
        bound = lowest(bound, self.ceiling)
        if self.best is None or bound is None:
            return False
        slack = bound - self.best.objective
        return slack <= max(self.gap * abs(self.best.objective), self.abs_gap or 0.0)

    def offer(self, plan: Plan) -> None:
        """Keep ``plan`` (one that meets every requirement) when it is the best so far."""
        if plan.better_than(self.best):
            self.best = plan
            if self.found is not None:
                self.found(plan.objective)

    def done(self) -> bool:
        """Whether the first plan is all that is asked for, and found."""
        return self.first and self.best is not None

    def maybe_stop(self, news: Searching) -> None:
        """Interrupt the round once the best full plan is within the gap of its bound."""
        self.stopped = self.stopped or self.closed(news.bound) or self.done()
        if self.stopped:
            news.stop()


def _value(var: VarData, x: np.ndarray, by_id: Mapping[int, int]) -> float:
    """``var``'s value in HiGHS's column vector ``x`` (its own value when it has no column)."""
    column = by_id.get(id(var))
    return float(var.value) if column is None else float(x[column])
