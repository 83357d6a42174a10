"""A separation the executed past broke: kept from getting worse, restored when it can be.

When a replan's executed states put two agents closer than the separation ``d`` at its step
``K`` (``||z_p(K) - z_q(K)||_inf = c < d``), no plan can mend step ``K``. The replan then holds
the pair to two things instead of dropping the separation:

* **no closer**: from ``K`` to the step the separation is back, on the steps and on the
  segments between them, the pair stays at least ``c`` apart (a floor at ``c``, enforced with
  the boundary epsilon only: the mission's margin is for the separation itself);
* **restored**: from the first step ``R > K`` at which the pair's reachable position boxes
  (:func:`stlplan.analysis.reach.reachable_boxes`: the dynamics and the state and input
  bounds, from the executed states) can be ``d`` apart with the mission's margin, at that step
  and every later one, the full separation holds again.

The boxes over-approximate where the agents can be, so ``R`` is the earliest step the dynamics
allow; when other constraints ask for a later one (the replan is infeasible even with tasks
dropped), :func:`restored_later` moves it one step at a time.
"""

from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np

from stlplan.analysis.reach import reachable_boxes
from stlplan.formula.boundary import EPSILON, required_margin
from stlplan.mission.problem import Problem, Recovery


def with_recoveries(problem: Problem) -> Problem:
    """``problem`` (a replan's) with a :class:`Recovery` for every pair its executed past leaves
    closer than the separation at its step."""
    past = problem.past
    if past is None or problem.separation is None or past.step >= problem.horizon:
        return problem
    K = past.step
    found: dict[tuple[str, str], Recovery] = {}
    boxes = None
    for p, q in itertools.combinations([a.name for a in problem.agents], 2):
        closest = _distance(problem, p, q, K)
        if closest >= problem.separation:
            continue
        if boxes is None:
            boxes = reachable_boxes(problem)
        found[(p, q)] = Recovery(closest, _restored(problem, boxes, p, q))
    if not found:
        return problem
    return replace(problem, past=replace(past, recovering=found), _by_name={})


def _distance(problem: Problem, p: str, q: str, k: int) -> float:
    assert problem.past is not None
    z = [problem.past.state(a, k)[list(problem.agent(a).position)] for a in (p, q)]
    return float(np.max(np.abs(z[0] - z[1])))


def _restored(
    problem: Problem, boxes: dict[str, tuple[np.ndarray, np.ndarray]], p: str, q: str
) -> int | None:
    """The first step after ``K`` from which, at every later step, the boxes of ``p`` and ``q``
    let them be the separation and the mission's margin apart (None: no such step)."""
    assert problem.past is not None and problem.separation is not None
    K, H = problem.past.step, problem.horizon
    margin = required_margin(problem.mission.objective.margin.minimum)
    need = problem.separation + margin + 2 * problem.robust_to + EPSILON
    restored = None
    for k in range(H, K, -1):
        if _widest(problem, boxes, p, q, k) < need:
            break
        restored = k
    return restored


def _widest(
    problem: Problem, boxes: dict[str, tuple[np.ndarray, np.ndarray]], p: str, q: str, k: int
) -> float:
    """The largest infinity-norm distance the position boxes of ``p`` and ``q`` allow at ``k``."""
    (lo_p, hi_p), (lo_q, hi_q) = (
        (
            boxes[a][0][k, list(problem.agent(a).position)],
            boxes[a][1][k, list(problem.agent(a).position)],
        )
        for a in (p, q)
    )
    return float(np.max(np.maximum(hi_p - lo_q, hi_q - lo_p)))


def restored_later(problem: Problem) -> Problem | None:
    """``problem`` with every pair that recovers restored one step later (never, past the
    horizon); None when no pair has a step left to move."""
    past = problem.past
    if past is None or all(r.restored is None for r in past.recovering.values()):
        return None
    H = problem.horizon
    later = {
        pair: replace(r, restored=None if r.restored is None or r.restored >= H else r.restored + 1)
        for pair, r in past.recovering.items()
    }
    return replace(problem, past=replace(past, recovering=later), _by_name={})
