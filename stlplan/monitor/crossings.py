"""The monitor's judgement between steps: safety on the straight segments a robot follows.

A robot tracking the planned waypoints moves from ``x(k)`` to ``x(k+1)`` along a straight
segment (DESIGN 2.9). Every predicate ``alpha_i`` is affine in the states, so on the segment
``alpha_i(s) = (1 - s) a_i + s b_i`` with ``a_i = alpha_i(x(k))``, ``b_i = alpha_i(x(k+1))`` and
``s in [0, 1]``, and the robustness of a disjunction ``OR_i alpha_i >= 0`` on the whole segment is

    rho_seg(k) = min_{s in [0, 1]} max_i ((1 - s) a_i + s b_i),

the minimum of a convex piecewise-linear function: it lies at ``s = 0``, ``s = 1`` or where two
lines cross. It is exact (a segment that passes a region's corner outside it counts as safe).

Which requirements are judged on segments (the same rule the planner applies): a constraint's
lowered formula, split through ``and`` and ``G``, requires parts at steps; a part that is a
disjunction of half-planes (outside a convex region) required at both ``k`` and ``k+1`` under one
binding is required on the segment between them. Separation is required on every segment of
every pair's relative position: ``||z_p - z_q||_inf >= d`` is the disjunction of four half-planes.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from stlplan.formula.boundary import HOLDS_AT, holds
from stlplan.formula.tree import Formula, Or, Predicate, step_parts
from stlplan.mission.problem import Problem
from stlplan.monitor.robustness import robustness
from stlplan.result import Trajectory

Cut = tuple[str, int]
"""An agent and the first step of a segment of its path that crosses."""


@dataclass(frozen=True)
class Crossing:
    """The worst segment of one requirement: ``rho_seg`` and where it is reached."""

    value: float
    """``rho_seg`` of the worst segment (< 0: the segment enters the region by that depth)."""
    step: int
    """The segment runs from ``step`` to ``step + 1``."""


def segment_floor(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``min_{s in [0,1]} max_i ((1 - s) a_i + s b_i)`` over the last axis of ``a`` and ``b``.

    ``a`` and ``b`` have shape ``(..., n)``; the result has shape ``(...)``.
    """
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    slope = b - a
    # candidates: s = 0, s = 1 and every crossing of two lines inside (0, 1)
    da = a[..., :, None] - a[..., None, :]
    ds = slope[..., None, :] - slope[..., :, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        cross = np.where(np.abs(ds) > 1e-15, da / ds, 0.0)
    cross = np.clip(np.nan_to_num(cross), 0.0, 1.0).reshape(*a.shape[:-1], -1)
    ends = np.broadcast_to(np.array([0.0, 1.0]), (*a.shape[:-1], 2))
    s = np.concatenate([ends, cross], axis=-1)  # (..., m)
    values = a[..., None, :] + s[..., :, None] * slope[..., None, :]  # (..., m, n)
    return np.min(np.max(values, axis=-1), axis=-1)


def _half_planes(part: Formula) -> tuple[Predicate, ...] | None:
    """The half-planes of a disjunction of two or more predicates, else None."""
    if isinstance(part, Or) and all(isinstance(c, Predicate) for c in part.children):
        return tuple(c for c in part.children if isinstance(c, Predicate))
    return None


def worst_segment(
    formula: Formula,
    signals: Mapping[str, np.ndarray],
    horizon: int,
    first: int = 0,
    planned: bool = False,
) -> Crossing | None:
    """The worst segment from step ``first`` on (a replan's step: the executed segments before
    it were not planned) of the safety parts of a lowered constraint; None without any.

    With ``planned``, the segment from the executed state at ``first`` is judged by what the
    plan decided: its end's value in the half-planes that state is in (the segment stays in
    such a half-plane when its end does), and not at all when the state is in none.
    """
    worst: Crossing | None = None
    for part, every in _segments(formula).items():
        starts = [k for k in every if k >= first]
        values = list(_segment_values(part, starts, signals, horizon)) if starts else []
        if planned and starts and starts[0] == first:
            planes = _half_planes(part) or ()
            alpha = np.array([robustness(p, signals, horizon) for p in planes])
            end = _end_value(alpha[:, first], alpha[:, first + 1])
            starts, values = (
                (starts, [end, *values[1:]]) if end is not None else (starts[1:], values[1:])
            )
        if not starts:
            continue
        i = int(np.argmin(values))
        if worst is None or values[i] < worst.value:
            worst = Crossing(float(values[i]), starts[i])
    return worst


def _segments(formula: Formula) -> dict[Formula, list[int]]:
    """Each disjunction of half-planes ``formula`` requires at two consecutive steps, with the
    first steps of those segments."""
    steps: dict[Formula, set[int]] = {}
    for part, k in step_parts(formula):
        if _half_planes(part) is not None:
            steps.setdefault(part, set()).add(k)
    out = {part: sorted(k for k in held if k + 1 in held) for part, held in steps.items()}
    return {part: starts for part, starts in out.items() if starts}


def _end_value(at_start: np.ndarray, at_end: np.ndarray) -> float | None:
    """The best value at a segment's end among the half-planes its start holds (None: none)."""
    held = at_start >= HOLDS_AT
    return float(np.max(at_end[held])) if held.any() else None


def separation_ends(positions: np.ndarray, separation: float, k: int) -> np.ndarray:
    """Per pair, shape (P, P): the separation's value at ``k+1`` in the half-planes the pair
    holds at ``k`` (``+inf`` where it holds none: the executed state broke it)."""

    def planes(t: int) -> np.ndarray:
        rel = positions[:, None, t] - positions[None, :, t]  # (P, P, 2)
        return np.concatenate([rel, -rel], axis=-1) - separation  # (P, P, 4)

    start, end = planes(k), planes(k + 1)
    held = start >= HOLDS_AT
    best = np.max(np.where(held, end, -np.inf), axis=-1)
    return np.where(held.any(axis=-1), best, np.inf)


def separation_segments(positions: np.ndarray, separation: float) -> np.ndarray:
    """``rho_seg`` of separation for every pair and segment: shape (P, P, H), upper triangle.

    ``positions`` has shape (P, H+1, 2). For a pair the four half-planes are
    ``+-(z_p - z_q)_j - d`` for ``j`` in x, y.
    """
    rel = positions[:, None] - positions[None, :]  # (P, P, H+1, 2)
    alpha = np.concatenate([rel, -rel], axis=-1) - separation  # (P, P, H+1, 4)
    return segment_floor(alpha[:, :, :-1], alpha[:, :, 1:])


def crossing_segments(problem: Problem, trajectory: Trajectory) -> list[Cut]:
    """Every segment on which a safety requirement fails (``rho_seg`` below ``HOLDS_AT``): the
    agents whose path it is, and its first step (for drawing; the verdicts give the worst ones)."""
    if not problem.inter_sample:
        return []
    found: set[Cut] = set()
    for constraint in problem.constraints:
        for binding in constraint.bindings:
            signals = {role: trajectory.states[name] for role, name in binding.items()}
            lowered = problem.lowered(constraint.formula, binding)
            for k in _failing_steps(lowered, signals, problem.horizon):
                found.update((name, k) for name in binding.values())
    if problem.separation is not None and len(problem.agents) > 1:
        names = [a.name for a in problem.agents]
        z = np.stack([trajectory.position(a.name, a.position) for a in problem.agents])
        seg = separation_segments(z, problem.separation)
        for p, q, k in np.argwhere(~holds(seg)):
            if p < q:
                found.update({(names[p], int(k)), (names[q], int(k))})
    return sorted(found)


def _failing_steps(formula: Formula, signals: Mapping[str, np.ndarray], horizon: int) -> set[int]:
    """First steps of the segments on which a safety part of ``formula`` fails."""
    out: set[int] = set()
    for part, starts in _segments(formula).items():
        values = _segment_values(part, starts, signals, horizon)
        out.update(k for k, v in zip(starts, values, strict=True) if not holds(v))
    return out


def _segment_values(
    part: Formula, starts: list[int], signals: Mapping[str, np.ndarray], horizon: int
) -> np.ndarray:
    """``rho_seg`` of a disjunction of half-planes on the segments starting at ``starts``."""
    planes = _half_planes(part) or ()
    alpha = np.array([robustness(p, signals, horizon) for p in planes]).T  # (H+1, n)
    return segment_floor(alpha[starts], alpha[[k + 1 for k in starts]])
