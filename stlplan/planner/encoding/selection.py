"""Tasks encoded by selecting elements (DESIGN 2.12): no group is enumerated.

A task ``T = <phi, c, Pattern>`` with elements ``e_1..e_N`` holds iff some group (``c`` elements
sharing no agent, unless the task reuses agents) has every element satisfy ``phi``. With
``h_e = h[e, phi, 0]`` the indicator of ``phi`` for element ``e`` (encoded once per element, as in
the group encoding), a binary ``x_e`` per element says "``e`` is chosen":

    sum_e x_e = c,    sum_{e containing p} x_e <= 1  for every agent p,    x_e <= h_e.

*Equivalence with the group encoding.* A group ``j`` with ``h_j = 1`` gives ``x_e = 1`` exactly on
its elements: ``c`` of them, no agent twice, each with ``h_e >= h_j = 1``. Conversely the chosen
elements of a feasible ``x`` are ``c`` distinct elements sharing no agent, i.e. a group, and each
has ``h_e = 1``, so the group encoding's ``h_j = 1`` is feasible for the same trajectory. Both
models therefore admit the same trajectories, margins and efforts.

A synchronous task ``F[a,b] <G[0,d] phi, c, Pattern>`` adds a start ``sigma_k'`` (SOS1 over
``k' in [a, b]``, exactly one is 1) and a window ``y_k in {0, 1}`` for ``k = a..K`` (``K`` the last
step at which ``phi`` can be decided):

    y_a <= sigma_a,   y_k <= y_{k-1} + sigma_k  (sigma_k = 0 for k > b),
    x_e + y_k - 1 <= h[e, phi, k],
    rho_s + 1 + d <= sum_k y_k,   0 <= rho_s <= min(gamma, K - a - d).

*Equivalence with DESIGN 2.1.* The window can switch on only at the chosen start and, once off,
never again, so ``{k : y_k = 1}`` is one run ``[k', k' + L - 1]`` with ``k' in [a, b]`` (or empty).
Every chosen element satisfies ``phi`` on it, so the chosen group's common run from ``k'`` is at
least ``L`` and ``rho_s <= L - 1 - d <= max_j max_{k'} c_j(k') - 1 - d``. Conversely, for the
group ``j`` and start ``k'`` attaining that maximum with run ``R``, ``x`` on ``j``'s elements,
``sigma_k' = 1`` and ``y = 1`` on ``[k', k' + R - 1]`` is feasible with ``rho_s = min(gamma,
R - 1 - d)``. The largest feasible ``rho_s`` is therefore the group encoding's, and the cap gamma
applies in both.

Effort floors (:mod:`stlplan.planner.encoding.floors`) read the links: per agent ``p``, the
elements containing ``p`` form a choice ``sum x_e <= 1`` with ``x_e <= h_e``, so
``e_q >= sum_{e containing p} floor_q(h_e) x_e`` holds for every agent ``q``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from pyomo.environ import value

from stlplan.formula.tree import horizon
from stlplan.mission.problem import Problem, TaskModel
from stlplan.planner.encoding.sos1 import sos1
from stlplan.planner.encoding.stl import StlContext, encode, indicator, require

"""How tasks choose their elements: the paper's group enumeration, or selection."""


@dataclass(frozen=True, eq=False)
class Selection:
    """A task's element choices ``x_e`` (binaries, in element order)."""

    task: TaskModel
    chosen: tuple[Any, ...]

    def elements(self) -> tuple[int, ...]:
        """Indices of the elements chosen in the loaded solution."""
        return tuple(i for i, x in enumerate(self.chosen) if float(value(x)) > 0.5)


@dataclass(frozen=True, eq=False)
class SyncSelection(Selection):
    """A synchronous task's choices, start ``sigma_k'`` (``k' = a..b``), window ``y_k``
    (``k = a..K``) and robustness ``rho_s``."""

    rho_s: Any = None
    starts: tuple[Any, ...] = ()
    window: tuple[Any, ...] = ()

    def run(self) -> tuple[int, int]:
        """``(start, length)`` of the window in the loaded solution."""
        assert self.task.sync is not None
        a = self.task.sync.a
        start = max(range(len(self.starts)), key=lambda i: float(value(self.starts[i])))
        length = sum(round(float(value(y))) for y in self.window)
        return a + start, length


