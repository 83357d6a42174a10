"""A large team's first plan improved element by element: each element planned again around all
the others, and a synchronous task's run started earlier.

A first plan of a large team (:mod:`stlplan.planner.first_plan.plan_first`) most often comes from the
repair by elements (:mod:`stlplan.planner.first_plan.by_elements`): the tasks' chosen elements planned one
after another, each around those before it. The first ones were planned as if the later ones
were not there, and the later ones go around them, so the plan spends more effort than its
choices need; and a part that found no plan alone had its synchronous task's run start later,
so the run may be shorter than the team can hold. Before the parts go on towards their proofs,
the plan's choices are written as a problem of their own again
(:func:`~stlplan.planner.first_plan.by_elements.element_problem`), whose parts (an element's agents, or an
agent no element chose) are each planned in their own model with every other part's plan as
moving obstacles (a prioritized turn, :class:`~stlplan.planner.first_plan.prioritized.Turn`):

- **sweeps**: every part planned again, those with the most effort first, a new plan kept only
  when it spends less; repeated while one lowers the team's effort;
- **earlier runs**: each synchronous task's run, while it starts after its window opens, is
  started one step earlier, the elements of its run planned again one after another. An
  element that finds no plan around the others finds one around as many of them as it can, and
  the parts still in its way are planned again after it (an ejection chain). The earlier run is
  kept when every part planned again finds a plan (one step more synchronous robustness, often
  for more effort), left as it was otherwise;

Sweeps run first, within half of ``budget.search_share`` of the improvement's time (itself
``budget.side_share`` of the time left);
then the earlier runs and, after them, sweeps again within the rest. The plans of the team after
the first sweeps and after the earlier runs are each joined in the model of the whole team,
solved once with every agent held near its plan
(:func:`~stlplan.planner.first_plan.prioritized.held_plan`); the better is taken when its objective is
higher than the first plan's.

The elements each task chose stay as they were. Every part's new plan meets every requirement
between it and the plans of all the others, so the team's plan stays a plan of the whole problem
after every accepted turn. This is a large neighbourhood search whose neighbourhoods are the
tasks' elements.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
from collections.abc import Hashable, Sequence
from dataclasses import dataclass
from typing import Any

from stlplan.mission.problem import Problem
from stlplan.planner.backend.values import effort, load_values, model_values, trajectory_values
from stlplan.planner.config import PlannerConfig
from stlplan.planner.core.lazy import LazySolver
from stlplan.planner.core.policy import RepairPolicy
from stlplan.planner.core.repairs import Rounds
from stlplan.planner.core.watch import load_plan
from stlplan.planner.encoding.model import PlanModel
from stlplan.planner.encoding.readout import chosen_run
from stlplan.planner.first_plan.by_elements import (
    Late,
    element_groups,
    element_part,
    element_problem,
)
from stlplan.planner.first_plan.overlay import States
from stlplan.planner.first_plan.prioritized import Turn, held_plan, requirements_naming
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.clock import Clock
from stlplan.planner.run.outcome import Outcome, Plan, VarKey, relative_gap
from stlplan.planner.tolerances import MONITOR
from stlplan.runtime import signals

_log = logging.getLogger(__name__)

Solved = tuple[PlanModel, Outcome]
"""A model of the whole team with its plan loaded, and the outcome of that plan."""

Found = tuple[States, dict[VarKey, float]]
"""A part's plan: its states, and its model's values."""


def improved(
    problem: Problem,
    solved: Solved,
    config: PlannerConfig,
    clock: Clock,
    budget: Budget,
    policy: RepairPolicy | None = None,
) -> Solved:
    """``solved`` (a plan of the whole team of ``problem``, loaded in its model) improved
    element by element within ``budget`` (module docstring), or as it was."""
    full, done = solved
    if done.objective is None or not done.status.has_plan:
        return solved
    elements = element_problem(problem, [full])
    if elements is None:
        return solved
    groups = element_groups(elements, config)
    if groups is None:
        return solved
    saved, before = model_values(full.model), frozenset(full.added)
    plan, taken = None, False
    try:
        with clock.reached.within("improvement by elements"):
            parted = (elements, groups)
            plan = _improved(problem, parted, full, config, clock, budget, saved, policy)
        taken = plan is not None and plan.objective > done.objective
    finally:
        if not taken:  # the first plan again, the requirements added since on its sides
            load_plan(full, saved, before)
    if plan is None or not taken:
        return solved
    clock.plan_found(plan.objective, "improvement by elements")
    gap = relative_gap(plan.objective, done.bound)
    return full, dataclasses.replace(done, objective=plan.objective, gap=gap)


def _improved(
    problem: Problem,
    parted: tuple[Problem, Sequence[tuple[str, ...]]],
    full: PlanModel,
    config: PlannerConfig,
    clock: Clock,
    budget: Budget,
    saved: dict[VarKey, float],
    policy: RepairPolicy | None,
) -> Plan | None:
    """The parts of the first plan's element problem (``parted``: it and its parts' agents)
    with their runs started earlier and planned again in sweeps, their plans joined in
    ``full``; None when neither changed a plan or the join found no plan."""
    elements, groups = parted
    whole = LazySolver(full, config, clock, policy)
    with contextlib.ExitStack() as lent:
        turns = Turns(problem, groups, full, whole, config, budget, lent)
        team = Team.of(turns.of(elements, saved))
        within = budget.share(config.budget.search_share)  # the join may take the rest
        first = sweeps(team, within.share(0.5))
        before = team.copy()
        moved = earlier_runs(team, turns, within)
        swept = sweeps(team, within) or first
        teams = [team, before] if moved and first else [team] if moved or swept else []
        return joined(whole, teams, config, budget)


def joined(
    whole: LazySolver, teams: Sequence[Team], config: PlannerConfig, budget: Budget
) -> Plan | None:
    """The best of the plans of ``teams`` each joined in the whole team's model (loaded in
    it), or None."""
    best = plan = None
    for n, team in enumerate(teams):
        if signals.requested() or (n > 0 and budget.expired()):
            break
        team.load()
        solver = whole if n == 0 else LazySolver(whole.pm, config, whole.clock, whole.policy)
        plan = held_plan(solver, team.turns, config, budget)
        if plan is not None and plan.better_than(best):
            best = plan
    if best is not None and best is not plan:
        load_plan(whole.pm, best.values, best.added)
    return best


class Turns:
    """The prioritized turns of the parts of a plan's element problems, built once per part
    and its tasks, each with its part's session lent for as long as ``lent`` lasts."""

    def __init__(
        self,
        problem: Problem,
        groups: Sequence[tuple[str, ...]],
        full: PlanModel,
        whole: LazySolver,
        config: PlannerConfig,
        budget: Budget,
        lent: contextlib.ExitStack,
    ) -> None:
        self.problem, self.groups, self.full, self.whole = problem, groups, full, whole
        self.config, self.budget, self.lent = config, budget, lent
        self.naming = requirements_naming(full)
        self.built: dict[Hashable, Rounds] = {}
        self.made: dict[int, Turn] = {}

    def of(self, elements: Problem, values: dict[VarKey, float]) -> list[Turn]:
        """The turns of ``elements``'s parts, a new part's model loaded with ``values`` (states
        of the team's current plan)."""
        states = trajectory_values(values)
        out = []
        for group in self.groups:
            part = element_part(
                elements, group, self.whole, self.config, self.budget, states, self.built
            )
            out.append(self.turn_of(part, self.config))
        return out

    def turn_of(self, part: Rounds, config: PlannerConfig) -> Turn:
        """The turn of ``part`` (a lazy loop of :func:`element_part`), made once, its session
        lent."""
        if id(part) not in self.made:
            session = self.lent.enter_context(part.lent(config.repair.gap))
            self.made[id(part)] = Turn(part.pm, session, self.full, config, self.naming)
        return self.made[id(part)]


