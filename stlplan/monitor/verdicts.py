"""The independent monitor: a second opinion on any team trajectory.

:func:`check` decides every task, synchronous task, constraint, the pairwise separation and each
agent's dynamics from the mission's formula trees and the trajectory alone, with numpy. It never
imports the encoder, the solver or Pyomo, so a plan is checked by code that did not produce it.

Semantics (DESIGN.md section 2). A robustness value holds iff it is at least ``HOLDS_AT``
(``EPSILON / 2``, :mod:`stlplan.formula.boundary`): a region's boundary is neither inside nor
outside, and the planner enforces every predicate with a margin of at least ``EPSILON``.

* element ``e`` of task ``T``: ``rho_e(k)`` is the robustness of ``phi`` with ``e``'s agents bound
  to the roles; a group's robustness is ``min_{e in group} rho_e(0)``, the task's is the max over
  groups, and ``T`` holds iff that holds. Groups are never enumerated: the best group is
  found by bisection over the elements' values (:func:`stlplan.mission.groups.best_group`);
* synchronous task ``F[a,b] <G[0,d] phi, c, Pattern>``: ``s_j(k) = 1`` iff ``rho_e(k)`` holds for
  every element of group ``j``; ``run_j(k')`` counts the consecutive steps ``k', k'+1, ...`` with
  ``s_j = 1`` (stopping where ``phi`` can no longer be evaluated); ``rho_s = max_j max_{k' in [a,b]}
  run_j(k') - 1 - d`` and the task holds iff ``rho_s >= 0`` (a group's run is the least of its
  elements' runs, so the best group from each ``k'`` is again a bisection over elements);
* constraints hold at step 0 under every binding; separation is
  ``min_{p<q, k} ||z_p(k) - z_q(k)||_inf - d_col``, which must hold;
* dynamics and bounds hold within the tolerance ``tol`` (relative to the terms' scale);
* with inter-sample safety (``problem.inter_sample``, the default) avoidance parts of constraints
  and separation are also judged on the straight segments between steps (a replan's from its
  step ``K`` on: the executed segments before it were not planned, and their path is not known)
  (:mod:`stlplan.monitor.crossings`): a constraint's or the separation's robustness is the minimum over
  steps and segments, and a failing segment is named with its step ``k -> k+1``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from stlplan.errors import TrajectoryError
from stlplan.formula.boundary import holds
from stlplan.formula.tree import Formula, Linear, atoms, horizon, step_parts
from stlplan.mission.groups import best_group
from stlplan.mission.problem import ConstraintModel, Problem, TaskModel
from stlplan.monitor.crossings import worst_segment
from stlplan.monitor.dynamics import dynamics_verdict
from stlplan.monitor.robustness import robustness
from stlplan.monitor.separation import separation_verdict
from stlplan.result import Element, MonitorReport, Trajectory, Verdict
from stlplan.words import counted


def check(
    problem: Problem,
    trajectory: Trajectory,
    tol: float = 1e-6,
    slack: float = 0.0,
    planned_only: bool = False,
) -> MonitorReport:
    """Every verdict on ``trajectory``: tasks, constraints, separation, then dynamics.

    Parameters
    ----------
    problem
        The checked mission.
    trajectory
        States ``x_p(0..H)`` and inputs ``u_p(0..H-1)`` of every agent of the mission.
    tol
        Tolerance of the dynamics and bounds checks: each number of the trajectory may be off
        by ``tol * max(1, |v|)`` (:mod:`stlplan.monitor.dynamics`).
    slack
        How far below ``HOLDS_AT`` a requirement's robustness may fall and still hold (0 for
        plans; a user's ``--tolerance`` for rounded trajectories from other tools).
    planned_only
        For a replan: judge constraints and separation from its step ``K`` on only (what the
        plan decided): neither the executed past nor a part at ``K`` that the executed state
        breaks, nor the segment from it.

    Raises
    ------
    TrajectoryError
        If the trajectory's horizon, agents or array shapes do not fit the mission.
    """
    _check_shapes(problem, trajectory)
    verdicts: list[Verdict] = []
    for task in problem.tasks:
        verdicts.append(_task_verdict(problem, trajectory, task, slack))
    first = problem.past.step if planned_only and problem.past is not None else 0
    for constraint in problem.constraints:
        verdicts.append(_constraint_verdict(problem, trajectory, constraint, slack, first))
    if problem.separation is not None:
        verdicts.append(separation_verdict(problem, trajectory, slack, first))
    for agent in problem.agents:
        verdicts.append(dynamics_verdict(agent, trajectory, tol, problem.past))
    return MonitorReport(tuple(verdicts), known=trajectory.known, tolerance=tol)


def non_position_reads(problem: Problem) -> list[str]:
    """Where a task or constraint reads a state component that is not its agent's position
    (``name: p.x[2] of uv1``); empty when the positions alone decide every requirement."""
    found = []
    named: list[tuple[str, Formula, list[Mapping[str, str]]]] = [
        (t.name, t.formula, [t.binding(e) for e in t.elements]) for t in problem.tasks
    ]
    named += [(c.name, c.formula, list(c.bindings)) for c in problem.constraints]
    for name, formula, bindings in named:
        terms = [t for a in atoms(formula) if isinstance(a, Linear) for t in a.terms]
        for binding in bindings:
            for term in terms:
                agent = problem.agent(binding[term.role])
                if term.component not in agent.position:
                    found.append(f"{name}: {term.role}.x[{term.component}] of {agent.name}")
    return list(dict.fromkeys(found))


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


def _task_verdict(
    problem: Problem, trajectory: Trajectory, task: TaskModel, slack: float
) -> Verdict:
    rho = element_robustness(problem, trajectory, task)
    if task.sync is not None:
        return _synchronous_verdict(task, rho, slack)
    # rho(T) = max over groups of min_{e in group} rho_e(0), without enumerating groups
    value, group = best_group(task.elements, rho[:, 0], task.count, task.reuse_agents)
    chosen = () if group is None else group
    satisfied = bool(holds(value, slack))
    text = _group_text(task, chosen)
    detail = (
        f"group {text} holds with margin {value:.3g}"
        if satisfied
        else f"no group satisfies: best {text} reaches {value:.3g}"
    )
    return Verdict(
        task.name, "task", satisfied, value, _group_elements(task, chosen), detail=detail
    )


def run_lengths(holds: np.ndarray) -> np.ndarray:
    """``run[j, k]``: consecutive steps ``k, k+1, ...`` with ``holds[j, .] = True``.

    Computed backwards: ``run[j, k] = holds[j, k] * (1 + run[j, k+1])`` with ``run[j, K] = 0``.
    """
    run = np.zeros((holds.shape[0], holds.shape[1] + 1), dtype=int)
    for k in range(holds.shape[1] - 1, -1, -1):
        run[:, k] = np.where(holds[:, k], run[:, k + 1] + 1, 0)
    return run[:, :-1]


@dataclass(frozen=True)
class Start:
    """The best group from one start ``k'``: its run length and spatial robustness."""

    start: int
    length: int
    spatial: float
    group: tuple[int, ...]


