"""MILP encoding of global tasks, synchronous robustness, constraints and separation.

Paper section 5, with DESIGN section 2.1 for the synchronous robustness:

* a task ``T = <phi, c, Pattern>`` holds at 0 iff some group has every element satisfy ``phi``:
  ``h_T = 1``, ``{1 - h_T, h_1..h_N}`` SOS1 and ``h_j <= h[element, phi, 0]`` for every element of
  group ``j``. Each element's ``phi`` is encoded once and shared by the groups that hold it;
* a synchronous task ``F[a,b] <G[0,d] phi, c, Pattern>`` counts, for each group ``j``, the run of
  consecutive steps on which every element satisfies ``phi`` (counting variables ``c_j``), and
  ``rho_s = max_j max_{k' in [a,b]} c_j(k') - 1 - d`` with ``0 <= rho_s <= gamma``;
* constraints hold at step 0 under every binding; separation holds at every step for every pair.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from pyomo.environ import value

from stlplan.formula.tree import Distance, Formula, Or, Predicate, horizon, step_parts
from stlplan.mission.checks import check_group_count
from stlplan.mission.problem import Problem, TaskModel
from stlplan.planner.encoding.sos1 import sos1
from stlplan.planner.encoding.stl import StlContext, encode, indicator, require


@dataclass(frozen=True, eq=False)
class TaskEncoding:
    """A task's group indicators ``h_j`` (a constant 1 when the task has a single group)."""

    task: TaskModel
    groups: tuple[Any, ...]


@dataclass(frozen=True, eq=False)
class SyncEncoding:
    """A synchronous task's robustness ``rho_s`` and counting variables ``c_j(k')``."""

    task: TaskModel
    rho_s: Any
    counts: Mapping[tuple[int, int], Any]
    """``(group j, step k')`` to ``c_j(k')`` for ``k'`` from ``a`` to the last step of ``phi``."""


def element_formulas(problem: Problem, task: TaskModel) -> list[tuple[Formula, dict[str, str]]]:
    """Each element's lowered ``phi`` with its binding, in element order."""
    out = []
    for element in task.elements:
        binding = task.binding(element)
        out.append((problem.lowered(task.formula, binding), binding))
    return out


def separation_formula(problem: Problem, first: str, second: str) -> Formula:
    """``||z_p - z_q||_inf >= separation``, lowered: an ``Or`` of four half-planes."""
    assert problem.separation is not None
    atom = Distance("p", "q", ">=", problem.separation)
    return problem.lowered(atom, {"p": first, "q": second})


def all_formulas(problem: Problem) -> list[tuple[Formula, dict[str, str]]]:
    """Every lowered formula the model enforces, with its binding (for bounds on the margin)."""
    out = [f for task in problem.tasks for f in element_formulas(problem, task)]
    for constraint in problem.constraints:
        for binding in constraint.bindings:
            out.append((problem.lowered(constraint.formula, binding), dict(binding)))
    if problem.separation is not None:
        for p, q in itertools.combinations([a.name for a in problem.agents], 2):
            out.append((separation_formula(problem, p, q), {"p": p, "q": q}))
    return out


def encode_task(ctx: StlContext, problem: Problem, task: TaskModel) -> TaskEncoding:
    """Group choice of a task at step 0.

    ``h_T = 1``, ``{1 - h_T, h_1..h_N}`` SOS1 and ``h_j <= h[element, phi, 0]`` for each element
    of group ``j``. A single group needs no choice: its elements' ``phi`` are required outright.
    """
    check_group_count(problem.mission, task.name, task.elements, problem.source)
    formulas = element_formulas(problem, task)
    if len(task.groups) == 1:
        for i in task.groups[0]:
            formula, binding = formulas[i]
            require(formula, 0, ctx.bound(binding))
        return TaskEncoding(task, (1.0,))
    used = sorted({i for group in task.groups for i in group})
    h_element = {i: encode(formulas[i][0], 0, ctx.bound(formulas[i][1])) for i in used}
    h_task = indicator(ctx)
    ctx.block.rows.add(h_task == 1)
    h_groups = [indicator(ctx) for _ in task.groups]
    for h_group, group in zip(h_groups, task.groups, strict=True):
        for i in group:
            ctx.block.rows.add(h_group <= h_element[i])
        ctx.ledger.conjunctions.append((h_group, [h_element[i] for i in group]))
    sos1(ctx.sos, [1 - h_task, *h_groups], ctx.encoding)
    ctx.ledger.choices.append((h_task, h_groups, h_groups))
    return TaskEncoding(task, tuple(h_groups))


def count_run(ctx: StlContext, q: Any, following: Any, cap: int) -> Any:
    """``c = (c_next + 1) q`` linearized exactly, with ``0 <= c <= cap`` and ``c_next <= cap - 1``.

    ``c <= cap q``, ``c <= c_next + 1``, ``c >= c_next + 1 - cap (1 - q)``.
    """
    c = ctx.block.reals.add()
    c.setlb(0)
    c.setub(cap)
    ctx.block.rows.add(c <= cap * q)
    ctx.block.rows.add(c <= following + 1)
    ctx.block.rows.add(c >= following + 1 - cap * (1 - q))
    return c


