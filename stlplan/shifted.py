"""The current plan shifted on: what a replan on a deadline gives back when its search has
nothing better (:mod:`stlplan.deadline`).

From the replan's step ``K``, each agent that is not lost applies the current plan's inputs,
corrected so that its states rejoin the plan's: with the drift ``f = A x(K) + B u_plan(K) -
x_plan(K+1)`` (where the measured state goes with the plan's input, against the plan: ``A e``
for a deviation ``e = x(K) - x_plan(K)``), the corrections ``du(K), ..., du(K+R-1)`` bring the
deviation ``d(k) = A^(k-1) f + sum_j A^(k-1-j) B du(K+j)`` to zero at ``K+R`` with the least
squared position deviation at ``K+1..K+R-1`` (:func:`rejoining`). ``R`` is one more than the fewest steps
that can bring any deviation to zero (2 for a single integrator, 3 for a double integrator):
the fewest leave no choice, and a double integrator brought back in two steps is off at ``K+1``
by up to ``0.5 e_p + 0.25 e_v`` per axis, twice what the extra step leaves. From ``K+R`` on the
states are the plan's again, so whatever the plan met there it meets still; this is the plan
the argument for robust margins builds (docs/replanning.md#plans-robust-to-a-disturbance). A
corrected input outside its bounds is clipped to them, and a horizon too short to rejoin
leaves the least deviation it can. A lost agent stays where it is.

The states are then computed from the measured ones with these inputs, and the monitor judges
the plan like any other: it may still fail what the deviation at steps ``K+1..K+r-1`` breaks.
"""

from __future__ import annotations

import numpy as np

from stlplan.mission.problem import AgentModel, Problem
from stlplan.monitor.verdicts import check as monitor_check
from stlplan.result import PlanResult, PlanStatus, Trajectory

TINY = 1e-6
"""The weight of the corrections' own size beside the positions' deviation (it only picks one
correction among equals)."""


def rejoining(agent: AgentModel, drift: np.ndarray, steps: int) -> np.ndarray:
    """The input corrections, shape ``(R, m)``, that bring a state back onto its plan after
    ``R`` steps with the least squared deviation of the position on the steps between (module
    docstring). ``drift`` is where the state would be off the plan one step on without a
    correction (``A e`` for a deviation ``e`` now); ``R`` is one more than the fewest steps that
    can, at most ``steps``."""
    n, m = agent.B.shape
    fewest = next((r for r in range(1, n) if np.linalg.matrix_rank(_reach(agent, r, r)) == n), n)
    R = min(fewest + 1, steps)
    position = np.eye(n)[list(agent.position)]
    power = np.linalg.matrix_power
    between = [position @ _reach(agent, k, R) for k in range(1, R)]
    off = [position @ power(agent.A, k - 1) @ drift for k in range(1, R)]
    Q = np.vstack(between) if between else np.zeros((0, R * m))
    q = np.concatenate(off) if off else np.zeros(0)
    # min |Q du + q|^2 (+ a tiny |du|^2) subject to reach(R) du = -A^(R-1) drift: its KKT system
    hessian = Q.T @ Q + TINY * np.eye(R * m)
    end = _reach(agent, R, R)
    kkt = np.block([[hessian, end.T], [end, np.zeros((n, n))]])
    rhs = np.concatenate([-Q.T @ q, -power(agent.A, R - 1) @ drift])
    solution, *_ = np.linalg.lstsq(kkt, rhs, rcond=None)
    return solution[: R * m].reshape(R, m)


def _reach(agent: AgentModel, k: int, R: int) -> np.ndarray:
    """How corrections ``du(0..R-1)`` (stacked) move the state after ``k`` steps: the blocks
    ``A^(k-1-j) B`` for ``j < k``, zero for the later ones."""
    n, m = agent.B.shape
    out = np.zeros((n, R * m))
    for j in range(k):
        out[:, j * m : (j + 1) * m] = np.linalg.matrix_power(agent.A, k - 1 - j) @ agent.B
    return out


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
            # off the plan one step on with the plan's input (the plan's state at the step may
            # be the measured one: an executed file's rows)
            drift = agent.A @ x[step] + agent.B @ u[step] - current.states[agent.name][step + 1]
            correction = rejoining(agent, drift, again.horizon - step)
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