def _best_from(task: TaskModel, rho: np.ndarray, run: np.ndarray, start: int) -> Start:
    """The longest common run of a group from ``start``, and among the groups with that run the
    best spatial robustness of ``G[0,d] AND_e phi_e`` (``-inf`` where the window leaves the
    signal)."""
    assert task.sync is not None
    d, elems, c = task.sync.d, task.elements, task.count
    steps = rho.shape[1]
    runs = run[:, start] if start < steps else np.zeros(len(elems), dtype=int)
    length, group = best_group(elems, runs.astype(float), c, task.reuse_agents)
    if start + d < steps:
        window = np.min(rho[:, start : start + d + 1], axis=1)
    else:
        window = np.full(len(elems), -np.inf)
    keep = np.where(runs >= length, window, -np.inf)
    spatial, best = best_group(elems, keep, c, task.reuse_agents)
    return Start(start, int(length), spatial, best or group or ())


def _synchronous_verdict(task: TaskModel, rho: np.ndarray, slack: float) -> Verdict:
    """``rho_s = max_{k' in [a,b]} (longest common run of a group from k') - 1 - d``: for each
    start, the longest run any group keeps is found by :func:`best_group` over the elements'
    own runs (a group's common run is the least of its elements' runs)."""
    assert task.sync is not None
    a, b, d = task.sync.a, task.sync.b, task.sync.d
    run = run_lengths(holds(np.nan_to_num(rho, nan=-np.inf), slack))
    starts = [_best_from(task, rho, run, k) for k in range(a, b + 1)]
    # the longest run, then the earliest start, then the best spatial robustness
    best = max(starts, key=lambda s: (s.length, -s.start, s.spatial))
    rho_s = best.length - 1 - d
    spatial_rho = max(_spatial_anywhere(task, rho, k) for k in range(a, b + 1))
    return Verdict(
        task.name,
        "synchronous",
        rho_s >= 0,
        spatial_rho,
        _group_elements(task, best.group),
        rho_s=float(rho_s),
        counted=float(min(rho_s, task.sync.gamma)) if rho_s >= 0 else float(rho_s),
        run_start=best.start,
        run_length=best.length,
        detail=_synchronous_detail(task, best.group, best.start, best.length, rho_s),
    )


