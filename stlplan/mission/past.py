"""A replan's problem: the executed past as data, and the events since (DESIGN 2.13-14).

A replan from step ``K`` keeps the whole horizon and the same encoding; the executed states of
steps ``0..K`` are data (measured: their dynamics are not checked), and only the inputs from
``K`` on are planned. A lost agent plans nothing from ``K`` on: it stays in the state it was
last seen in, and the others keep their separation from it. A closed region becomes, for every
agent that is not lost, the constraint ``G[K,H] !in(p, region)`` (``G[K+1,H]``, named
``closed REGION (leaving)``, for an agent inside it at ``K``: it must be out at the next step).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import replace

import numpy as np

from stlplan.errors import EventError, TrajectoryError
from stlplan.formula.parser import parse
from stlplan.mission.problem import ConstraintModel, Past, Problem
from stlplan.result import Trajectory
from stlplan.words import counted

BOUND_TOL = 1e-9
"""How far an executed state may lie outside its bounds and still be read as within them."""


def replanned(
    problem: Problem,
    executed: Trajectory,
    step: int,
    lost: Sequence[str] = (),
    closed: Sequence[str] = (),
) -> Problem:
    """``problem`` replanned from step ``step`` of the ``executed`` trajectory.

    Raises
    ------
    EventError
        ``step`` outside ``0..H-1``; an unknown, repeated or every agent in ``lost``; an
        unknown region in ``closed``.
    TrajectoryError
        An executed state before ``step`` missing, not finite, or outside its bounds (naming the
        agent and the step).
    """
    _check_events(problem, step, lost, closed)
    states = {
        a.name: np.asarray(executed.states[a.name][: step + 1], float) for a in problem.agents
    }
    _check_states(problem, states)
    past = Past(step, states, frozenset(lost), tuple(closed))
    agents = tuple(replace(a, initial_state=states[a.name][0].copy()) for a in problem.agents)
    constraints = problem.constraints + tuple(_closures(problem, past))
    return replace(problem, agents=agents, constraints=constraints, past=past, _by_name={})


def check_step(problem: Problem, step: int) -> None:
    """Raise :class:`EventError` unless ``step`` is in ``0..H-1``."""
    H = problem.horizon
    if not 0 <= step <= H - 1:
        raise EventError(f"--at {step}: expected a step in 0..{H - 1} (the horizon is {H})")


def _check_events(problem: Problem, step: int, lost: Sequence[str], closed: Sequence[str]) -> None:
    check_step(problem, step)
    names = [a.name for a in problem.agents]
    for name in lost:
        if name not in names:
            raise EventError(f"--lost {name}: no such agent; agents: {', '.join(names)}")
    twice = sorted({n for n in lost if list(lost).count(n) > 1})
    if twice:
        raise EventError(f"--lost {twice[0]}: the agent is lost twice; name each agent once")
    if set(lost) == set(names):
        raise EventError(
            f"--lost names every agent ({counted(len(names), 'agent')}): nothing is left to plan"
        )
    for region in closed:
        if region not in problem.regions:
            known = ", ".join(problem.regions)
            raise EventError(f"--closed {region}: no such region; regions: {known}")
    twice = sorted({r for r in closed if list(closed).count(r) > 1})
    if twice:
        raise EventError(f"--closed {twice[0]}: the region is closed twice; name each region once")


def _check_states(problem: Problem, states: Mapping[str, np.ndarray]) -> None:
    for agent in problem.agents:
        x = states[agent.name]
        for k, row in enumerate(x):
            if not np.all(np.isfinite(row)):
                raise TrajectoryError(
                    f"agent '{agent.name}' step {k}: the executed past needs every state "
                    "component (a file of positions only cannot be replanned from)"
                )
            low = row < agent.state_lo - BOUND_TOL
            high = row > agent.state_hi + BOUND_TOL
            for i in np.flatnonzero(low | high):
                raise TrajectoryError(
                    f"agent '{agent.name}' step {k}: x{i} = {row[i]:.6g} is outside its state "
                    f"bounds [{agent.state_lo[i]:g}, {agent.state_hi[i]:g}]"
                )


def _closures(problem: Problem, past: Past) -> Iterable[ConstraintModel]:
    """``G[K,H] !in(p, region)`` for every closed region and every agent not lost that is
    outside it at ``K``; an agent inside it then must be out from ``K+1`` on."""
    H, K = problem.horizon, past.step
    for region in past.closed:
        inside = {a.name for a in problem.agents if _inside(problem, region, a.name, past)}
        for start, agents, name in ((K, False, region), (K + 1, True, f"{region} (leaving)")):
            bindings = tuple(
                {"p": a.name}
                for a in problem.agents
                if a.name not in past.lost and (a.name in inside) == agents
            )
            if bindings and start <= H:
                formula = parse(f"G[{start},{H}] !in(p, {region})", where=f"--closed {region}")
                yield ConstraintModel(f"closed {name}", formula, bindings)


def _inside(problem: Problem, region: str, agent: str, past: Past) -> bool:
    """Whether ``agent``'s position at the replan's step lies in ``region`` (boundary included)."""
    rows, rhs = problem.regions[region]
    position = past.state(agent, past.step)[list(problem.agent(agent).position)]
    return all(float(np.dot(g, position)) <= h for g, h in zip(rows, rhs, strict=True))
