"""Reading a solved planning model back: trajectory, groups, runs, effort, the PlanResult."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
from pyomo.environ import value

from stlplan.planner.encoding.model import PlanModel, SyncChoice, TaskChoice
from stlplan.planner.encoding.selection import Selection, SyncSelection
from stlplan.planner.encoding.tasks import SyncEncoding, best_run, chosen_group
from stlplan.result import Assignment, ModelSize, PlanResult, PlanStatus, Trajectory


def trajectory(pm: PlanModel) -> Trajectory:
    """States ``x_p(0..H)`` and inputs ``u_p(0..H-1)`` of the loaded solution, as arrays."""
    states, inputs = {}, {}
    for agent in pm.problem.agents:
        states[agent.name] = np.array(
            [[value(v) for v in row] for row in pm.states(agent)], dtype=float
        ).reshape(pm.problem.horizon + 1, agent.n)
        inputs[agent.name] = np.array(
            [[value(v) for v in row] for row in pm.inputs(agent)], dtype=float
        ).reshape(pm.problem.horizon, agent.m)
    return Trajectory(pm.problem.horizon, states, inputs)


def effort(inputs: Mapping[str, np.ndarray], norm: str) -> float:
    """Team effort in ``norm``.

    ``l1``: ``sum_p sum_k ||u_p(k)||_1``; ``l2``: ``sum_p ||u_p||_2`` over the stacked inputs
    (the paper's effort); ``linf``: ``sum_p max_k ||u_p(k)||_inf``.
    """
    per_agent = {
        "l1": lambda u: float(np.abs(u).sum()),
        "l2": lambda u: float(np.sqrt((u**2).sum())),
        "linf": lambda u: float(np.abs(u).max(initial=0.0)),
    }[norm]
    return sum(per_agent(u) for u in inputs.values())


def chosen(enc: TaskChoice) -> tuple[int, ...]:
    """Element indices of the group a task chose in the loaded solution."""
    if isinstance(enc, Selection):
        return enc.elements()
    return enc.task.groups[chosen_group(enc)]


def chosen_run(enc: SyncChoice) -> tuple[tuple[int, ...], int, int]:
    """``(element indices, start, length)`` of a synchronous task's run in the loaded solution."""
    if isinstance(enc, SyncSelection):
        return (enc.elements(), *enc.run())
    j, start, length = best_run(enc)
    return enc.task.groups[j], start, length


def partners(pm: PlanModel, name: str) -> list[str]:
    """The agents that fill the other roles of the elements agent ``name`` fills in the loaded
    solution's choices (its formation), in the problem's order. A task whose choice has no
    values loaded is left out."""
    found: set[str] = set()
    for enc in (*pm.tasks, *pm.synchronous):
        indices = _loaded_choice(enc)
        for i in indices or ():
            if name in enc.task.elements[i]:
                found.update(enc.task.elements[i])
    return [a.name for a in pm.problem.agents if a.name in found - {name}]


def _loaded_choice(enc: TaskChoice | SyncChoice) -> tuple[int, ...] | None:
    """Element indices of a task's choice in the loaded solution; None without its values."""
    if isinstance(enc, Selection):
        read: Iterable[Any] = enc.chosen
    elif isinstance(enc, SyncEncoding):
        read = enc.counts.values()
    else:
        read = enc.groups
    if any(value(v, exception=False) is None for v in read):
        return None
    return chosen_run(enc)[0] if isinstance(enc, SyncEncoding) else chosen(enc)


def assignments(pm: PlanModel) -> tuple[tuple[Assignment, ...], dict[str, float]]:
    """The chosen group of every task (with the run of synchronous ones) and ``rho_s`` per task."""
    out, rho_s = [], {}
    for enc in pm.tasks:
        task = enc.task
        out.append(Assignment(task.name, tuple(task.elements[i] for i in chosen(enc))))
    for sync in pm.synchronous:
        task = sync.task
        assert task.sync is not None
        members, start, length = chosen_run(sync)
        rho = float(length - 1 - task.sync.d)
        rho_s[task.name] = rho
        group = tuple(task.elements[i] for i in members)
        out.append(Assignment(task.name, group, rho, start, length))
    order = {t.name: n for n, t in enumerate(pm.problem.tasks)}
    return tuple(sorted(out, key=lambda a: order[a.task])), rho_s


def plan_result(
    pm: PlanModel,
    status: PlanStatus,
    message: str,
    step1: Mapping[str, Any],
    size: ModelSize,
    build_seconds: float,
    solve_seconds: float,
    steps: int,
) -> PlanResult:
    """Assemble the :class:`PlanResult` of a solved model (solution loaded)."""
    plan = trajectory(pm)
    chosen, rho_s = assignments(pm)
    margin = float(value(pm.margin))
    return PlanResult(
        status=status,
        message=message,
        trajectory=plan,
        objective=step1.get("objective"),
        bound=step1.get("bound"),
        gap=step1.get("gap"),
        rho_s=rho_s,
        effort=effort(plan.inputs, pm.problem.mission.objective.effort),
        margin=margin,
        assignments=chosen,
        model_size=size,
        build_seconds=build_seconds,
        solve_seconds=solve_seconds,
        steps=steps,
    )
