"""The least L1 effort of one agent, or of several side by side, meeting a set of predicates.

The effort floors (:mod:`stlplan.planner.encoding.floors`) and the element floors
(:mod:`stlplan.planner.encoding.team_floors`) are built from these LPs.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import highspy
import numpy as np

from stlplan.formula.tree import Predicate
from stlplan.mission.problem import AgentModel
from stlplan.planner.tolerances import FEASIBILITY

INF = float("inf")

AgentPredicate = tuple[Predicate, int]
"""A predicate on one agent's state at step ``k``, its role bound to that agent."""


def add_dense_rows(highs: Any, matrix: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> None:
    """Add the rows of a dense ``matrix`` to ``highs`` (its nonzeros only)."""
    starts: list[int] = []
    index: list[int] = []
    values: list[float] = []
    for row in matrix:
        starts.append(len(index))
        nonzero = np.flatnonzero(np.abs(row) > 1e-12)
        index.extend(nonzero.tolist())
        values.extend(row[nonzero].tolist())
    highs.addRows(
        len(matrix), lo, hi, len(index),
        np.array(starts, dtype=np.int32), np.array(index, dtype=np.int32),
        np.array(values, dtype=float),
    )  # fmt: skip


def least_effort(highs: Any, base_rows: int, matrix: np.ndarray, lo: np.ndarray) -> float:
    """Solve ``highs`` with the rows ``matrix u >= lo`` added (then removed): its least effort,
    lowered by :data:`FEASIBILITY`; inf when infeasible, 0 (no cut) when unknown."""
    add_dense_rows(highs, matrix, lo, np.full(len(lo), INF))
    highs.run()
    status = highs.getModelStatus()
    value = highs.getInfo().objective_function_value
    extra = np.arange(base_rows, highs.getNumRow(), dtype=np.int32)
    highs.deleteRows(len(extra), extra)
    if status == highspy.HighsModelStatus.kInfeasible:
        return INF
    if status != highspy.HighsModelStatus.kOptimal:
        return 0.0
    return max(0.0, float(value) - FEASIBILITY)


class EffortLp:
    """``E_p(S)`` for one agent, as a warm-started HiGHS LP over its inputs.

    Variables ``u`` (H*m) and ``s`` (H*m); rows ``s - u >= 0``, ``s + u >= 0`` and the state box
    ``x_lo <= f_k + G_k u <= x_hi`` for ``k = 1..H``, with ``x(k) = f_k + G_k u`` condensed
    (``f_k = A^k x^0``, ``G_k`` the stacked ``A^(k-1-i) B``). A query adds the predicate rows
    ``c . G_k u >= b + r_min - c . f_k``, solves and deletes them.
    """

    def __init__(self, agent: AgentModel, horizon: int, margin: float) -> None:
        self.margin, self.agent, self.horizon = margin, agent, horizon
        n, m = agent.n, agent.m
        self.free = np.empty((horizon + 1, n))
        self.gains = np.zeros((horizon + 1, n, horizon * m))
        self.free[0] = agent.initial_state
        for k in range(horizon):
            self.free[k + 1] = agent.A @ self.free[k]
            self.gains[k + 1] = agent.A @ self.gains[k]
            self.gains[k + 1][:, k * m : (k + 1) * m] = agent.B
        self.highs = highspy.Highs()
        self.highs.setOptionValue("output_flag", False)
        self._base()

    def _base(self) -> None:
        lower, upper, cost, matrix, lo, hi = self.base_block()
        width = len(cost)
        self.highs.addVars(width, lower, upper)
        self.highs.changeColsCost(width, np.arange(width, dtype=np.int32), cost)
        add_dense_rows(self.highs, matrix, lo, hi)
        self.base_rows = self.highs.getNumRow()

    def base_block(self) -> tuple[np.ndarray, ...]:
        """The agent's columns ``(u, s)`` (lower, upper, cost) and rows (matrix, lo, hi)."""
        agent, horizon = self.agent, self.horizon
        width = horizon * agent.m
        u_lo = np.tile(agent.input_lo, horizon)
        u_hi = np.tile(agent.input_hi, horizon)
        cost = np.concatenate([np.zeros(width), np.ones(width)])
        lower = np.concatenate([u_lo, np.zeros(width)])
        upper = np.concatenate([u_hi, np.maximum(np.abs(u_lo), np.abs(u_hi))])
        eye = np.eye(width)
        rows = [np.hstack([-eye, eye]), np.hstack([eye, eye])]
        lo = [np.zeros(width), np.zeros(width)]
        hi = [np.full(width, INF), np.full(width, INF)]
        for k in range(1, horizon + 1):
            rows.append(np.hstack([self.gains[k], np.zeros((agent.n, width))]))
            lo.append(agent.state_lo - self.free[k])
            hi.append(agent.state_hi - self.free[k])
        return lower, upper, cost, np.vstack(rows), np.concatenate(lo), np.concatenate(hi)

    def floor(self, predicates: Iterable[AgentPredicate]) -> float:
        """``E_p(S)``: least L1 effort meeting every predicate of ``S`` (inf if none can)."""
        width = self.gains.shape[2]
        matrix, lo = [], []
        for node, k in predicates:
            c = np.zeros(self.free.shape[1])
            for term in node.terms:
                c[term.component] += term.coef
            matrix.append(np.concatenate([c @ self.gains[k], np.zeros(width)]))
            lo.append(node.bound + self.margin - float(c @ self.free[k]))
        if not matrix:
            return 0.0
        return least_effort(self.highs, self.base_rows, np.vstack(matrix), np.array(lo))
