"""Step 1 by independent components: agents that no task, constraint or objective term links.

With obstacle and collision avoidance left out (lazy), problem (step1) often falls apart: in the
farm cases the UV and IR agents serve crops A and B while the Vis agents serve crop C, and the
objective ``t - beta * sum_p e_p`` is a sum of one term per part (``t`` belongs to the part with
the synchronous tasks). HiGHS proves such a sum far more slowly than each part alone (a node's
bound closes only when every part's does), so each part has its own lazy loop. Parts are linked by

* a task: every agent that can serve one of its elements (the group choice couples them);
* the synchronous tasks together (``t = min_l rho_s^l``);
* a constraint binding with several agents;
* a maximized spatial margin (then there is one part);
* a collision requirement between agents of two parts that the combined plan violates: the two
  parts are merged and solved again, starting with the requirements both had added.

A merged part's optimum is at most ``U_m``, the sum of its parts' bounds (merging only adds
requirements). It is first *repaired*: solved with every agent but those of the colliding pairs
held near the parts' plans, a small problem. When they name a crowd (``repair.crowd_agents``,
in a team of ``repair.crowd_team``), it is not: the parts' plans are first repaired agent by agent
(:mod:`stlplan.planner.core.in_turn`), and the crossing requirements are left out of the merged model
until a turn's plan violates them (a turn needs a model that the plan it starts from meets). A
repaired plan within the gap of ``U_m`` is the merged part's optimum; otherwise it is the first
plan of the merged part's own solve, which stops as soon as a plan is within the gap of ``U_m``
or of its own bound.

With no such violation left, the union of the parts' plans is feasible for the full problem and its
objective is the sum ``F = sum_c F_c``, while ``U = sum_c U_c`` bounds the full optimum. A part is
solved again with an absolute gap while ``(U - F) / |F|`` exceeds the gap, so the result is the
full problem's optimum to the same tolerance as one solve (with ``solver.first_plan`` neither
this nor a merged part's own solve after a repair that found a plan: a plan is all that is
asked for). A part whose new plan breaks a requirement with another part's plan gets its plan
from before back, with the new bound, and the tightening ends (short of the gap, then). Finally
the parts' requirements are encoded in one model of the full problem, its states held near the
parts' plans, and one small solve sets every indicator (its objective, a point of the full
problem, is the one reported); step 2 runs on that model as usual
(:mod:`stlplan.planner.core.assembly`). The run records ``U`` whenever every part has a bound (at
the end of each round of a part, from the least bound of each part's rounds so far), and the
assembled plan's objective, as the whole problem's figures (:mod:`stlplan.planner.run.convergence`);
a part's own figures are not the whole's, unless it is a merge of every part.

With the first-plan heuristics (the policy's hooks, :mod:`stlplan.planner.core.hooks`), when the
largest part has ``parts.plan_first_agents`` agents or more, all of the above is first done for a
first plan only, in a model of the whole team of its own, before the parts go on towards their
proofs (:mod:`stlplan.planner.first_plan.hooks`). While looking for a first plan, a part's
repairs plan around the plans the parts done published (:func:`_solve_part`), and before parts
whose plans collide are merged, each is repaired around the others' plans. That first plan is
then improved element by element (by the hooks, within ``budget.side_share`` of the time
left).
"""

from __future__ import annotations

import dataclasses
import functools
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from stlplan.mission.problem import Problem
from stlplan.planner.config import PlannerConfig
from stlplan.planner.core.around import Publisher
from stlplan.planner.core.assembly import assemble
from stlplan.planner.core.collisions import crossing_requirements
from stlplan.planner.core.hooks import FirstPlanHooks, Solved
from stlplan.planner.core.merges import merge_repaired, merge_repairs, merged_parts
from stlplan.planner.core.parts import Part, PartRounds, build_part, followed, tighten, totals
from stlplan.planner.core.side_by_side import in_shares, part_workers
from stlplan.planner.core.team_split import agent_parts
from stlplan.planner.core.watch import trajectory_states
from stlplan.planner.encoding.model import PlanModel, build_model
from stlplan.planner.run import outcome
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.clock import Clock
from stlplan.planner.run.outcome import ASSEMBLY_FAILED, Outcome, Plan
from stlplan.result import PlanStatus
from stlplan.runtime import signals

