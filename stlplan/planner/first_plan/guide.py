"""A path in the plane and in time for one agent around fixed others: the sides of a turn.

A prioritized turn (:mod:`stlplan.planner.first_plan.prioritized`) is a MILP with a disjunction for every
step its agent may meet an earlier one, and late in a large crowd it takes seconds. Prioritized
path planners search space and time instead (a grid of positions, one layer per step). This
module does that for an agent that moves as a single integrator in the plane: ``x(k+1) = x(k) +
B u(k)`` with ``x`` its position, ``B`` diagonal and ``u`` in a box. With the other agents'
states as numbers, every alternative of a requirement of the turn is a half-plane in the
agent's position, ``a . p >= c(t) + r``, so a grid path can be checked against all of them.

The search finds, layer by layer, the path closest to a reference (the agent's plan on its own:
the sum of the L1 distances to it, plus a little per move) whose every segment keeps one
alternative of each segment requirement at both of its ends, and whose every step keeps one of
each step requirement. The grid of step ``t`` is centred on the reference's position at ``t``,
its spacing a third of the longest move along each axis, so where nothing is in the way the
path is the reference itself: its task met as the reference meets it, on the boundaries of its
regions included. The path is not the plan: the turn takes the side it keeps of each
requirement (:func:`stlplan.planner.encoding.deferred.best_side`) as a row without a binary,
and solves the agent's own model for the plan (its task, its effort).

Only the neighbourhood of each requirement is examined, from the cells the search reached: with
axis-parallel alternatives (boxes: obstacles, separation in the infinity norm) a segment can
break a requirement only within a move of the region that breaks every alternative; other
alternatives are examined on the whole grid (:mod:`stlplan.planner.first_plan.guide_stops`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from stlplan.mission.problem import AgentModel, Problem
from stlplan.planner.encoding.alphas import in_position
from stlplan.planner.encoding.deferred import Requirement
from stlplan.planner.first_plan.guide_stops import Grid, HalfPlanes, reached, stopped
from stlplan.planner.first_plan.witness import witness
from stlplan.planner.tolerances import ROOM, ROUND_OFF

CELLS_PER_MOVE = 3
"""Grid spacing: the longest move along an axis is this many cells."""
REACH_MOVES = 12
"""How far the path may stray from the reference along an axis, in longest moves."""
MOVE_COST = 0.1
"""Cost of a move per unit of length, against 1 per unit of distance from the reference."""


def single_integrator(agent: AgentModel) -> bool:
    """Whether ``agent`` moves as a single integrator in the plane (the module's model)."""
    if agent.n != 2 or agent.m != 2 or tuple(agent.position) != (0, 1):
        return False
    b = agent.B
    diagonal = bool(np.all(np.diag(b) != 0) and b[0, 1] == 0 and b[1, 0] == 0)
    reach = np.maximum(np.abs(np.diag(b) * agent.input_lo), np.abs(np.diag(b) * agent.input_hi))
    return bool(np.array_equal(agent.A, np.eye(2)) and diagonal and np.all(reach > 0))


def make_grid(agent: AgentModel, reference: np.ndarray) -> Grid:
    """The grid of ``agent`` around ``reference``."""
    ends = np.stack([np.diag(agent.B) * agent.input_lo, np.diag(agent.B) * agent.input_hi])
    low, high = ends.min(axis=0), ends.max(axis=0)
    h = np.maximum(np.abs(low), np.abs(high)) / CELLS_PER_MOVE
    n = np.full(2, CELLS_PER_MOVE * REACH_MOVES)
    return Grid(np.asarray(reference, float), h, n, low, high)


@dataclass(frozen=True)
class Search:
    """A path (positions from the first free step on), or None and the agents whose
    requirements stopped the moves the search had left."""

    path: np.ndarray | None
    blockers: frozenset[str] = frozenset()


def readable_planes(
    requirements: Sequence[Requirement], agent: str, fixed: Mapping[str, np.ndarray], margin: float
) -> list[HalfPlanes]:
    """The requirements that read no agent but ``agent`` and those of ``fixed``, with the
    states of ``fixed`` as numbers, in order."""
    if not requirements:
        return []
    where = in_position(requirements, agent, fixed, 2)
    c = where.c + margin + ROOM  # room for the plan to move
    ends = np.append(where.firsts, len(where.alternatives))
    out = []
    for r, req in enumerate(requirements):
        if not where.readable[r]:
            continue
        alts, steps, slot = ends[r + 1] - ends[r], len(req.steps), where.alternatives[ends[r]]
        planes = c[slot : slot + alts * steps].reshape(alts, steps)
        reads = frozenset(req.binding.values()) - {agent}
        out.append(HalfPlanes(where.a[ends[r] : ends[r + 1]], planes, req.k, req.span, reads))
    return out


def _shifted(values: np.ndarray, move: np.ndarray, fill: float) -> np.ndarray:
    """``values`` moved by ``move`` cells: ``out[p + move] = values[p]``."""
    out = np.full_like(values, fill)
    dx, dy = int(move[0]), int(move[1])
    nx, ny = values.shape
    if abs(dx) >= nx or abs(dy) >= ny:
        return out
    src = values[max(0, -dx) : nx - max(0, dx), max(0, -dy) : ny - max(0, dy)]
    out[max(0, dx) : nx - max(0, -dx), max(0, dy) : ny - max(0, -dy)] = src
    return out


def _outside(grid: Grid, t: int, agent: AgentModel) -> np.ndarray:
    """The cells of step ``t`` outside the agent's state bounds."""
    xs, ys = grid.points(t)
    lo, hi = agent.state_lo, agent.state_hi
    return (xs < lo[0]) | (xs > hi[0]) | (ys < lo[1]) | (ys > hi[1])


def search(
    grid: Grid,
    agent: AgentModel,
    first: int,
    requirements: Sequence[HalfPlanes],
    weights: np.ndarray,
) -> Search:
    """The path from the reference's position at step ``first`` to the horizon closest to
    the reference (its distance at step ``t`` weighted by ``weights[t]``) that keeps
    ``requirements``: its positions at steps ``first..H``, or why there is none."""
    by_step: dict[int, list[HalfPlanes]] = {}
    for hp in requirements:  # the moves from step t read the segment (t, t+1) and step t+1
        by_step.setdefault(hp.k if hp.span else hp.k - 1, []).append(hp)
    centre = tuple(int(v) for v in grid.n)
    offsets = np.abs(np.indices(grid.shape) - grid.n[:, None, None])
    far = grid.h[0] * offsets[0] + grid.h[1] * offsets[1]  # L1 distance from the reference
    cost = np.full(grid.shape, np.inf)
    cost[centre] = 0.0
    parents = []
    for t in range(first, len(grid.reference) - 1):
        cells, shifts = grid.moves(t)
        stop = stopped(by_step.get(t, ()), grid, t, shifts, reached(cost), CELLS_PER_MOVE + 1)
        best, parent = np.full(grid.shape, np.inf), np.full(grid.shape, -1, dtype=int)
        length = MOVE_COST * np.abs(shifts).sum(axis=1)
        for m, move in enumerate(cells):
            arrive = _shifted(np.where(stop[m], np.inf, cost), move, np.inf) + length[m]
            better = arrive < best
            best[better], parent[better] = arrive[better], m
        best[_outside(grid, t + 1, agent)] = np.inf
        if not np.isfinite(best).any():
            return Search(None, _blockers(by_step.get(t, ()), grid, t, shifts, cost))
        cost = best + weights[t + 1] * far
        parents.append((cells, parent))
    return Search(_backtrack(grid, first, cost, parents))


def _blockers(
    found: Sequence[HalfPlanes], grid: Grid, t: int, shifts: np.ndarray, cost: np.ndarray
) -> frozenset[str]:
    """The agents read by the requirements of ``found`` that stop a move from a cell the
    search reached at step ``t``."""
    near, out = reached(cost), set[str]()
    for hp in found:
        stop = stopped([hp], grid, t, shifts, near, CELLS_PER_MOVE + 1)
        if (stop & np.isfinite(cost)).any():
            out |= hp.reads
    return frozenset(out)


def _backtrack(
    grid: Grid, first: int, cost: np.ndarray, parents: Sequence[tuple[np.ndarray, np.ndarray]]
) -> np.ndarray:
    i, j = np.unravel_index(int(np.argmin(cost)), grid.shape)
    cell = (int(i), int(j))
    cells = [cell]
    for moves, parent in reversed(parents):
        move = moves[parent[cell]]
        cell = (int(cell[0] - move[0]), int(cell[1] - move[1]))
        cells.append(cell)
    cells.reverse()
    return np.array([grid.origin(first + t) + grid.h * np.array(c) for t, c in enumerate(cells)])


def task_planes(
    problem: Problem, agent: str, reference: np.ndarray, margin: float
) -> list[HalfPlanes]:
    """The half-planes, one a step, by which ``reference`` (the plan of ``agent`` alone in
    ``problem``) meets each of its tasks of one element and no synchronous window
    (:mod:`stlplan.planner.first_plan.witness`): a path keeping them all meets those tasks too. Each is
    raised to the task's margin, but never past the reference, which keeps them all."""
    out = []
    for task in problem.tasks:
        bindings = [task.binding(e) for e in task.elements]
        if task.sync is not None or task.count != 1 or len(bindings) != 1:
            continue
        if set(bindings[0].values()) != {agent}:
            continue
        formula = problem.lowered(task.formula, bindings[0])
        kept = witness(formula, {role: reference for role in bindings[0]})
        for w in kept or ():
            a = np.zeros((1, 2))
            for term in w.predicate.terms:
                a[0, term.component] += term.coef
            wanted = w.predicate.bound + margin + problem.tightening(w.predicate, w.step)
            c = min(wanted, float(a[0] @ reference[w.step, :2])) - ROUND_OFF
            out.append(HalfPlanes(a, np.array([[c]]), w.step, 0))
    return out


def guide_path(
    agent: AgentModel,
    first: int,
    reference: np.ndarray,
    requirements: Sequence[Requirement],
    fixed: Mapping[str, np.ndarray],
    margin: float,
    late: bool = False,
    task: Sequence[HalfPlanes] = (),
) -> Search:
    """The agent's positions at steps ``0..H`` (``reference`` up to ``first``, then a grid
    path) keeping one alternative of every requirement it can read and every half-plane of
    ``task``; or no path, and the agents in the way. ``late``: a step's distance from the
    reference weighs more the later it is (the path strays early rather than late, when the
    reference ends where the task wants it)."""
    grid = make_grid(agent, reference)
    later = [req for req in requirements if (req.k if req.span else req.k - 1) >= first]
    readable = [hp for hp in task if hp.k > first]
    readable += readable_planes(later, agent.name, fixed, margin)
    steps = np.arange(len(reference), dtype=float)
    weights = (1.0 + np.maximum(0.0, steps - first)) ** 2 if late else np.ones_like(steps)
    found = search(grid, agent, first, readable, weights)
    if found.path is None:
        return found
    return Search(np.vstack([reference[:first], found.path]))