def choose_elements(ctx: StlContext, task: TaskModel) -> tuple[Any, ...]:
    """Binaries ``x_e`` with ``sum x_e = c`` and, unless the task reuses agents, each agent in at
    most one chosen element (recorded as a choice per agent for the effort floors)."""
    chosen = tuple(ctx.block.binaries.add() for _ in task.elements)
    ctx.block.rows.add(sum(chosen) == task.count)
    if task.reuse_agents:
        return chosen
    for agent in sorted({a for element in task.elements for a in element}):
        mine = [x for x, element in zip(chosen, task.elements, strict=True) if agent in element]
        if len(mine) > 1:
            ctx.block.rows.add(sum(mine) <= 1)
    return chosen


def link_floors(ctx: StlContext, task: TaskModel, chosen: Sequence[Any], h: Sequence[Any]) -> None:
    """Record ``x_e <= h_e`` for the effort floors: per agent, its elements form a choice."""
    if task.reuse_agents:
        for x, h_e in zip(chosen, h, strict=True):
            ctx.ledger.conjunctions.append((x, [h_e]))
        return
    for agent in sorted({a for element in task.elements for a in element}):
        mine = [n for n, element in enumerate(task.elements) if agent in element]
        ctx.ledger.choices.append((None, [h[n] for n in mine], [chosen[n] for n in mine]))
        service = (task.name, agent, [h[n] for n in mine], [chosen[n] for n in mine])
        ctx.ledger.services.append(service)


def select_task(ctx: StlContext, problem: Problem, task: TaskModel) -> Selection:
    """``x_e <= h[e, phi, 0]`` over the chosen elements (see the module docstring)."""
    formulas = [problem.lowered(task.formula, task.binding(e)) for e in task.elements]
    bindings = [task.binding(e) for e in task.elements]
    if len(task.elements) == task.count and not _shares_agents(task):
        for formula, binding in zip(formulas, bindings, strict=True):
            require(formula, 0, ctx.bound(binding))  # every element must hold: no choice
        return Selection(task, tuple(1.0 for _ in task.elements))
    h = [encode(f, 0, ctx.bound(b)) for f, b in zip(formulas, bindings, strict=True)]
    chosen = choose_elements(ctx, task)
    for x, h_e, element in zip(chosen, h, task.elements, strict=True):
        ctx.block.rows.add(x <= h_e)
        ctx.ledger.elements.append((x, h_e, tuple(element)))
    link_floors(ctx, task, chosen, h)
    return Selection(task, chosen)


def _shares_agents(task: TaskModel) -> bool:
    """Whether two of the task's elements share an agent (then not all can be chosen)."""
    if task.reuse_agents:
        return False
    agents = [a for element in task.elements for a in element]
    return len(agents) != len(set(agents))


def window_run(ctx: StlContext, a: int, b: int, last: int) -> tuple[list[Any], list[Any]]:
    """Start entries ``sigma_k'`` (SOS1, ``k' = a..b``) and window binaries ``y_k``
    (``k = a..last``) with ``y_a <= sigma_a`` and ``y_k <= y_{k-1} + sigma_k``."""
    starts = [indicator(ctx) for _ in range(a, b + 1)]
    if len(starts) == 1:
        ctx.block.rows.add(starts[0] == 1)
    else:
        sos1(ctx.sos, starts, ctx.encoding)
    window = [ctx.block.binaries.add() for _ in range(a, last + 1)]
    previous: Any = 0
    for k, y in zip(range(a, last + 1), window, strict=True):
        opening = starts[k - a] if k <= b else 0
        ctx.block.rows.add(y <= previous + opening)
        previous = y
    return starts, window


def select_synchronous(ctx: StlContext, problem: Problem, task: TaskModel) -> SyncSelection:
    """Synchronous robustness of ``F[a,b] <G[0,d] phi, c, Pattern>`` by selection (see the
    module docstring)."""
    assert task.sync is not None
    a, b, d, gamma = task.sync.a, task.sync.b, task.sync.d, task.sync.gamma
    last = problem.horizon - horizon(task.formula)
    chosen = choose_elements(ctx, task)
    starts, window = window_run(ctx, a, b, last)
    for element, x in zip(task.elements, chosen, strict=True):
        binding = task.binding(element)
        scope = ctx.bound(binding)
        formula = problem.lowered(task.formula, binding)
        for k, y in zip(range(a, last + 1), window, strict=True):
            ctx.block.rows.add(x + y - 1 <= encode(formula, k, scope))
    rho_s = ctx.block.reals.add()
    rho_s.setlb(0)
    rho_s.setub(min(gamma, last - a - d))  # a run from k' >= a has at most last - a + 1 steps
    ctx.block.rows.add(rho_s + 1 + d <= sum(window))
    return SyncSelection(task, chosen, rho_s, tuple(starts), tuple(window))
