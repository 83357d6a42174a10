"""The independent monitor: a second opinion on any team trajectory.

:func:`check` decides every task, synchronous task, constraint, the pairwise separation and each
agent's dynamics from the mission's formula trees and the trajectory alone, with numpy. It never
imports the encoder, the solver or Pyomo, so a plan is checked by code that did not produce it.

Semantics (DESIGN.md section 2). A robustness value holds iff it is at least ``HOLDS_AT``
(``EPSILON / 2``, :mod:`stlplan.formula.boundary`): a region's boundary is neither inside nor
outside, and the planner enforces every predicate with a margin of at least ``EPSILON``.

* element ``e`` of task ``T``: ``rho_e(k)`` is the robustness of ``phi`` with ``e``'s agents bound
  to the roles; a group's robustness is ``min_{e in group} rho_e(0)``, the task's is the max over
  groups, and ``T`` holds iff that holds;
* synchronous task ``F[a,b] <G[0,d] phi, c, Pattern>``: ``s_j(k) = 1`` iff ``rho_e(k)`` holds for
  every element of group ``j``; ``run_j(k')`` counts the consecutive steps ``k', k'+1, ...`` with
  ``s_j = 1`` (stopping where ``phi`` can no longer be evaluated); ``rho_s = max_j max_{k' in [a,b]}
  run_j(k') - 1 - d`` and the task holds iff ``rho_s >= 0``;
* constraints hold at step 0 under every binding; separation is
  ``min_{p<q, k} ||z_p(k) - z_q(k)||_inf - d_col``, which must hold;
* dynamics and bounds hold within the tolerance ``tol`` (relative to the terms' scale);
* with inter-sample safety (``problem.inter_sample``, the default) avoidance parts of constraints
  and separation are also judged on the straight segments between steps
  (:mod:`stlplan.monitor.crossings`): a constraint's or the separation's robustness is the minimum over
  steps and segments, and a failing segment is named with its step ``k -> k+1``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from stlplan.errors import TrajectoryError
from stlplan.formula.boundary import holds
from stlplan.mission.problem import AgentModel, ConstraintModel, Problem, TaskModel
from stlplan.monitor.crossings import separation_segments, worst_segment
from stlplan.monitor.robustness import robustness
from stlplan.result import Element, MonitorReport, Trajectory, Verdict


def check(problem: Problem, trajectory: Trajectory, tol: float = 1e-6) -> MonitorReport:
    """Every verdict on ``trajectory``: tasks, constraints, separation, then dynamics.

    Parameters
    ----------
    problem
        The checked mission.
    trajectory
        States ``x_p(0..H)`` and inputs ``u_p(0..H-1)`` of every agent of the mission.
    tol
        Tolerance of the dynamics and bounds checks (robustness verdicts use ``HOLDS_AT``).

    Raises
    ------
    TrajectoryError
        If the trajectory's horizon, agents or array shapes do not fit the mission.
    """
    _check_shapes(problem, trajectory)
    verdicts: list[Verdict] = []
    for task in problem.tasks:
        verdicts.append(_task_verdict(problem, trajectory, task))
    for constraint in problem.constraints:
        verdicts.append(_constraint_verdict(problem, trajectory, constraint))
    if problem.separation is not None:
        verdicts.append(_separation_verdict(problem, trajectory, problem.separation))
    for agent in problem.agents:
        verdicts.append(_dynamics_verdict(agent, trajectory, tol))
    return MonitorReport(tuple(verdicts))


def _check_shapes(problem: Problem, trajectory: Trajectory) -> None:
    H = problem.horizon
    if trajectory.horizon != H:
        raise TrajectoryError(
            f"trajectory horizon {trajectory.horizon} differs from the mission's horizon {H}"
        )
    for agent in problem.agents:
        if agent.name not in trajectory.states or agent.name not in trajectory.inputs:
            raise TrajectoryError(f"trajectory has no states or inputs for agent '{agent.name}'")
        x, u = trajectory.states[agent.name], trajectory.inputs[agent.name]
        if np.shape(x) != (H + 1, agent.n) or np.shape(u) != (H, agent.m):
            raise TrajectoryError(
                f"agent '{agent.name}': expected states of shape {(H + 1, agent.n)} and inputs of "
                f"shape {(H, agent.m)}, found {np.shape(x)} and {np.shape(u)}"
            )


def element_robustness(problem: Problem, trajectory: Trajectory, task: TaskModel) -> np.ndarray:
    """``rho_e(k)`` for every element ``e`` of ``task`` (rows) and evaluable step ``k`` (columns)."""
    rows = []
    for element in task.elements:
        binding = task.binding(element)
        signals = {role: trajectory.states[name] for role, name in binding.items()}
        rows.append(robustness(problem.lowered(task.formula, binding), signals, problem.horizon))
    return np.array(rows, dtype=float).reshape(len(task.elements), -1)


def _group_text(task: TaskModel, group: Sequence[int]) -> str:
    return ", ".join("(" + ", ".join(task.elements[i]) + ")" for i in group)


def _group_elements(task: TaskModel, group: Sequence[int]) -> tuple[Element, ...]:
    return tuple(task.elements[i] for i in group)


def _task_verdict(problem: Problem, trajectory: Trajectory, task: TaskModel) -> Verdict:
    rho = element_robustness(problem, trajectory, task)
    if task.sync is not None:
        return _synchronous_verdict(task, rho)
    # rho(T) = max_j min_{e in group j} rho_e(0)
    groups = np.array(task.groups, dtype=int)
    group_rho = np.min(rho[:, 0][groups], axis=1)
    best = int(np.nanargmax(group_rho)) if not np.all(np.isnan(group_rho)) else 0
    value = float(group_rho[best])
    satisfied = holds(value)
    text = _group_text(task, task.groups[best])
    detail = (
        f"group {text} holds with margin {value:.3g}"
        if satisfied
        else f"no group satisfies: best {text} reaches {value:.3g}"
    )
    return Verdict(
        task.name, "task", satisfied, value, _group_elements(task, task.groups[best]), detail=detail
    )


def run_lengths(holds: np.ndarray) -> np.ndarray:
    """``run[j, k]``: consecutive steps ``k, k+1, ...`` with ``holds[j, .] = True``.

    Computed backwards: ``run[j, k] = holds[j, k] * (1 + run[j, k+1])`` with ``run[j, K] = 0``.
    """
    run = np.zeros((holds.shape[0], holds.shape[1] + 1), dtype=int)
    for k in range(holds.shape[1] - 1, -1, -1):
        run[:, k] = np.where(holds[:, k], run[:, k + 1] + 1, 0)
    return run[:, :-1]


def _synchronous_verdict(task: TaskModel, rho: np.ndarray) -> Verdict:
    assert task.sync is not None
    a, b, d = task.sync.a, task.sync.b, task.sync.d
    groups = np.array(task.groups, dtype=int)
    per_group = rho[groups]  # (groups, c, K)
    steps = per_group.shape[2]
    starts = np.arange(a, b + 1)
    # s_j(k) = 1 iff every element of group j satisfies phi at k
    run = run_lengths(np.all(holds(per_group), axis=1))
    run = np.hstack([run, np.zeros((len(groups), b + 1), dtype=int)])[:, starts]
    # spatial robustness of G[0,d] AND_e phi_e from k': min_e min_{k in [k', k'+d]} rho_e(k)
    spatial = np.full((len(groups), len(starts)), -np.inf)
    for i, start in enumerate(starts):
        if start + d < steps:
            spatial[:, i] = np.min(per_group[:, :, start : start + d + 1], axis=(1, 2))
    j, i = _best_start(run, spatial, starts)
    rho_s = int(run[j, i]) - 1 - d
    spatial_rho = float(np.max(np.nan_to_num(spatial, nan=-np.inf)))
    return Verdict(
        task.name,
        "synchronous",
        rho_s >= 0,
        spatial_rho,
        _group_elements(task, task.groups[j]),
        rho_s=float(rho_s),
        run_start=int(starts[i]),
        run_length=int(run[j, i]),
        detail=_synchronous_detail(task, j, int(starts[i]), int(run[j, i]), rho_s),
    )


def _best_start(run: np.ndarray, spatial: np.ndarray, starts: np.ndarray) -> tuple[int, int]:
    """Group ``j`` and start index ``i`` with the longest run, then earliest start, then best
    spatial robustness (then the first group)."""
    flat_run = run.ravel()
    flat_start = np.broadcast_to(starts[None, :], run.shape).ravel()
    flat_spatial = np.nan_to_num(spatial, nan=-np.inf).ravel()
    # np.lexsort sorts by the last key first; index 0 is the best candidate
    best = int(np.lexsort((-flat_spatial, flat_start, -flat_run))[0])
    j, i = np.unravel_index(best, run.shape)
    return int(j), int(i)


def _synchronous_detail(task: TaskModel, j: int, start: int, length: int, rho_s: int) -> str:
    assert task.sync is not None
    need = task.sync.d + 1
    text = _group_text(task, task.groups[j])
    if rho_s >= 0:
        return (
            f"group {text} holds phi together for {length} steps from step {start} "
            f"(needs {need}): rho_s = {rho_s}"
        )
    if length == 0:
        return (
            f"no group holds phi together at any start in [{task.sync.a}, {task.sync.b}] "
            f"(needs {need} steps): rho_s = {rho_s}"
        )
    return (
        f"no group holds phi together for {need} steps: best {text} for {length} from step "
        f"{start}, rho_s = {rho_s}"
    )


def _binding_text(binding: dict[str, str]) -> str:
    return ", ".join(f"{role}={agent}" for role, agent in binding.items())


def _binding_value(
    problem: Problem, trajectory: Trajectory, constraint: ConstraintModel, binding: Any
) -> tuple[float, str]:
    """``rho(phi, 0)`` under ``binding``, or the worst segment's ``rho_seg`` when lower (and where)."""
    signals = {role: trajectory.states[name] for role, name in binding.items()}
    lowered = problem.lowered(constraint.formula, binding)
    sampled = float(robustness(lowered, signals, problem.horizon)[0])
    crossing = worst_segment(lowered, signals, problem.horizon) if problem.inter_sample else None
    if crossing is None or not crossing.value < sampled - 1e-12:
        return sampled, ""
    return crossing.value, f" on the segment {crossing.step} -> {crossing.step + 1}"


