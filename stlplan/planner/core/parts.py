"""The independent parts of a team as they are solved: each part's model, lazy solver and result.

:mod:`stlplan.planner.core.components` solves each part on its own (its docstring lists the links);
:mod:`stlplan.planner.core.team_split` says which agents make a part.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

from stlplan.mission.problem import Problem
from stlplan.planner.backend.values import plan_of
from stlplan.planner.config import PlannerConfig
from stlplan.planner.core.lazy import LazySolver
from stlplan.planner.core.policy import RepairPolicy
from stlplan.planner.core.team_split import sub_problem
from stlplan.planner.core.watch import load_plan
from stlplan.planner.encoding.deferred import Deferral, requirement_key
from stlplan.planner.encoding.model import PlanModel, add_requirements, build_model
from stlplan.planner.run import outcome
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.clock import Clock
from stlplan.planner.run.outcome import Outcome, Plan


class Strategy(Protocol):
    """A way to solve step 1 (:mod:`stlplan.planner.strategy` composes them)."""

    def solve(
        self,
        problem: Problem,
        config: PlannerConfig,
        clock: Clock,
        budget: Budget,
        start: Plan | None = None,
    ) -> tuple[PlanModel, Outcome]:
        """The model of ``problem`` with the plan loaded, and how step 1 ended; the first solve
        starts from ``start`` when given."""
        ...

    def describe(self) -> str:
        """The strategy in words."""
        ...


class PartRounds(Strategy, Protocol):
    """The strategy inside the parts (:class:`~stlplan.planner.strategy.LazyRounds`): it makes
    each part's lazy loop, which repairs by its policy, and solves a team alone."""

    @property
    def policy(self) -> RepairPolicy:
        """How the loops repair."""
        ...

    def rounds(
        self, pm: PlanModel, config: PlannerConfig, clock: Clock, whole: bool = False
    ) -> LazySolver:
        """The lazy loop of ``pm`` (``whole``: a model of the whole team)."""
        ...


@dataclass(eq=False)
class Part:
    """One part: its agents, model, lazy solver and last result; ``inner`` made its solver
    (None: a loop repairing by the configuration's policy)."""

    agents: tuple[str, ...]
    pm: PlanModel
    solver: LazySolver
    inner: PartRounds | None = None
    step1: Outcome | None = None
    merged_from: tuple[Part, ...] = ()
    free: frozenset[str] = frozenset()
    team: int | None = None  # a merged part's: the whole team's agents


def build_part(
    problem: Problem,
    agents: Sequence[str],
    config: PlannerConfig,
    clock: Clock,
    budget: Budget,
    seed: set[tuple[Any, ...]] = frozenset(),  # type: ignore[assignment]
    inner: PartRounds | None = None,
    deferral: Deferral | None = None,
) -> Part:
    """Build (and seed with known requirements) the lazy model of one part, its loop made by
    ``inner`` (reusing ``deferral``, the split of the requirements of a part of the same
    agents, when given)."""
    sub = sub_problem(problem, agents)
    with clock.building():
        pm = build_model(sub, config, budget.share(config.budget.side_share).deadline, deferral)
    assert pm.deferral is not None
    add_requirements(pm, [n for n, r in enumerate(pm.deferral.lazy) if requirement_key(r) in seed])
    whole = len(sub.agents) == len(problem.agents)  # a merge of every part: the whole problem
    if inner is None:
        return Part(tuple(agents), pm, LazySolver(pm, config, clock, whole=whole))
    return Part(tuple(agents), pm, inner.rounds(pm, config, clock, whole), inner)


def totals(parts: Sequence[Part]) -> tuple[float | None, float | None]:
    """The sums of the parts' objectives and of their bounds (None: a part has none)."""
    return outcome.totals([p.step1 for p in parts])


def tighten(
    parts: Sequence[Part],
    config: PlannerConfig,
    budget: Budget,
    plan: float | None = None,
    together: Callable[[], bool] | None = None,
) -> None:
    """Solve parts again with absolute gaps until their sum (or ``plan``, a plan of the parts
    together) meets the gap (:func:`stlplan.planner.run.outcome.tightening`), while at least one
    least solve of ``budget`` is left.

    With ``together`` (whether the plans the parts hold now still make a plan of the whole: no
    requirement between them broken), a part whose new plan fails it gets its plan from before
    back, with the tighter of the two bounds, and the tightening ends."""
    for _ in range(len(parts)):
        if budget.expired():
            return
        chosen = outcome.tightening([p.step1 for p in parts], config.solver.gap, plan)
        if chosen is None:
            return
        worst, abs_gap = chosen
        part = parts[worst]
        before = part.step1, plan_of(part.pm.model, part.pm.model.step1, part.pm.added)
        reached = part.solver.clock.reached
        reached.solving(part.agents, len(part.merged_from))
        with reached.within("tightening"):
            part.step1 = part.solver.run(budget, abs_gap=abs_gap)
        if together is not None and not together():
            _restore(part, *before, config.solver.gap)
            return


def _restore(part: Part, step1: Outcome | None, kept: Plan, gap: float) -> None:
    """Load ``kept`` back into ``part`` with ``step1``, its result, bounded by the part's
    latest result too."""
    load_plan(part.pm, kept.values, kept.added)
    latest, part.step1 = part.step1, step1
    if step1 is None or latest is None:
        return
    bound = outcome.lowest(step1.bound, latest.bound)
    found = outcome.relative_gap(step1.objective, bound)
    part.step1 = outcome.capped(step1, bound, found is not None and found <= gap)


def followed(parts: list[Part], clock: Clock) -> list[Part]:
    """``parts``, each recording on ``clock`` at the end of its every round the sum of the
    parts' least bounds so far (each part's lazy rounds: relaxations of it), once every part
    has one: a bound of the whole problem."""

    def record() -> None:
        ceilings = [p.solver.watch.ceiling for p in parts if p.solver.watch is not None]
        bounds = [c for c in ceilings if c is not None]
        if len(bounds) == len(parts):
            clock.bound_found(sum(bounds))

    for part in parts:
        part.solver.rounded = record
    return parts
