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
asked for). Finally the parts' requirements are encoded in one model of the full problem, its
states held near the parts' plans, and one small solve sets every indicator (its objective, a
point of the full problem, is the one reported); step 2 runs on that model as usual
(:mod:`stlplan.planner.core.assembly`). The run records ``U`` whenever every part has a bound (at
the end of each round of a part, from the least bound of each part's rounds so far), and the
assembled plan's objective, as the whole problem's figures (:mod:`stlplan.planner.run.convergence`);
a part's own figures are not the whole's, unless it is a merge of every part.

With the first-plan heuristics (the policy's hooks, :mod:`stlplan.planner.core.hooks`), when the
largest part has ``parts.plan_first_agents`` agents or more, all of the above is first done for a
first plan only, in a model of the whole team of its own, before the parts go on towards their
proofs (:mod:`stlplan.planner.first_plan.hooks`). While looking for a first plan, a part's
repairs plan around the plans the parts done published (:func:`publishing`), and before parts
whose plans collide are merged, each is repaired around the others' plans. That first plan is
then improved element by element (by the hooks, within ``parts.improve_share`` of the time
left).
"""

from __future__ import annotations

import dataclasses
import threading
import time
from collections.abc import Callable, Sequence

from stlplan.mission.problem import Problem
from stlplan.planner.config import PlannerConfig
from stlplan.planner.core.around import Publisher
from stlplan.planner.core.assembly import assemble
from stlplan.planner.core.collisions import crossing_requirements
from stlplan.planner.core.hooks import FirstPlanHooks, Solved
from stlplan.planner.core.merges import merged_parts, repair_merge
from stlplan.planner.core.parts import Part, PartRounds, build_part, followed, tighten, totals
from stlplan.planner.core.policy import RepairPolicy
from stlplan.planner.core.side_by_side import in_shares, part_workers
from stlplan.planner.core.team_split import agent_parts
from stlplan.planner.core.watch import trajectory_states
from stlplan.planner.encoding.model import PlanModel, build_model
from stlplan.planner.run import outcome
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.clock import Clock
from stlplan.planner.run.outcome import Outcome, Plan
from stlplan.result import PlanStatus
from stlplan.runtime import signals

_COUNTING = threading.Lock()
"""Parts solved side by side count the planned ones one at a time."""

PartSolve = Callable[[Part, PlannerConfig, Budget], Outcome]
"""One part's solve within its share of the time, ``(part, config, budget) -> result``."""


def _combined(parts: Sequence[Part], config: PlannerConfig, clock: Clock, tick: float) -> Outcome:
    """The parts' results as one :class:`Outcome` of the full problem (started at ``tick``);
    its bound, the sum of the parts' when each has one, is recorded as the whole's."""
    steps, seconds = [p.step1 for p in parts], time.perf_counter() - tick
    rounds = len(clock.round_log)
    done = outcome.combined(steps, config.solver.gap, signals.requested(), seconds, rounds)
    clock.bound_found(done.bound)
    return done


def solve_in_shares(
    parts: Sequence[Part], config: PlannerConfig, budget: Budget, solve: PartSolve | None = None
) -> None:
    """Solve the parts not solved yet, the smallest first, each within an equal share of the
    time left but ``parts.merge_reserve`` (what one leaves goes to the next); the reserve is for
    merging parts whose plans collide, and :func:`~stlplan.planner.core.parts.tighten` spends what is left at the end on
    the part furthest from its bound. With ``parts.side_by_side`` workers, as many parts are
    solved at the same time (:mod:`stlplan.planner.core.side_by_side`). A stop request ends the loop
    before the next part.

    Parameters
    ----------
    parts
        The parts; each one without a result (``step1`` None) gets the result of its solve.
    config
        The run's configuration (``parts.merge_reserve``).
    budget
        The time the parts share.
    solve
        How one part is solved within its share (default: its first solve, a merged part
        repaired first).
    """
    solve = solve or _solve_part
    waiting = sorted((p for p in parts if p.step1 is None), key=lambda p: len(p.agents))

    def run(part: Part, share: Budget) -> None:
        part.step1 = solve(part, config, share)

    reserve = config.parts.merge_reserve
    in_shares(waiting, run, budget, reserve, part_workers(config))


def _solve_part(part: Part, config: PlannerConfig, budget: Budget) -> Outcome:
    """A part's first solve; a merged part is repaired first (module docstring)."""
    reached = part.solver.clock.reached
    reached.solving(part.agents, len(part.merged_from))
    if not part.merged_from:
        done = part.solver.run(budget)
        with _COUNTING:
            reached.planned += done.status.has_plan
        return done
    repaired = repair_merge(part, config, budget)
    _, ceiling = totals(part.merged_from)
    assert part.solver.watch is not None
    part.solver.watch.ceiling = ceiling
    if repaired is not None and config.solver.first_plan:  # a plan is all that is asked for
        return outcome.proven(repaired, ceiling, config.solver.gap) or outcome.bounded(
            repaired, ceiling
        )
    return outcome.proven(repaired, ceiling, config.solver.gap) or part.solver.run(budget)


def solve_parts(
    problem: Problem,
    config: PlannerConfig,
    clock: Clock,
    budget: Budget,
    inner: PartRounds | None = None,
    start: Plan | None = None,
    plan_first: int | None = None,
    hooks: FirstPlanHooks | None = None,
) -> tuple[PlanModel, Outcome] | None:
    """Solve step 1 part by part (module docstring) within ``budget``, each part by the lazy
    loop ``inner`` makes (default: one repairing by ``config``'s policy), each part's first solve starting from ``start`` (a plan
    of the whole team: its keys of the part's variables); None when the problem has one part.
    With the first-plan ``hooks``, when a part has ``plan_first`` agents or more, a first plan of
    the whole team comes before the parts' proofs (:mod:`stlplan.planner.first_plan.hooks`).

    Returns the full problem's model with the plan loaded (when there is one) and the result.
    """
    names = agent_parts(problem)
    if len(names) < 2:
        return None
    clock.reached.parts = len(names)
    tick = time.perf_counter()
    with clock.building():
        full = build_model(problem, config.with_overrides({"model.floors": False}))
    built = [build_part(problem, agents, config, clock, budget, inner=inner) for agents in names]
    parts = followed(built, clock)
    if start is not None:  # its agents' states and inputs; HiGHS completes the rest
        for part in parts:
            part.solver.session.start_from(start)
    early = None
    if (
        plan_first is not None
        and hooks is not None
        and hooks.plans_first(problem, config, plan_first)
    ):
        found = first_plan_of_parts(problem, parts, config, clock, budget, hooks)
        policy = None if inner is None else inner.policy
        early = _improved(problem, found, config, clock, budget, hooks, policy)
        parts = followed(parts, clock)
    gap = config.solver.gap
    parts, done = solve_apart(problem, full, parts, config, clock, budget, tick, hooks)
    if not done.status.has_plan:
        return better(early, (full, done), gap)
    if not (signals.requested() or config.solver.first_plan):
        tighten(parts, config, budget)
    if len(parts) == 1:  # merged into one part of the whole team: its model is a full one
        return better(early, (dataclasses.replace(parts[0].pm, problem=problem), done), gap)
    return better(early, (full, _whole(full, parts, config, clock, budget, tick)), gap)


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
    solve = _solve_part if published is None else publishing(published, _solve_part)
    while True:
        solve_in_shares(parts, config, budget, solve)
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
    model of its own, within ``parts.plan_first_share`` of the time
    (:mod:`stlplan.planner.first_plan.hooks`); None without one. The parts not proven are left
    to go on from their first plans: unsolved, with the requirements they added."""
    tick = time.perf_counter()
    quick = config.with_overrides({"solver.first_plan": True})
    share = budget.share(config.parts.plan_first_share)
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


def _improved(
    problem: Problem,
    early: Solved | None,
    config: PlannerConfig,
    clock: Clock,
    budget: Budget,
    hooks: FirstPlanHooks,
    policy: RepairPolicy | None,
) -> Solved | None:
    """The first plan ``early`` improved by ``hooks`` within the time left, its loops repairing
    by ``policy`` (default: ``config``'s)."""
    if early is None or signals.requested():
        return early
    policy = policy or RepairPolicy.of(config, hooks)
    return hooks.improved(problem, early, config, clock, budget, policy)


def better(first: Solved | None, second: Solved, gap: float) -> Solved:
    """The second solve when its plan is at least as good as the first's (or there is no
    first), else the first; either with the tighter bound of the two (:func:`outcome.better`)."""
    kept, done = outcome.better(None if first is None else first[1], second[1], gap,
                                signals.requested())  # fmt: skip
    if kept or first is None:
        return second[0], done
    return first[0], done


def publishing(published: Publisher | None, solve: PartSolve) -> PartSolve:
    """A part's ``solve`` whose repairs plan around the plans in ``published`` (its lazy
    solver's ``published``), and which publishes its own plan there."""

    def solved(part: Part, config: PlannerConfig, budget: Budget) -> Outcome:
        part.solver.published = published
        try:
            done = solve(part, config, budget)
        finally:
            part.solver.published = None
        if published is not None and done.status.has_plan:
            published.publish(trajectory_states(part.pm))
        return done

    return solved


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