def _constraint_verdict(
    problem: Problem, trajectory: Trajectory, constraint: ConstraintModel
) -> Verdict:
    # rho(constraint) = min over bindings of rho(phi, 0) (and of rho_seg on the segments)
    values, segments = [], []
    for binding in constraint.bindings:
        value, where = _binding_value(problem, trajectory, constraint, binding)
        values.append(value)
        segments.append(where)
    if not values:
        return Verdict(constraint.name, "constraint", True, float("inf"), detail="no binding")
    worst = int(np.argmin(np.where(np.isnan(values), -np.inf, values)))
    value = values[worst]
    failing = sum(1 for v in values if not holds(v))
    who = _binding_text(dict(constraint.bindings[worst])) + segments[worst]
    if failing == 0:
        detail = f"holds for all {len(values)} binding(s); tightest {who} with margin {value:.3g}"
    else:
        detail = f"fails for {failing} of {len(values)} binding(s); worst {who} reaches {value:.3g}"
    return Verdict(constraint.name, "constraint", failing == 0, value, detail=detail)


def _separation_verdict(problem: Problem, trajectory: Trajectory, separation: float) -> Verdict:
    # rho = min_{p<q} min_k ||z_p(k) - z_q(k)||_inf - separation
    name = "separation"
    agents = problem.agents
    if len(agents) < 2:
        return Verdict(name, "separation", True, float("inf"), detail="fewer than two agents")
    z = np.stack([trajectory.position(a.name, a.position) for a in agents])  # (P, H+1, 2)
    gap = np.max(np.abs(z[:, None] - z[None, :]), axis=3) - separation  # (P, P, H+1)
    upper = np.triu(np.ones((len(agents), len(agents)), dtype=bool), k=1)
    gap = np.where(upper[:, :, None], np.nan_to_num(gap, nan=-np.inf), np.inf)
    p, q, k = np.unravel_index(int(np.argmin(gap)), gap.shape)
    value = float(gap[p, q, k])
    pair = f"{agents[p].name} and {agents[q].name} at step {k}"
    if problem.inter_sample and gap.shape[2] > 1:
        seg = separation_segments(z, separation)
        seg = np.where(upper[:, :, None], np.nan_to_num(seg, nan=-np.inf), np.inf)
        sp, sq, sk = np.unravel_index(int(np.argmin(seg)), seg.shape)
        if seg[sp, sq, sk] < value - 1e-12:
            value = float(seg[sp, sq, sk])
            pair = f"{agents[sp].name} and {agents[sq].name} on the segment {sk} -> {sk + 1}"
    satisfied = holds(value)
    detail = (
        f"every pair keeps {separation:g} apart; closest {pair} with margin {value:.3g}"
        if satisfied
        else f"{pair} are closer than {separation:g} by {-value:.3g}"
    )
    return Verdict(name, "separation", satisfied, value, detail=detail)