def group_runs(
    ctx: StlContext, task: TaskModel, h: Mapping[tuple[int, int], Any], start: int, last: int
) -> dict[tuple[int, int], Any]:
    """Counting variables ``c_j(k')`` for ``k' = start..last`` from binaries ``q_j(k')``.

    ``q_j(k') <= h[element, phi, k']`` for every element of group ``j``, ``q_j(k') in {0, 1}``,
    ``c_j(k') = (c_j(k'+1) + 1) q_j(k')`` and ``c_j(last + 1) = 0``.
    """
    counts: dict[tuple[int, int], Any] = {}
    for j, group in enumerate(task.groups):
        following: Any = 0
        for k in range(last, start - 1, -1):
            q = ctx.block.binaries.add()
            for i in group:
                ctx.block.rows.add(q <= h[i, k])
            ctx.ledger.conjunctions.append((q, [h[i, k] for i in group]))
            following = counts[j, k] = count_run(ctx, q, following, last - k + 1)
    return counts


def encode_synchronous(ctx: StlContext, problem: Problem, task: TaskModel) -> SyncEncoding:
    """Synchronous robustness of ``F[a,b] <G[0,d] phi, c, Pattern>`` (DESIGN 2.1).

    With selection entries ``lambda_jk'`` SOS1 (one ``(j, k')`` chosen, ``k' in [a, b]``):
    ``rho_s + 1 + d <= c_j(k') + (rho_max + 1 + d)(1 - lambda_jk')`` and
    ``0 <= rho_s <= rho_max = min(gamma, last - a - d)`` (no run from ``k' >= a`` is longer than
    ``last - a + 1``), so ``rho_s <= max_j max_{k' in [a,b]} c_j(k') - 1 - d``, tight when
    maximized.
    """
    assert task.sync is not None
    a, b, d, gamma = task.sync.a, task.sync.b, task.sync.d, task.sync.gamma
    last = problem.horizon - horizon(task.formula)
    check_group_count(problem.mission, task.name, task.elements, problem.source)
    formulas = element_formulas(problem, task)
    used = sorted({i for group in task.groups for i in group})
    h = {
        (i, k): encode(formulas[i][0], k, ctx.bound(formulas[i][1]))
        for i in used
        for k in range(a, last + 1)
    }
    counts = group_runs(ctx, task, h, a, last)
    rho_s = ctx.block.reals.add()
    rho_s.setlb(0)
    rho_s.setub(min(gamma, last - a - d))  # a run from k' >= a has at most last - a + 1 steps
    starts = [(j, k) for j in range(len(task.groups)) for k in range(a, b + 1)]
    chosen = [indicator(ctx) for _ in starts]
    if len(chosen) == 1:
        ctx.block.rows.add(chosen[0] == 1)
    else:
        sos1(ctx.sos, chosen, ctx.encoding)
    big_m = rho_s.ub + 1 + d
    for lam, start in zip(chosen, starts, strict=True):
        ctx.block.rows.add(rho_s + 1 + d <= counts[start] + big_m * (1 - lam))
    return SyncEncoding(task, rho_s, counts)


def executed(problem: Problem, part: Formula, k: int) -> bool:
    """Whether ``part`` at step ``k`` is a replan's data, not planned: it reads only steps before
    ``K``, or is a disjunction of half-planes at ``K`` (whose segment to ``K+1`` is planned,
    :func:`stlplan.planner.encoding.deferred.segment_end`)."""
    if problem.past is None:
        return False
    planes = [part] if isinstance(part, Predicate) else list(getattr(part, "children", ()))
    is_planes = isinstance(part, (Predicate, Or)) and all(isinstance(p, Predicate) for p in planes)
    at_k = k == problem.past.step and is_planes
    return problem.in_past(part, k) or at_k


def encode_constraints(ctx: StlContext, problem: Problem) -> None:
    """Every constraint holds at step 0 under each of its bindings (a replan's parts in its
    executed past left out)."""
    for constraint in problem.constraints:
        for binding in constraint.bindings:
            lowered = problem.lowered(constraint.formula, binding)
            if problem.past is None:
                require(lowered, 0, ctx.bound(binding))
                continue
            for part, k in step_parts(lowered, 0):
                if not executed(problem, part, k):
                    require(part, k, ctx.bound(binding))


def encode_separation(ctx: StlContext, problem: Problem) -> None:
    """``|dx| >= r or |dy| >= r`` (four half-planes) for every pair of agents and step ``0..H``
    (a replan's from ``K+1``; a pair its past left too close from the step it is restored)."""
    if problem.separation is None:
        return
    for p, q in itertools.combinations([a.name for a in problem.agents], 2):
        formula = separation_formula(problem, p, q)
        scope = ctx.bound({"p": p, "q": q})
        for k in range(problem.separated_from(p, q), problem.horizon + 1):
            if not executed(problem, formula, k):
                require(formula, k, scope)


def chosen_group(encoding: TaskEncoding) -> int:
    """Index of the group whose indicator is (closest to) 1 in the loaded solution."""
    values = [float(value(h)) for h in encoding.groups]
    return max(range(len(values)), key=values.__getitem__)


def best_run(encoding: SyncEncoding) -> tuple[int, int, int]:
    """``(group, start, length)`` of the longest counted run starting in ``[a, b]``."""
    assert encoding.task.sync is not None
    a, b = encoding.task.sync.a, encoding.task.sync.b
    runs = {key: round(float(value(c))) for key, c in encoding.counts.items() if a <= key[1] <= b}
    (j, start), length = max(runs.items(), key=lambda item: (item[1], -item[0][1], -item[0][0]))
    return j, start, length
