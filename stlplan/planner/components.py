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
(:mod:`stlplan.planner.in_turn`), and the crossing requirements are left out of the merged model
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
(:mod:`stlplan.planner.assembly`). The run records ``U`` whenever every part has a bound (at
the end of each round of a part, from the least bound of each part's rounds so far), and the
assembled plan's objective, as the whole problem's figures (:mod:`stlplan.planner.convergence`);
a part's own figures are not the whole's, unless it is a merge of every part.

When the largest part has ``parts.plan_first_agents`` agents or more, all of the above is first
done for a first plan only, in a model of the whole team of its own, before the parts go on
towards their proofs (:mod:`stlplan.planner.plan_first`). While looking for a first plan, a
part's repairs plan around the plans of the parts done (:mod:`stlplan.planner.published`).
"""

from __future__ import annotations

import dataclasses
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from stlplan.mission.problem import Problem
from stlplan.planner import outcome
from stlplan.planner.assembly import added_keys, assemble, plan_values
from stlplan.planner.budget import Budget
from stlplan.planner.clock import Clock
from stlplan.planner.collisions import crossing_requirements, merge_groups
from stlplan.planner.config import PlannerConfig
from stlplan.planner.encoding.alphas import violated
from stlplan.planner.encoding.deferred import Requirement, requirement_key
from stlplan.planner.encoding.model import PlanModel, add_requirements, build_model
from stlplan.planner.lazy import LazySolver
from stlplan.planner.outcome import Outcome, Plan
from stlplan.planner.parts import agent_parts, sub_problem
from stlplan.planner.plan_first import Solved, better, plans_first
from stlplan.planner.published import published_for, publishing
from stlplan.planner.repair_policy import RepairPolicy
from stlplan.planner.repairs import Broken
from stlplan.planner.side_by_side import in_shares, part_workers
from stlplan.planner.watch import VIOLATION_TOL, least_margin, trajectory_states
from stlplan.result import PlanStatus
from stlplan.runtime import signals


@dataclass(eq=False)
class Part:
    """One part: its agents, model, lazy solver and last result."""

    agents: tuple[str, ...]
    pm: PlanModel
    solver: LazySolver
    step1: Outcome | None = None
    merged_from: tuple[Part, ...] = ()
    free: frozenset[str] = frozenset()
    team: int | None = None  # a merged part's: the whole team's agents


_COUNTING = threading.Lock()
"""Parts solved side by side count the planned ones one at a time."""

PartSolve = Callable[[Part, PlannerConfig, Budget], Outcome]
"""One part's solve within its share of the time, ``(part, config, budget) -> result``."""


def _part(
    problem: Problem,
    agents: Sequence[str],
    config: PlannerConfig,
    clock: Clock,
    budget: Budget,
    seed: set[tuple[Any, ...]] = frozenset(),  # type: ignore[assignment]
    policy: RepairPolicy | None = None,
) -> Part:
    """Build (and seed with known requirements) the lazy model of one part."""
    sub = sub_problem(problem, agents)
    with clock.building():
        pm = build_model(sub, config, budget.share(config.model.floors_share).deadline)
    assert pm.deferral is not None
    add_requirements(pm, [n for n, r in enumerate(pm.deferral.lazy) if requirement_key(r) in seed])
    whole = len(sub.agents) == len(problem.agents)  # a merge of every part: the whole problem
    return Part(tuple(agents), pm, LazySolver(pm, config, clock, policy, whole))


def _totals(parts: Sequence[Part]) -> tuple[float | None, float | None]:
    return outcome.totals([p.step1 for p in parts])


def _tighten(
    parts: Sequence[Part], config: PlannerConfig, budget: Budget, plan: float | None = None
) -> None:
    """Solve parts again with absolute gaps until their sum (or ``plan``, a plan of the parts
    together) meets the gap (:func:`stlplan.planner.outcome.tightening`), while at least one
    least solve of ``budget`` is left."""
    for _ in range(len(parts)):
        if budget.expired():
            return
        chosen = outcome.tightening([p.step1 for p in parts], config.solver.gap, plan)
        if chosen is None:
            return
        worst, abs_gap = chosen
        part = parts[worst]
        reached = part.solver.clock.reached
        reached.solving(part.agents, len(part.merged_from))
        with reached.within("tightening"):
            part.step1 = part.solver.run(budget, abs_gap=abs_gap)


def _followed(parts: list[Part], clock: Clock) -> list[Part]:
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
    merging parts whose plans collide, and :func:`_tighten` spends what is left at the end on
    the part furthest from its bound. With ``parts.side_by_side`` workers, as many parts are
    solved at the same time (:mod:`stlplan.planner.side_by_side`). A stop request ends the loop
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
    repaired = _repair(part, config, budget)
    _, ceiling = _totals(part.merged_from)
    assert part.solver.watch is not None
    part.solver.watch.ceiling = ceiling
    if repaired is not None and config.solver.first_plan:  # a plan is all that is asked for
        return outcome.proven(repaired, ceiling, config.solver.gap) or outcome.bounded(
            repaired, ceiling
        )
    return outcome.proven(repaired, ceiling, config.solver.gap) or part.solver.run(budget)


def _repair(part: Part, config: PlannerConfig, budget: Budget) -> Outcome | None:
    """Repair the parts' plans together by the repairs the policy names for the merge (module
    docstring); then tighten the bounds of the parts the merged part comes from towards the
    repaired plan (None: no plan)."""
    tick = time.perf_counter()
    broken = _broken(part)
    largest = max(len(p.pm.problem.agents) for p in part.merged_from)
    first = config.solver.first_plan
    repairs = part.solver.policy.merge_repairs(len(part.free), largest, part.team, first)
    for repair, share in repairs:
        plan = repair.repair(broken, config, budget.share(share))
        if plan is not None:
            repaired = part.solver.repaired(plan, time.perf_counter() - tick)
            _tighten(part.merged_from, config, budget, plan=repaired.objective)
            return repaired
    return None


def _broken(part: Part) -> Broken:
    """The plans of the parts a merged part comes from, loaded into its model, with the
    requirements they break together."""
    pm = part.pm
    assert pm.deferral is not None
    models = [p.pm for p in part.merged_from]
    for var, planned in plan_values(pm, models):
        var.set_value(planned, skip_validation=True)
    bad = violated(pm.deferral.lazy, trajectory_states(pm), least_margin(pm), VIOLATION_TOL)
    return Broken(part.solver, bad, models, part.free)


def solve_parts(
    problem: Problem,
    config: PlannerConfig,
    clock: Clock,
    budget: Budget,
    policy: RepairPolicy | None = None,
    start: Plan | None = None,
    plan_first: int | None = None,
) -> tuple[PlanModel, Outcome] | None:
    """Solve step 1 part by part (module docstring) within ``budget``, repairing in turn by
    ``policy`` (default: ``config``'s), each part's first solve starting from ``start`` (a plan
    of the whole team: its keys of the part's variables); None when the problem has one part.
    When a part has ``plan_first`` agents or more, a first plan of the whole team comes before
    the parts' proofs (:mod:`stlplan.planner.plan_first`).

    Returns the full problem's model with the plan loaded (when there is one) and the result.
    """
    names = agent_parts(problem)
    if len(names) < 2:
        return None
    clock.reached.parts = len(names)
    tick = time.perf_counter()
    with clock.building():
        full = build_model(problem, config.with_overrides({"model.floors": False}))
    built = [_part(problem, agents, config, clock, budget, policy=policy) for agents in names]
    parts = _followed(built, clock)
    if start is not None:  # its agents' states and inputs; HiGHS completes the rest
        for part in parts:
            part.solver.session.start_from(start)
    early = None
    if plan_first is not None and plans_first(problem, config, plan_first):
        early = _first_plan(problem, parts, config, clock, budget)
        parts = _followed(parts, clock)
    gap = config.solver.gap
    parts, done = _apart(problem, full, parts, config, clock, budget, tick)
    if not done.status.has_plan:
        return better(early, (full, done), gap)
    if not (signals.requested() or config.solver.first_plan):
        _tighten(parts, config, budget)
    if len(parts) == 1:  # merged into one part of the whole team: its model is a full one
        return better(early, (dataclasses.replace(parts[0].pm, problem=problem), done), gap)
    return better(early, (full, _whole(full, parts, config, clock, budget, tick)), gap)


def _apart(
    problem: Problem,
    full: PlanModel,
    parts: list[Part],
    config: PlannerConfig,
    clock: Clock,
    budget: Budget,
    tick: float,
) -> tuple[list[Part], Outcome]:
    """Solve the parts in shares, merging those whose plans collide, until none do (or one
    has no plan); the parts and their combined outcome."""
    solve = publishing(published_for(full, config), _solve_part)
    while True:
        solve_in_shares(parts, config, budget, solve)
        done = _combined(parts, config, clock, tick)
        if not done.status.has_plan:  # the message names a part without a plan
            failed = [p.agents for p in parts if p.step1 is None or not p.step1.status.has_plan]
            clock.reached.follow(failed[0] if failed else ())
            return parts, done
        crossing = crossing_requirements(full, parts)
        if not crossing:
            return parts, done
        if signals.requested():  # the parts' plans collide: no plan of the full problem
            return parts, dataclasses.replace(done, status=PlanStatus.INTERRUPTED_NO_PLAN)
        parts = _merged(problem, parts, crossing, config, clock, budget)


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
    objective = _assembled(full, parts, config, clock, budget)
    seconds = time.perf_counter() - tick
    stopped = signals.requested()
    return outcome.assembled(done, objective, config.solver.gap, stopped, seconds)


def _first_plan(
    problem: Problem, parts: list[Part], config: PlannerConfig, clock: Clock, budget: Budget
) -> Solved | None:
    """A plan of the whole team from the parts' first plans, merged where they collide, in a
    model of its own, within ``parts.plan_first_share`` of the time
    (:mod:`stlplan.planner.plan_first`); None without one. The parts not proven are left to go
    on from their first plans: unsolved, with the requirements they added."""
    tick = time.perf_counter()
    quick = config.with_overrides({"solver.first_plan": True})
    share = budget.share(config.parts.plan_first_share)
    with clock.building():
        full = build_model(problem, config.with_overrides({"model.floors": False}))
    _stop_at_first_plans(parts, True)
    try:
        merged, done = _apart(problem, full, parts, quick, clock, share, tick)
        found = _whole(full, merged, quick, clock, share, tick) if done.status.has_plan else None
    finally:
        _stop_at_first_plans(parts, False)
    for part in parts:
        if part.step1 is not None and part.step1.status is not PlanStatus.OPTIMAL:
            part.step1 = None
    return (full, found) if found is not None and found.status.has_plan else None


def _stop_at_first_plans(parts: Sequence[Part], first: bool) -> None:
    """Make the parts' lazy loops stop at their first plan meeting every requirement, or not."""
    for part in parts:
        part.solver.stop_at_first_plan(first)


def _assembled(
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
        clock.plan_found(objective)
    return objective


def _merged(
    problem: Problem,
    parts: list[Part],
    crossing: Sequence[Requirement],
    config: PlannerConfig,
    clock: Clock,
    budget: Budget,
) -> list[Part]:
    """``parts`` with those linked by ``crossing`` merged (seeded with what they had added),
    each recording the whole's bound (:func:`_followed`)."""
    out, first = list(parts), config.solver.first_plan
    for group in merge_groups(parts, [set(r.binding.values()) for r in crossing]):
        agents = {a for p in group for a in p.agents}
        free = frozenset(a for r in crossing for a in r.binding.values()) & agents
        seed = set().union(*(added_keys(p.pm) for p in group))
        # (a repair in turn adds them as its plans cross)
        if not group[0].solver.policy.on_merge(len(free), len(problem.agents), first):
            seed |= {requirement_key(r) for r in crossing if set(r.binding.values()) <= agents}
        order = [a.name for a in problem.agents if a.name in agents]
        out = [p for p in out if p not in group]
        merged = _part(problem, order, config, clock, budget, seed, group[0].solver.policy)
        clock.reached.merges += 1
        merged.merged_from = tuple(group)
        merged.free, merged.team = free, len(problem.agents)
        out.append(merged)
    return _followed(out, clock)