@dataclass
class Team:
    """The parts' turns and each part's current plan: its states, its model's values, its
    effort."""

    turns: list[Any]
    plans: list[States]
    kept: list[dict[VarKey, float]]
    spent: list[float]

    @classmethod
    def of(cls, turns: Sequence[Turn]) -> Team:
        """The turns with the plans loaded in their models."""
        kept = [model_values(turn.pm.model) for turn in turns]
        return cls(
            list(turns), [dict(t.own) for t in turns], kept, [effort(t.pm.model) for t in turns]
        )

    def copy(self) -> Team:
        """The team as it is now, its lists copied."""
        return Team(list(self.turns), list(self.plans), list(self.kept), list(self.spent))

    def restore(self, was: Team) -> None:
        """The team as ``was`` (a :meth:`copy`), each part's plan loaded in its model."""
        self.turns, self.plans, self.kept, self.spent = was.turns, was.plans, was.kept, was.spent
        self.load()

    def load(self) -> None:
        """Each part's current plan loaded in its turn's model."""
        for turn, kept in zip(self.turns, self.kept, strict=True):
            load_values(turn.pm.model, kept)

    def around(self, i: int) -> States:
        """The current plans of every part but part ``i``."""
        return {a: s for j, plan in enumerate(self.plans) if j != i for a, s in plan.items()}

    def values(self) -> dict[VarKey, float]:
        """The states and inputs of the team's current plan, by variable."""
        out: dict[VarKey, float] = {}
        for kept in self.kept:
            out.update(trajectory_values(kept))
        return out

    def take(self, i: int, turn: Turn, found: States) -> None:
        """Part ``i``'s new plan ``found``, with the values ``turn``'s model holds (the plan's:
        the caller loads them)."""
        self.turns[i], self.plans[i] = turn, found
        self.kept[i], self.spent[i] = model_values(turn.pm.model), effort(turn.pm.model)


