"""The current plan shifted on: what a replan on a deadline gives back when its search has
nothing better (:mod:`stlplan.deadline`).

From the replan's step ``K``, each agent that is not lost applies the current plan's inputs,
corrected so that its states rejoin the plan's as soon as its dynamics allow: with the measured
deviation ``e = x(K) - x_plan(K)``, the corrections ``du(K), ..., du(K+r-1)`` are the least-norm
solution of ``A^r e + sum_j A^(r-1-j) B du(K+j) = 0`` for the smallest ``r`` that has one
(1 for a single integrator, 2 for a double integrator; :func:`rejoining`). From ``K+r`` on the
states are the plan's again, so whatever the plan met there it meets still; this is the plan the
argument for robust margins builds (docs/replanning.md#plans-robust-to-a-disturbance). A
corrected input outside its bounds is clipped to them, and a horizon too short to rejoin leaves
the least deviation it can. A lost agent stays where it is.

The states are then computed from the measured ones with these inputs, and the monitor judges
the plan like any other: it may still fail what the deviation at steps ``K+1..K+r-1`` breaks.
"""

from __future__ import annotations

import numpy as np

from stlplan.mission.problem import AgentModel, Problem
from stlplan.monitor.verdicts import check as monitor_check
from stlplan.result import PlanResult, PlanStatus, Trajectory

REJOINED = 1e-9
"""The residual below which a correction brings the states back onto the plan's."""


def rejoining(agent: AgentModel, deviation: np.ndarray, steps: int) -> np.ndarray:
    """The input corrections, shape ``(r, m)``, that bring a state off its plan by ``deviation``
    back onto it after ``r <= steps`` steps, ``r`` the fewest that can (module docstring); with
    too few steps, those of ``steps`` that leave the least deviation."""
    A, B = agent.A, agent.B
    n, m = B.shape
    best = np.zeros((0, m))
    for r in range(1, min(n, steps) + 1):
        blocks = [np.linalg.matrix_power(A, r - 1 - j) @ B for j in range(r)]
        target = -np.linalg.matrix_power(A, r) @ deviation
        solution, *_ = np.linalg.lstsq(np.hstack(blocks), target, rcond=None)
        best = solution.reshape(r, m)
        if np.max(np.abs(np.hstack(blocks) @ solution - target), initial=0.0) < REJOINED:
            break
    return best


def shifted_trajectory(
    again: Problem, current: Trajectory, executed: Trajectory, step: int
) -> Trajectory:
    """The current plan shifted on from the measured states of ``step`` (module docstring), on the
    replanned problem ``again`` (its past: the measured states, the lost agents)."""
    assert again.past is not None
    states, inputs = {}, {}
    for agent in again.agents:
        x = np.array(current.states[agent.name], dtype=float)
        u = np.array(current.inputs[agent.name], dtype=float)
        u[:step] = executed.inputs[agent.name][:step]
        x[: step + 1] = again.past.states[agent.name]
        if agent.name in again.past.lost:
            u[step:] = 0.0
            x[step + 1 :] = x[step]
        else:
            deviation = x[step] - current.states[agent.name][step]
            correction = rejoining(agent, deviation, again.horizon - step)
            u[step : step + len(correction)] += correction
            u[step:] = np.clip(u[step:], agent.input_lo, agent.input_hi)
            for k in range(step, again.horizon):
                x[k + 1] = agent.A @ x[k] + agent.B @ u[k]
        states[agent.name], inputs[agent.name] = x, u
    return Trajectory(again.horizon, states, inputs)


def shifted_plan(
    again: Problem, current: Trajectory, executed: Trajectory, step: int
) -> PlanResult:
    """The current plan shifted on from ``step`` (:func:`shifted_trajectory`), judged by the
    monitor on the replanned problem ``again``."""
    trajectory = shifted_trajectory(again, current, executed, step)
    report = monitor_check(again, trajectory)
    failed = [v.name for v in report.verdicts if not v.satisfied]
    verdict = (
        "the monitor finds it meets every task and constraint"
        if not failed
        else (f"the monitor finds it fails {', '.join(failed)}")
    )
    message = f"the current plan shifted on from the measured states of step {step}; {verdict}"
    return PlanResult(PlanStatus.SHIFTED, message, trajectory=trajectory, report=report)