Violation = tuple[int, int, int, float, str]
"""``(step, check order, component, size, message)`` of one dynamics violation."""


def _violations(
    steps: np.ndarray,
    order: int,
    error: np.ndarray,
    allowed: np.ndarray,
    describe: Callable[[int, int], str],
) -> list[Violation]:
    """Entries ``(r, i)`` whose ``error`` exceeds ``allowed`` (NaN counts as a violation).

    ``steps[r]`` is row ``r``'s step; ``describe(r, i)`` says what was found and expected.
    """
    out: list[Violation] = []
    for r, i in np.argwhere(~(error <= allowed)):
        size = float(error[r, i]) if np.isfinite(error[r, i]) else float("inf")
        out.append((int(steps[r]), order, int(i), size, describe(int(r), int(i))))
    return out


def _bound_violations(
    values: np.ndarray, lo: np.ndarray, hi: np.ndarray, symbol: str, order: int, tol: float
) -> list[Violation]:
    # lo - tol * max(1, |lo|, |hi|) <= v <= hi + tol * max(1, |lo|, |hi|)
    excess = np.maximum(np.maximum(lo - values, values - hi), 0.0)
    allowed = np.broadcast_to(
        tol * np.maximum(1.0, np.maximum(np.abs(lo), np.abs(hi))), values.shape
    )
    return _violations(
        np.arange(len(values)),
        order,
        excess,
        allowed,
        lambda r, i: f"{symbol}[{i}] = {values[r, i]:.6g}, expected within [{lo[i]:g}, {hi[i]:g}]",
    )