_COUNTING = threading.Lock()
"""Parts solved side by side count the planned ones one at a time."""

PartSolve = Callable[[Part, Budget], Outcome]
"""One part's first solve within its share of the time, ``(part, share) -> result``."""


def _combined(parts: Sequence[Part], config: PlannerConfig, clock: Clock, tick: float) -> Outcome:
    """The parts' results as one :class:`Outcome` of the full problem (started at ``tick``);
    its bound, the sum of the parts' when each has one, is recorded as the whole's."""
    steps, seconds = [p.step1 for p in parts], time.perf_counter() - tick
    rounds = len(clock.round_log)
    done = outcome.combined(steps, config.solver.gap, signals.requested(), seconds, rounds)
    clock.bound_found(done.bound)
    return done


def waiting(parts: Sequence[Part]) -> list[Part]:
    """The parts not solved yet, the smallest first: the order of their first solves, each
    within an equal share of the time left but ``parts.merge_reserve`` (what one leaves goes to
    the next). The reserve is for merging parts whose plans collide, and
    :func:`~stlplan.planner.core.parts.tighten` spends what is left at the end on the part
    furthest from its bound. With ``parts.side_by_side`` workers, as many parts are solved at
    the same time (:mod:`stlplan.planner.core.side_by_side`)."""
    return sorted((p for p in parts if p.step1 is None), key=lambda p: len(p.agents))


def _solve_part(
    part: Part, budget: Budget, config: PlannerConfig, published: Publisher | None = None
) -> Outcome:
    """A part's first solve; a merged part is repaired first (module docstring). Its repairs
    plan around the plans in ``published``, and a plan it finds is published there."""
    solver, reached = part.solver, part.solver.clock.reached
    reached.solving(part.agents, len(part.merged_from))
    solver.published = published
    try:
        if not part.merged_from:
            done = solver.run(budget)
            with _COUNTING:
                reached.planned += done.status.has_plan
        else:  # the repairs the policy names, in order, until one plans the merge
            tick, repaired = time.perf_counter(), None
            broken, repairs = merge_repairs(part, config)
            for repair, share in repairs:
                plan = repair.repair(broken, config, budget.share(share))
                if plan is not None:
                    repaired = merge_repaired(part, plan, config, budget, tick)
                    break
            done = _merge_proven(part, repaired, config, budget)
    finally:
        solver.published = None
    if published is not None and done.status.has_plan:
        published.publish(trajectory_states(part.pm))
    return done


def _merge_proven(
    part: Part, repaired: Outcome | None, config: PlannerConfig, budget: Budget
) -> Outcome:
    """A merged part's result from its ``repaired`` plan (None: none) and the bounds of the
    parts it comes from, or from its own rounds."""
    _, ceiling = totals(part.merged_from)
    assert part.solver.watch is not None
    part.solver.watch.ceiling = ceiling
    proven = outcome.proven(repaired, ceiling, config.solver.gap)
    if repaired is not None and config.solver.first_plan:  # a plan is all that is asked for
        return proven or outcome.bounded(repaired, ceiling)
    return proven or part.solver.run(budget)


