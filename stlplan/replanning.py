"""A replan: the same planning run on a problem whose past is data (DESIGN 2.13-14).

:func:`replan` plans the problem :func:`stlplan.mission.past.replanned` makes of an executed
trajectory, from a starting plan (the rest of an earlier plan, by default the executed file's
own later rows), and returns a result whose trajectory keeps the executed past (its inputs as
executed, where the file gave them) and whose :class:`~stlplan.result.Replan` says what was kept.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from stlplan.mission.past import replanned
from stlplan.mission.problem import Problem
from stlplan.planner.overrides import Overrides
from stlplan.planner.run.outcome import Plan, VarKey
from stlplan.result import PlanResult, Replan, Trajectory


def trajectory_start(problem: Problem, trajectory: Trajectory, step: int) -> Plan:
    """The states after ``step`` and the inputs from ``step`` on of ``trajectory`` (an earlier
    plan), as a start for a replan of ``problem`` (HiGHS completes the rest)."""
    values: dict[VarKey, float] = {}
    for agent in problem.agents:
        x, u = trajectory.states[agent.name], trajectory.inputs[agent.name]
        for k in range(step + 1, problem.horizon + 1):
            values.update(_finite("x", (agent.name, k), x[k]))
        for k in range(step, problem.horizon):
            values.update(_finite("u", (agent.name, k), u[k]))
            values.update(_finite("s", (agent.name, k), np.abs(u[k])))
    return Plan(math.nan, values, meets_all=False)


def _finite(name: str, at: tuple[str, int], row: np.ndarray) -> dict[VarKey, float]:
    return {(name, (*at, i)): float(v) for i, v in enumerate(row) if math.isfinite(v)}


def replan(
    problem: Problem,
    executed: Trajectory,
    step: int,
    lost: Sequence[str] = (),
    closed: Sequence[str] = (),
    overrides: Overrides | None = None,
    progress: Callable[[Any], None] | None = None,
    start: Plan | None = None,
) -> tuple[Problem, PlanResult]:
    """Plan ``problem`` again from step ``step`` of ``executed``, with agents ``lost`` and
    regions ``closed`` at that step, and verify the whole trajectory with the monitor.

    ``start`` (default: ``executed``'s own states and inputs past ``step``, where it has them)
    is where step 1 starts. When the rest of the mission cannot be met, the plan is degraded
    (``Overrides.degrade`` unless set to False): it drops the fewest tasks it must. Returns the replanned problem and the verified result.
    """
    from stlplan.pipeline import plan

    tick = time.perf_counter()
    again = replanned(problem, executed, step, lost, closed)
    overrides = overrides or Overrides()
    if overrides.degrade is None:  # a replan degrades unless told not to
        overrides = dataclasses.replace(overrides, degrade=True)
    if start is None:
        start = trajectory_start(again, executed, step)
    again, result = plan(again, overrides, progress=progress, start=start)
    assert again.past is not None
    inputs = {a.name: executed.inputs[a.name][:step] for a in again.agents}
    past_effort = sum(float(np.nansum(np.abs(u))) for u in inputs.values())
    trajectory = result.trajectory
    if trajectory is not None:
        trajectory = _with_past_inputs(trajectory, inputs)
    seconds = time.perf_counter() - tick
    record = Replan(step, tuple(again.past.events()), seconds, past_effort)
    return again, dataclasses.replace(result, trajectory=trajectory, replan=record)


def _with_past_inputs(trajectory: Trajectory, inputs: Mapping[str, np.ndarray]) -> Trajectory:
    """``trajectory`` with the executed inputs before the replan's step (NaN where the executed
    file gave none)."""
    merged = {}
    for name, u in trajectory.inputs.items():
        u = np.array(u, dtype=float)
        u[: len(inputs[name])] = inputs[name]
        merged[name] = u
    return dataclasses.replace(trajectory, inputs=merged)