def _dynamics_violations(
    agent: AgentModel, x: np.ndarray, u: np.ndarray, tol: float
) -> list[Violation]:
    """Violations of ``x(0) = x_init``, ``x(k+1) = A x(k) + B u(k)`` and the bounds.

    The equalities allow ``tol * max(1, |x_init|)`` and ``tol * (1 + |A| |x(k)| + |B| |u(k)|)``
    (the scale of the terms summed), the bounds ``tol * max(1, |bound|)``.
    """
    init = agent.initial_state
    found = []
    found += _violations(
        np.zeros(1, dtype=int),
        0,
        np.abs(x[:1] - init),
        tol * np.maximum(1.0, np.abs(init))[None],
        lambda r, i: f"x[{i}] = {x[0, i]:.6g}, expected the initial state {init[i]:.6g}",
    )
    expected = x[:-1] @ agent.A.T + u @ agent.B.T
    scale = 1.0 + np.abs(x[:-1]) @ np.abs(agent.A).T + np.abs(u) @ np.abs(agent.B).T
    found += _violations(
        np.arange(1, len(x)),
        1,
        np.abs(x[1:] - expected),
        tol * scale,
        lambda r, i: f"x[{i}] = {x[r + 1, i]:.6g}, expected A x(k) + B u(k) = {expected[r, i]:.6g}",
    )
    found += _bound_violations(x, agent.state_lo, agent.state_hi, "x", 2, tol)
    found += _bound_violations(u, agent.input_lo, agent.input_hi, "u", 3, tol)
    return found


def _dynamics_verdict(agent: AgentModel, trajectory: Trajectory, tol: float) -> Verdict:
    # robustness = -(largest violation) or 0 when every equation and bound holds within tol
    name = f"dynamics {agent.name}"
    x = np.asarray(trajectory.states[agent.name], dtype=float)
    u = np.asarray(trajectory.inputs[agent.name], dtype=float)
    found = _dynamics_violations(agent, x, u, tol)
    if not found:
        detail = (
            f"{agent.name}: initial state, x(k+1) = A x(k) + B u(k) and bounds hold for "
            f"steps 0..{trajectory.horizon}"
        )
        return Verdict(name, "dynamics", True, 0.0, detail=detail)
    step, _, _, _, text = min(found)
    worst = max(v[3] for v in found)
    more = f" ({len(found)} violations in all)" if len(found) > 1 else ""
    return Verdict(
        name, "dynamics", False, -worst, detail=f"{agent.name} step {step}: {text}{more}"
    )