@dataclass(frozen=True)
class Parts:
    """Independent parts solved apart by ``inner``, merged where their plans collide (module
    docstring); a first plan before the parts' proofs when a part has ``plan_first`` agents or
    more and the first-plan ``hooks`` say so. A team of one part, or one whose parts' plans do
    not assemble into a plan of the whole, is solved whole by ``inner``."""

    inner: PartRounds
    plan_first: int | None = None
    hooks: FirstPlanHooks | None = None

    def solve(
        self,
        problem: Problem,
        config: PlannerConfig,
        clock: Clock,
        budget: Budget,
        start: Plan | None = None,
    ) -> Solved:
        """The full problem's model with the plan loaded (when there is one) and the result;
        each part's first solve starts from ``start`` (its keys of the part's variables)."""
        names = agent_parts(problem)
        if len(names) < 2:
            return self.inner.solve(problem, config, clock, budget, start)
        clock.reached.parts, tick = len(names), time.perf_counter()
        with clock.building():
            full = build_model(problem, config.with_overrides({"model.floors": False}))
        parts = [
            build_part(problem, agents, config, clock, budget, inner=self.inner) for agents in names
        ]
        for part in followed(parts, clock):
            if start is not None:  # its agents' states and inputs; HiGHS completes the rest
                part.solver.session.start_from(start)
        early = self._first_plan(problem, parts, config, clock, budget)
        parts, done = solve_apart(problem, full, parts, config, clock, budget, tick, self.hooks)
        if not done.status.has_plan:
            return better(early, (full, done), config.solver.gap)
        if not (signals.requested() or config.solver.first_plan):
            together = functools.partial(_together, full, parts)
            tighten(parts, config, budget, together=together)
        if len(parts) == 1:  # merged into one part of the whole team: its model is a full one
            whole = dataclasses.replace(parts[0].pm, problem=problem)
            return better(early, (whole, done), config.solver.gap)
        found = better(
            early, (full, _whole(full, parts, config, clock, budget, tick)), config.solver.gap
        )
        if found[1].stop == ASSEMBLY_FAILED and not budget.expired():
            return self.inner.solve(problem, config, clock, budget, start)  # no plan of the whole
        return found

    def _first_plan(
        self,
        problem: Problem,
        parts: list[Part],
        config: PlannerConfig,
        clock: Clock,
        budget: Budget,
    ) -> Solved | None:
        """A first plan of the whole team, improved, before the parts' proofs (None: not
        looked for, or none)."""
        hooks, least = self.hooks, self.plan_first
        if least is None or hooks is None or not hooks.plans_first(problem, config, least):
            return None
        found = first_plan_of_parts(problem, parts, config, clock, budget, hooks)
        if found is not None and not signals.requested():
            found = hooks.improved(problem, found, config, clock, budget, self.inner.policy)
        followed(parts, clock)
        return found

    def describe(self) -> str:
        repair = self.inner.policy.repair
        ordered = ["prioritized"] if repair.orders else []
        ordered += [] if repair.by_elements is None else ["by elements before a first plan"]
        crowd, first = repair.crowd_agents, "".join(f"{w}, " for w in [" or ".join(ordered)] if w)
        team = "" if repair.crowd_team is None else f" of a team >= {repair.crowd_team}"
        merge = f"{first}in turn if >= {crowd} agents{team}, held" if crowd is not None else "held"
        early = "" if self.plan_first is None else f"; plan first if >= {self.plan_first} agents"
        after = "" if self.hooks is None else self.hooks.describe()
        early += f", {after}" if early and after else ""
        return f"parts({self.inner.describe()}; merge: {merge}{early})"


def solve_apart(
    problem: Problem,
    full: PlanModel,
    parts: list[Part],
    config: PlannerConfig,
    clock: Clock,
    budget: Budget,
    tick: float,
    hooks: FirstPlanHooks | None,
) -> tuple[list[Part], Outcome]:
    """Solve the parts in shares, merging those whose plans collide, until none do (or one
    has no plan); the parts and their combined outcome. With the first-plan ``hooks``, the parts
    publish their plans and colliding parts are repaired around each other's before a merge."""
    published = None if hooks is None else hooks.publisher(full, config)
    solve: PartSolve = functools.partial(_solve_part, config=config, published=published)
    workers, reserve = part_workers(config), config.parts.merge_reserve
    while True:
        first = waiting(parts)
        solved = in_shares(first, solve, budget, reserve, workers)
        for part, step1 in zip(first, solved, strict=True):
            part.step1 = step1  # (None: not solved, a stop request)
        done = _combined(parts, config, clock, tick)
        if not done.status.has_plan:  # the message names a part without a plan
            failed = [p.agents for p in parts if p.step1 is None or not p.step1.status.has_plan]
            clock.reached.follow(failed[0] if failed else ())
            return parts, done
        crossing = crossing_requirements(full, parts)
        if hooks is not None and hooks.before_merge(
            full, parts, crossing, published, config, budget
        ):
            done = _combined(parts, config, clock, tick)
            crossing = crossing_requirements(full, parts)
        if not crossing:
            return parts, done
        if signals.requested():  # the parts' plans collide: no plan of the full problem
            return parts, dataclasses.replace(done, status=PlanStatus.INTERRUPTED_NO_PLAN)
        parts = merged_parts(problem, parts, crossing, config, clock, budget, full.deferral)