def _spatial_anywhere(task: TaskModel, rho: np.ndarray, start: int) -> float:
    """Best spatial robustness of ``G[0,d] AND_e phi_e`` from ``start`` over every group."""
    assert task.sync is not None
    d = task.sync.d
    if start + d >= rho.shape[1]:
        return float("-inf")
    window = np.min(np.nan_to_num(rho[:, start : start + d + 1], nan=-np.inf), axis=1)
    return best_group(task.elements, window, task.count, task.reuse_agents)[0]


def _capped(task: TaskModel, rho_s: int) -> str:
    """Why the objective counts less than ``rho_s``: its cap gamma (DESIGN 2.1)."""
    assert task.sync is not None
    gamma = task.sync.gamma
    return f", counted up to gamma = {gamma:g}" if rho_s > gamma else ""


def _synchronous_detail(
    task: TaskModel, group: Sequence[int], start: int, length: int, rho_s: int
) -> str:
    assert task.sync is not None
    need = task.sync.d + 1
    text = _group_text(task, group)
    if rho_s >= 0:
        return (
            f"group {text} holds phi together for {counted(length, 'step')} from step {start} "
            f"(needs {need}): rho_s = {rho_s}{_capped(task, rho_s)}"
        )
    if length == 0:
        return (
            f"no group holds phi together at any start in [{task.sync.a}, {task.sync.b}] "
            f"(needs {counted(need, 'step')}): rho_s = {rho_s}"
        )
    return (
        f"no group holds phi together for {counted(need, 'step')}: best {text} for {length} from step "
        f"{start}, rho_s = {rho_s}"
    )


def _binding_text(binding: dict[str, str]) -> str:
    return ", ".join(f"{role}={agent}" for role, agent in binding.items())


def _binding_value(
    problem: Problem,
    trajectory: Trajectory,
    constraint: ConstraintModel,
    binding: Any,
    first: int = 0,
) -> tuple[float, str]:
    """``rho(phi, 0)`` under ``binding``, or the worst segment's ``rho_seg`` when lower (and
    where); from step ``first`` on, the least ``rho`` of the parts of ``phi`` (``G`` and ``and``
    unrolled) that read a step from ``first`` on."""
    signals = {role: trajectory.states[name] for role, name in binding.items()}
    lowered = problem.lowered(constraint.formula, binding)
    H = problem.horizon
    if first:
        parts = [(p, k) for p, k in step_parts(lowered, 0) if k + horizon(p) >= first]
        values = [(float(robustness(p, signals, H)[k]), k + horizon(p)) for p, k in parts]
        # a part at K itself reads the executed state only: data, not the plan's
        sampled = min((v for v, end in values if end > first), default=np.inf)
    else:
        sampled = float(robustness(lowered, signals, H)[0])
    start = 0 if problem.past is None else problem.past.step
    crossing = (
        worst_segment(lowered, signals, H, start, planned=bool(first))
        if problem.inter_sample
        else None
    )
    if crossing is None or not crossing.value < sampled - 1e-12:
        return sampled, ""
    return crossing.value, f" on the segment {crossing.step} -> {crossing.step + 1}"


def _constraint_verdict(
    problem: Problem,
    trajectory: Trajectory,
    constraint: ConstraintModel,
    slack: float,
    first: int = 0,
) -> Verdict:
    # rho(constraint) = min over bindings of rho(phi, 0) (and of rho_seg on the segments)
    values, segments = [], []
    for binding in constraint.bindings:
        value, where = _binding_value(problem, trajectory, constraint, binding, first)
        values.append(value)
        segments.append(where)
    if not values:
        return Verdict(constraint.name, "constraint", True, float("inf"), detail="no binding")
    worst = int(np.argmin(np.where(np.isnan(values), -np.inf, values)))
    value = values[worst]
    failing = sum(1 for v in values if not holds(v, slack))
    who = _binding_text(dict(constraint.bindings[worst])) + segments[worst]
    if failing == 0:
        every = "the 1 binding" if len(values) == 1 else f"all {len(values)} bindings"
        detail = f"holds for {every}; tightest {who} with margin {value:.3g}"
    else:
        some = f"{failing} of {counted(len(values), 'binding')}"
        detail = f"fails for {some}; worst {who} reaches {value:.3g}"
    return Verdict(constraint.name, "constraint", failing == 0, value, detail=detail)
