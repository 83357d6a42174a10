"""The pairwise separation's verdict, and a separation a replan's executed past broke.

``rho = min_{p<q} min_k ||z_p(k) - z_q(k)||_inf - d``, and with inter-sample safety the same on
the straight segments between steps (:func:`stlplan.monitor.crossings.separation_segments`).

A replan whose executed state at ``K`` holds a pair ``c < d`` apart asks two things of its plan
(:mod:`stlplan.analysis.recovery`): no closer than ``c`` from ``K`` until the step the problem
restores the separation at, ``R``, and the full separation from ``R`` on. Judging what the plan
decided (``planned_only``), the monitor reads ``c`` off the trajectory and checks the first on
those steps and segments, the second as the separation itself; the margin it reports is the
separation's. Judging the whole trajectory, the pair fails at ``K``, and the detail says from
which step the trajectory keeps the separation again.
"""

from __future__ import annotations

import numpy as np

from stlplan.formula.boundary import EPSILON, holds
from stlplan.mission.problem import Problem
from stlplan.monitor.crossings import segment_floor, separation_ends, separation_segments
from stlplan.result import Trajectory, Verdict


def separation_verdict(
    problem: Problem, trajectory: Trajectory, slack: float, first: int = 0
) -> Verdict:
    """The separation's verdict: every step from ``first`` (a replan's ``K`` when judging what
    it planned; the executed state's own excluded), and every segment."""
    assert problem.separation is not None
    d, agents = problem.separation, problem.agents
    if len(agents) < 2:
        return Verdict(
            "separation", "separation", True, float("inf"), detail="fewer than two agents"
        )
    z = np.stack([trajectory.position(a.name, a.position) for a in agents])  # (P, H+1, 2)
    K = 0 if problem.past is None else problem.past.step
    gap, seg = _step_values(z, d, bool(first), K, problem.inter_sample)
    floors = _floors(problem, z, K) if first else {}
    for (p, q), (_, R) in floors.items():  # judged against their floors below
        gap[p, q, :R] = np.inf
        if seg is not None:
            seg[p, q, : max(R - K, 0)] = np.inf
    value, where = _worst(gap, seg, K, agents)
    satisfied = holds(value, slack)
    detail = (
        f"every pair keeps {d:g} apart; closest {where} with margin {value:.3g}"
        if satisfied
        else f"{where} are closer than {d:g} by {-value:.3g}"
    )
    if problem.past is not None and not first:
        detail += _restoring(problem, z, d, K)
    for (p, q), (closest, R) in floors.items():
        low = _floor_value(z[p], z[q], closest, K, R, problem.inter_sample)
        if not holds(low, slack):
            satisfied = False
            detail = (
                f"{agents[p].name} and {agents[q].name} come closer than their {closest:.3g} "
                f"at step {K} (the executed past) before step {R} by {-low:.3g}; " + detail
            )
    return Verdict("separation", "separation", satisfied, value, detail=detail)


def _step_values(
    z: np.ndarray, d: float, planned: bool, K: int, inter_sample: bool
) -> tuple[np.ndarray, np.ndarray | None]:
    """Per pair ``(P, P, H+1)`` at steps and ``(P, P, H-K)`` on segments from ``K``: the
    distance less ``d``, ``+inf`` outside the upper triangle (and, planned, on the past)."""
    P = len(z)
    upper = np.triu(np.ones((P, P), dtype=bool), k=1)[:, :, None]
    gap = np.max(np.abs(z[:, None] - z[None, :]), axis=3) - d
    gap = np.where(upper, np.nan_to_num(gap, nan=-np.inf), np.inf)
    if planned:  # what the plan decided: the steps after K (the executed state's own)
        gap[:, :, : K + 1] = np.inf
    if not inter_sample or gap.shape[2] <= K + 1:
        return gap, None
    seg = separation_segments(z[:, K:], d)
    if planned:  # the segment from the executed state, by its end
        seg[:, :, 0] = separation_ends(z, d, K)
    return gap, np.where(upper, np.nan_to_num(seg, nan=-np.inf), np.inf)


def _worst(gap: np.ndarray, seg: np.ndarray | None, K: int, agents: tuple) -> tuple[float, str]:
    """The smallest value over steps and segments, and where it is, in words."""
    p, q, k = np.unravel_index(int(np.argmin(gap)), gap.shape)
    value, where = float(gap[p, q, k]), f"{agents[p].name} and {agents[q].name} at step {k}"
    if seg is not None:
        sp, sq, sk = np.unravel_index(int(np.argmin(seg)), seg.shape)
        if seg[sp, sq, sk] < value - 1e-12:
            value, sk = float(seg[sp, sq, sk]), sk + K
            where = f"{agents[sp].name} and {agents[sq].name} on the segment {sk} -> {sk + 1}"
    return value, where


def _floors(problem: Problem, z: np.ndarray, K: int) -> dict[tuple[int, int], tuple[float, int]]:
    """The pairs the problem lets recover (by index): their distance at ``K`` in the trajectory,
    and the step their separation is restored at (``H + 1``: never)."""
    assert problem.past is not None
    index = {a.name: n for n, a in enumerate(problem.agents)}
    return {
        (index[p], index[q]): (
            float(np.max(np.abs(z[index[p], K] - z[index[q], K]))),
            problem.separated_from(p, q),
        )
        for p, q in problem.past.recovering
        if p in index and q in index
    }


def _floor_value(
    zp: np.ndarray, zq: np.ndarray, closest: float, K: int, R: int, inter_sample: bool
) -> float:
    """How far the pair stays above ``closest`` (less the boundary epsilon) from ``K`` to ``R``:
    on the segments ``[K, K+1] .. [R-1, R]`` (one half-plane at both ends), else the steps."""
    rel = zp - zq
    planes = np.concatenate([rel, -rel], axis=-1) - (closest - EPSILON)  # (H+1, 4)
    if not inter_sample:
        return float(np.min(np.max(planes[K + 1 : R], axis=-1), initial=np.inf))
    last = min(R, len(rel) - 1)
    if last <= K:
        return float("inf")
    return float(np.min(segment_floor(planes[K:last], planes[K + 1 : last + 1])))


def _restoring(problem: Problem, z: np.ndarray, d: float, K: int) -> str:
    """For the pairs the executed past left too close: how close they came after ``K`` and from
    which step on the trajectory keeps them ``d`` apart again (steps and segments), in words."""
    assert problem.past is not None
    index = {a.name: n for n, a in enumerate(problem.agents)}
    said = []
    for p, q in problem.past.recovering:
        if p not in index or q not in index:
            continue
        rel = z[index[p]] - z[index[q]]
        planes = np.concatenate([rel, -rel], axis=-1)
        ok = holds(np.max(planes, axis=-1) - d)
        closest = np.max(planes[K + 1 :], axis=-1)
        if problem.inter_sample:
            ok[:-1] &= holds(segment_floor(planes[:-1] - d, planes[1:] - d))
            closest = segment_floor(planes[K:-1], planes[K + 1 :])
        bad = np.flatnonzero(~ok)
        back = int(bad[-1]) + 1 if len(bad) else 0
        again = f"{d:g} apart again from step {back}" if back < len(rel) else "never apart again"
        said.append(f"{p} and {q} no closer than {max(np.min(closest), 0.0):.3g} after it, {again}")
    return f" (the executed past at step {K}; {'; '.join(said)})" if said else ""