def _together(full: PlanModel, parts: Sequence[Part]) -> bool:
    """Whether the parts' plans break no requirement between them (a tightened part's may)."""
    return not crossing_requirements(full, parts)


def _whole(
    full: PlanModel,
    parts: Sequence[Part],
    config: PlannerConfig,
    clock: Clock,
    budget: Budget,
    tick: float,
) -> Outcome:
    """The parts' plans assembled in ``full`` as the outcome of the whole problem."""
    done = _combined(parts, config, clock, tick)
    objective = assembled_objective(full, parts, config, clock, budget)
    seconds = time.perf_counter() - tick
    stopped = signals.requested()
    return outcome.assembled(done, objective, config.solver.gap, stopped, seconds)


def first_plan_of_parts(
    problem: Problem,
    parts: list[Part],
    config: PlannerConfig,
    clock: Clock,
    budget: Budget,
    hooks: FirstPlanHooks,
) -> Solved | None:
    """A plan of the whole team from the parts' first plans, merged where they collide, in a
    model of its own, within ``budget.search_share`` of the time
    (:mod:`stlplan.planner.first_plan.hooks`); None without one. The parts not proven are left
    to go on from their first plans: unsolved, with the requirements they added."""
    tick = time.perf_counter()
    quick = config.with_overrides({"solver.first_plan": True})
    share = budget.share(config.budget.search_share)
    with clock.building():
        full = build_model(problem, config.with_overrides({"model.floors": False}))
    _stop_at_first_plans(parts, True)
    try:
        merged, done = solve_apart(problem, full, parts, quick, clock, share, tick, hooks)
        found = _whole(full, merged, quick, clock, share, tick) if done.status.has_plan else None
    finally:
        _stop_at_first_plans(parts, False)
    for part in parts:
        if part.step1 is not None and part.step1.status is not PlanStatus.OPTIMAL:
            part.step1 = None
    return (full, found) if found is not None and found.status.has_plan else None


def better(first: Solved | None, second: Solved, gap: float) -> Solved:
    """The second solve when its plan is at least as good as the first's (or there is no
    first), else the first; either with the tighter bound of the two (:func:`outcome.better`)."""
    kept, done = outcome.better(None if first is None else first[1], second[1], gap,
                                signals.requested())  # fmt: skip
    if kept or first is None:
        return second[0], done
    return first[0], done


def _stop_at_first_plans(parts: Sequence[Part], first: bool) -> None:
    """Make the parts' lazy loops stop at their first plan meeting every requirement, or not."""
    for part in parts:
        part.solver.stop_at_first_plan(first)


def assembled_objective(
    full: PlanModel, parts: Sequence[Part], config: PlannerConfig, clock: Clock, budget: Budget
) -> float | None:
    """The parts' plans assembled in ``full`` (:func:`assemble`, a finishing solve of the whole
    team); its objective, or None."""
    clock.reached.solving([a.name for a in full.problem.agents])
    with clock.reached.within("assembly"):
        objective = assemble(full, [p.pm for p in parts], config, clock, budget.finishing())
        if objective is None:
            clock.reached.failed("assembly")
    if objective is not None:
        parts_agents = [[a.name for a in p.pm.problem.agents] for p in parts]
        clock.plan_found(objective, "assembly", clock.reached.sources(parts_agents))
    return objective