def earlier_runs(team: Team, turns: Turns, budget: Budget) -> bool:
    """Each synchronous task's run started a step earlier, and again, while the elements of its
    run and the parts then in their way all find plans (:func:`chain_moved`); whether a run was."""
    late: dict[str, int] = {}
    for sync in turns.full.synchronous:
        name, steps = sync.task.name, 1
        while not (budget.expired() or signals.requested()):
            elements = earlier(turns.problem, turns.full, name, steps, late)
            if elements is None or not chain_moved(team, turns.of(elements, team.values()), budget):
                break
            _log.debug("improvement: the run of %s starts %d step(s) earlier", name, steps)
            late[name], steps = -steps, steps + 1
    return bool(late)


def earlier(problem: Problem, full: PlanModel, name: str, steps: int, late: Late) -> Problem | None:
    """The element problem of the plan loaded in ``full`` with task ``name``'s run started
    ``steps`` steps earlier (and the other runs ``late`` steps later); None when that starts it
    before the task's window opens, or makes it longer than its synchronous robustness counts
    (``gamma``)."""
    (sync,) = (s for s in full.synchronous if s.task.name == name)
    window = sync.task.sync
    assert window is not None
    _, start, length = chosen_run(sync)
    if start - steps < window.a or length + steps - 1 - window.d > window.gamma:
        return None
    return element_problem(problem, [full], {**late, name: -steps})


def chain_moved(team: Team, turns: Sequence[Turn], budget: Budget) -> bool:
    """The parts whose turns differ from the team's planned again in ``turns`` (:func:`_chain`);
    all taken when every one finds a plan, none otherwise."""
    changed = [i for i, turn in enumerate(turns) if turn is not team.turns[i]]
    was = team.copy()
    if changed and _chain(team, turns, changed, budget):
        return True
    team.restore(was)  # and the models of the parts planned in a broken chain
    return False


def _chain(team: Team, turns: Sequence[Turn], changed: Sequence[int], budget: Budget) -> bool:
    """The parts ``changed``, one after the other, each around the plans of every part not
    waiting for its turn; a part that finds none there finds one around some of them only
    (:func:`_displacing`), and the others wait for a turn of their own, after it (an ejection
    chain). Whether every part waiting found a plan."""
    owner = {a: j for j, plan in enumerate(team.plans) for a in plan}
    waiting, planned = list(changed), set[int]()
    while waiting:
        if budget.expired() or signals.requested():
            return False
        i = waiting.pop(0)
        out = {*waiting, *changed} - planned
        settled = {a: s for a, s in team.around(i).items() if owner[a] not in out}
        found = _solved(turns[i], settled, budget)
        if found is None:
            moved = _displacing(turns[i], settled, owner, planned, budget)
            if moved is None:
                return False
            found, displaced = moved
            _log.debug("improvement: parts %s in the way of %s", displaced, sorted(turns[i].agents))
            waiting += displaced
        load_values(turns[i].pm.model, found[1])
        team.take(i, turns[i], found[0])
        planned.add(i)
    return True


def _displacing(
    turn: Turn, settled: States, owner: dict[str, int], planned: set[int], budget: Budget
) -> tuple[Found, list[int]] | None:
    """``turn``'s part planned around the parts ``planned`` and as many other parts of
    ``settled`` as it can: the parts its plan around the planned ones only is in the way of
    taken back one at a time, each kept when a plan around it exists. The plan, and the parts
    whose plans it is in the way of (not of ``planned``); None without a plan."""
    kept = {a: s for a, s in settled.items() if owner[a] in planned}
    found = _solved(turn, kept, budget)
    if found is None:
        return None
    for j in sorted({owner[a] for a in turn.in_the_way(found[0], settled)}):
        if budget.expired() or signals.requested():
            break
        tried = {**kept, **{a: s for a, s in settled.items() if owner[a] == j}}
        better = _solved(turn, tried, budget)
        if better is not None:
            found, kept = better, tried
    return found, sorted({owner[a] for a in turn.in_the_way(found[0], settled)} - planned)


def _solved(turn: Turn, fixed: States, budget: Budget) -> Found | None:
    """``turn``'s part planned around ``fixed``, or None (its model's values then stale)."""
    found = turn.solve(fixed, budget)
    turn.clear()
    return None if found is None else (found, model_values(turn.pm.model))


def sweeps(team: Team, budget: Budget) -> bool:
    """Each part planned again around all the others' plans, the most effort first, a new plan
    kept when it spends less; sweeps while one lowers the effort. Whether any did (the turns'
    models then hold the kept plans)."""
    order = sorted(range(len(team.turns)), key=lambda i: -team.spent[i])
    lowered = False
    while not (budget.expired() or signals.requested()):
        gained = 0.0
        for i in order:
            if budget.expired() or signals.requested():
                break
            turn, spent = team.turns[i], team.spent[i]
            found = turn.solve(team.around(i), budget)
            turn.clear()
            now = effort(turn.pm.model) if found is not None else None
            if found is not None and now is not None and now < spent - MONITOR:
                gained += spent - now
                team.take(i, turn, found)
            else:
                load_values(turn.pm.model, team.kept[i])
        lowered = lowered or gained > 0
        if gained <= 0:
            break
    return lowered
