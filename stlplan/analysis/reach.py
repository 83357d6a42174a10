"""Where agents can be, and where formulas require them to be, found without solving.

:func:`reachable_boxes` over-approximates each agent's reachable states by interval arithmetic
(it tightens the model's bounds and big-M constants, and proves regions out of reach);
:func:`meeting_steps` lists the pairs of agents those boxes let come closer than the separation;
:func:`needs` lists the region visits every trajectory satisfying a formula must make.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping

import numpy as np

from stlplan.formula.tree import Always, And, Eventually, Formula, InRegion, Until
from stlplan.mission.problem import Problem

Need = tuple[str, str, int]
"""(role, region, deadline): the role must be in the region at some step <= deadline."""


def reachable_boxes(problem: Problem) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Interval hull of each agent's reachable states per step, inside its state box.

    ``[x(0)] = x^0`` and ``[x(k+1)] = (A [x(k)] + B [u]) cap [x_lo, x_hi]`` in interval
    arithmetic (``A = A+ + A-`` split by sign); a replan's known states are points. Tightens variable bounds and big-M constants.
    """
    boxes = {}
    for a in problem.agents:
        lo = np.empty((problem.horizon + 1, a.n))
        hi = np.empty_like(lo)
        known = problem.known_through(a.name)
        for k in range(known + 1):
            lo[k] = hi[k] = (
                a.initial_state if problem.past is None else problem.past.state(a.name, k)
            )
        a_pos, a_neg = np.maximum(a.A, 0), np.minimum(a.A, 0)
        b_pos, b_neg = np.maximum(a.B, 0), np.minimum(a.B, 0)
        u_lo = b_pos @ a.input_lo + b_neg @ a.input_hi
        u_hi = b_pos @ a.input_hi + b_neg @ a.input_lo
        for k in range(known, problem.horizon):
            lo[k + 1] = np.maximum(a_pos @ lo[k] + a_neg @ hi[k] + u_lo, a.state_lo)
            hi[k + 1] = np.minimum(a_pos @ hi[k] + a_neg @ lo[k] + u_hi, a.state_hi)
        boxes[a.name] = (lo, hi)
    return boxes


def meeting_steps(
    problem: Problem, boxes: Mapping[str, tuple[np.ndarray, np.ndarray]] | None = None
) -> dict[tuple[str, str], tuple[int, ...]]:
    """The steps at which two agents' reachable positions come closer than the separation.

    Agents ``p`` and ``q`` can meet at step ``k`` when the infinity-norm distance between their
    position boxes at ``k`` (the largest gap between the boxes along an axis, 0 where they
    overlap) is below the mission's separation. A pair that cannot meet at any step keeps its
    separation whatever either agent does.

    Parameters
    ----------
    problem
        The mission; without a separation no pair needs one, and the answer is empty.
    boxes
        Reachable boxes (:func:`reachable_boxes` of ``problem`` when None).

    Returns
    -------
    dict
        ``(p, q)`` in mission order to the steps at which they can meet; pairs that never can
        are left out.
    """
    if problem.separation is None:
        return {}
    boxes = reachable_boxes(problem) if boxes is None else boxes
    names = [a.name for a in problem.agents]
    lo = np.stack([boxes[a.name][0][:, list(a.position)] for a in problem.agents])
    hi = np.stack([boxes[a.name][1][:, list(a.position)] for a in problem.agents])
    found = {}
    for i, name in enumerate(names[:-1]):
        # gap between i's box and each later agent's, per step and axis: (N - i - 1, H+1, 2)
        gap = np.maximum(lo[i + 1 :] - hi[i], lo[i] - hi[i + 1 :])
        near = np.maximum(gap, 0.0).max(axis=2) < problem.separation
        for j, steps in enumerate(near, start=i + 1):
            if steps.any():
                found[(name, names[j])] = tuple(int(k) for k in np.flatnonzero(steps))
    return found


def needs(formula: Formula, shift: int = 0) -> Iterator[Need]:
    """Region visits every satisfying trajectory must make, with their deadlines.

    Follows only ``&``, ``G``, ``F`` and the right side of ``U`` (never ``|`` or ``!``):
    ``G[a,b] f`` needs ``f`` at ``k+a``; ``F[a,b] f`` at some step up to ``k+b``; ``l U[a,b] r``
    needs ``r`` by ``k+b`` and ``l`` at ``k`` (``l U*[0,b] r`` needs ``r`` only).
    """
    if isinstance(formula, InRegion):
        yield formula.role, formula.region, shift
    elif isinstance(formula, And):
        for child in formula.children:
            yield from needs(child, shift)
    elif isinstance(formula, Always):
        yield from needs(formula.child, shift + formula.interval.lo)
    elif isinstance(formula, Eventually):
        yield from needs(formula.child, shift + formula.interval.hi)
    elif isinstance(formula, Until):
        if formula.interval.lo > 0 or not formula.strict:  # U*[0,b] may hold by right alone
            yield from needs(formula.left, shift)
        yield from needs(formula.right, shift + formula.interval.hi)
