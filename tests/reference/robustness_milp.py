"""A reference optimum for STL missions, built without stlplan's encoder.

The standard robustness encoding of STL (Raman et al., "Model predictive control with signal
temporal logic specifications", 2014; the form stlpy writes), with one continuous robustness
variable ``rho`` per subformula and step and one binary per disjunct, solved by plain highspy:

* predicate ``rho <= alpha(x(k))``;
* conjunction (``&``, ``G``) ``rho <= rho_i`` for every child;
* disjunction (``|``, ``F``) ``rho <= rho_i + M (1 - b_i)``, ``sum b_i = 1``, ``b_i`` binary;
* until (the paper's, both ends included) ``max_{k'} min(rho_right(k'), rho_left(k..k'))``.

Only upper bounds on ``rho`` are written, which is exact for a maximized robustness: any feasible
``rho`` is at most the true robustness, and the true robustness is feasible. Each ``rho`` is
bounded by interval arithmetic over the state box (``[alpha_lo, alpha_hi]`` for a predicate, min
or max of the children's bounds above it; never the reachable boxes stlplan computes), and
``M_i = max rho - min rho_i``.

The objective is the mission's for plain STL: maximize ``w r - beta sum |u|`` (``r`` fixed at
the required minimum unless maximized), with every constraint's robustness ``>= r``.

With inter-sample safety (the mission's default), a disjunction of half-planes that a constraint
requires at consecutive steps ``k`` and ``k + 1`` is required on the segment: its robustness is
``max_i min(alpha_i(x(k)), alpha_i(x(k+1)))`` (one half-plane at both ends), for the pairwise
separation as well. Tasks (groups of agents) are outside this reference.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from dataclasses import dataclass, field

import highspy
import numpy as np

from stlplan.formula.tree import (
    Always,
    And,
    Distance,
    Eventually,
    Formula,
    Or,
    Predicate,
    Until,
    step_parts,
)
from stlplan.mission.problem import Problem


@dataclass(frozen=True)
class Reference:
    """The reference verdict: ``optimal`` with its objective and margin, or ``infeasible``."""

    status: str
    objective: float | None = None
    margin: float | None = None


@dataclass
class _Milp:
    """Columns and rows of a MILP, built one by one."""

    lower: list[float] = field(default_factory=list)
    upper: list[float] = field(default_factory=list)
    integer: list[bool] = field(default_factory=list)
    cost: list[float] = field(default_factory=list)
    rows: list[tuple[dict[int, float], float, float]] = field(default_factory=list)

    def column(self, lo: float, hi: float, integer: bool = False) -> int:
        self.lower.append(lo)
        self.upper.append(hi)
        self.integer.append(integer)
        self.cost.append(0.0)
        return len(self.lower) - 1

    def row(self, terms: Mapping[int, float], lo: float, hi: float) -> None:
        self.rows.append((dict(terms), lo, hi))

    def solve(self, time_limit: float) -> tuple[str, float | None, list[float]]:
        lp = highspy.HighsLp()
        lp.num_col_, lp.num_row_ = len(self.lower), len(self.rows)
        lp.col_cost_, lp.col_lower_, lp.col_upper_ = self.cost, self.lower, self.upper
        lp.row_lower_ = [lo for _, lo, _ in self.rows]
        lp.row_upper_ = [hi for _, _, hi in self.rows]
        starts, index, values = [0], [], []
        for terms, _, _ in self.rows:
            index += list(terms)
            values += list(terms.values())
            starts.append(len(index))
        lp.a_matrix_.format_ = highspy.MatrixFormat.kRowwise
        lp.a_matrix_.start_, lp.a_matrix_.index_, lp.a_matrix_.value_ = starts, index, values
        kinds = highspy.HighsVarType
        lp.integrality_ = [kinds.kInteger if i else kinds.kContinuous for i in self.integer]
        lp.sense_ = highspy.ObjSense.kMaximize
        highspy.Highs.resetGlobalScheduler(True)  # sized afresh for this solve's one thread
        h = highspy.Highs()
        for name, value in (("output_flag", False), ("threads", 1), ("time_limit", time_limit),
                            ("mip_rel_gap", 1e-9), ("mip_abs_gap", 1e-9)):  # fmt: skip
            h.setOptionValue(name, value)
        h.passModel(lp)
        h.run()
        highspy.Highs.resetGlobalScheduler(True)  # the next solve sizes the pool for itself
        status = h.getModelStatus()
        if status == highspy.HighsModelStatus.kInfeasible:
            return "infeasible", None, []
        if status != highspy.HighsModelStatus.kOptimal:
            return h.modelStatusToString(status), None, []
        return "optimal", h.getInfo().objective_function_value, list(h.getSolution().col_value)


class _Encoder:
    """The mission's states, inputs and robustness variables in one :class:`_Milp`."""

    def __init__(self, problem: Problem) -> None:
        self.problem = problem
        self.milp = _Milp()
        self.x: dict[tuple[str, int, int], int] = {}
        self.memo: dict[tuple[object, ...], int] = {}
        self._dynamics()

    def _dynamics(self) -> None:
        # x(k+1) = A x(k) + B u(k), x(0) = x0, state and input boxes, s >= |u|
        milp, beta = self.milp, self.problem.mission.objective.beta
        for a in self.problem.agents:
            H = self.problem.horizon
            for k, i in itertools.product(range(H + 1), range(a.n)):
                lo, hi = (a.initial_state[i],) * 2 if k == 0 else (a.state_lo[i], a.state_hi[i])
                self.x[a.name, k, i] = milp.column(float(lo), float(hi))
            for k in range(H):
                u = [milp.column(float(a.input_lo[j]), float(a.input_hi[j])) for j in range(a.m)]
                for j, col in enumerate(u):
                    s = milp.column(0.0, float(max(abs(a.input_lo[j]), abs(a.input_hi[j]))))
                    milp.cost[s] = -beta
                    milp.row({s: 1.0, col: -1.0}, 0.0, np.inf)
                    milp.row({s: 1.0, col: 1.0}, 0.0, np.inf)
                for i in range(a.n):
                    terms = {self.x[a.name, k + 1, i]: 1.0}
                    for c in range(a.n):
                        if a.A[i, c]:
                            terms[self.x[a.name, k, c]] = (
                                terms.get(self.x[a.name, k, c], 0.0) - a.A[i, c]
                            )
                    for j in range(a.m):
                        if a.B[i, j]:
                            terms[u[j]] = -float(a.B[i, j])
                    milp.row(terms, 0.0, 0.0)

    def predicate(self, node: Predicate, k: int, binding: Mapping[str, str]) -> int:
        # rho <= sum(coef x) - bound, rho within the range of alpha over the state box
        terms: dict[int, float] = {}
        lo = hi = -node.bound
        for t in node.terms:
            col = self.x[binding[t.role], k, t.component]
            terms[col] = terms.get(col, 0.0) - t.coef
            ends = (t.coef * self.milp.lower[col], t.coef * self.milp.upper[col])
            lo, hi = lo + min(ends), hi + max(ends)
        rho = self.milp.column(lo, hi)
        terms[rho] = 1.0
        self.milp.row(terms, -np.inf, -node.bound)
        return rho

    def meet(self, children: list[int]) -> int:
        # rho <= rho_i for every child
        milp = self.milp
        rho = milp.column(
            min(milp.lower[c] for c in children), min(milp.upper[c] for c in children)
        )
        for c in children:
            self.milp.row({rho: 1.0, c: -1.0}, -np.inf, 0.0)
        return rho

    def join(self, children: list[int]) -> int:
        # rho <= rho_i + M_i (1 - b_i), sum b_i = 1, M_i = max rho - min rho_i
        milp = self.milp
        rho = milp.column(
            max(milp.lower[c] for c in children), max(milp.upper[c] for c in children)
        )
        picks = [milp.column(0.0, 1.0, integer=True) for _ in children]
        for c, b in zip(children, picks, strict=True):
            big = milp.upper[rho] - milp.lower[c]
            milp.row({rho: 1.0, c: -1.0, b: big}, -np.inf, big)
        milp.row(dict.fromkeys(picks, 1.0), 1.0, 1.0)
        return rho

    def robustness(self, node: Formula, k: int, binding: Mapping[str, str]) -> int:
        """Column of a lower bound on the robustness of ``node`` at ``k`` (tight at the optimum)."""
        key = (node, k, tuple(sorted(binding.items())))
        if key not in self.memo:
            self.memo[key] = self._robustness(node, k, binding)
        return self.memo[key]

    def _robustness(self, node: Formula, k: int, binding: Mapping[str, str]) -> int:
        if isinstance(node, Predicate):
            return self.predicate(node, k, binding)
        if isinstance(node, And | Or):
            kids = [self.robustness(c, k, binding) for c in node.children]
            return self.meet(kids) if isinstance(node, And) else self.join(kids)
        if isinstance(node, Always | Eventually):
            span = range(k + node.interval.lo, k + node.interval.hi + 1)
            kids = [self.robustness(node.child, t, binding) for t in span]
            return self.meet(kids) if isinstance(node, Always) else self.join(kids)
        if isinstance(node, Until):
            terms = []
            for t in range(k + node.interval.lo, k + node.interval.hi + 1):
                lefts = [self.robustness(node.left, s, binding) for s in range(k, t + 1)]
                terms.append(self.meet([self.robustness(node.right, t, binding), *lefts]))
            return self.join(terms)
        raise ValueError(f"the reference cannot encode {type(node).__name__}")

    def on_segment(self, node: Or, k: int, binding: Mapping[str, str]) -> int:
        """``max_i min(alpha_i(k), alpha_i(k+1))``: one half-plane at both ends of the segment."""
        sides = []
        for alt in node.children:
            assert isinstance(alt, Predicate)
            ends = [self.robustness(alt, t, binding) for t in (k, k + 1)]
            sides.append(self.meet(ends))
        return self.join(sides)


def _requirements(problem: Problem) -> list[tuple[str, Formula, int, Mapping[str, str]]]:
    """Every constraint part and separation step: ``(family, formula, k, binding)``."""
    out: list[tuple[str, Formula, int, Mapping[str, str]]] = []
    for c in problem.constraints:
        for binding in c.bindings:
            family = f"{c.name}/{sorted(binding.items())}"
            out += [
                (family, f, k, binding) for f, k in step_parts(problem.lowered(c.formula, binding))
            ]
    if problem.separation is not None:
        names = [a.name for a in problem.agents]
        for p, q in itertools.combinations(names, 2):
            apart = problem.lowered(Distance("p", "q", ">=", problem.separation), {"p": p, "q": q})
            out += [
                (f"sep/{p}/{q}", apart, k, {"p": p, "q": q}) for k in range(problem.horizon + 1)
            ]
    return out


def _half_planes(node: Formula) -> bool:
    return isinstance(node, Or) and all(isinstance(c, Predicate) for c in node.children)


def reference_optimum(problem: Problem, time_limit: float = 120.0) -> Reference:
    """Solve ``problem`` (constraints and separation, no tasks) with the standard encoding."""
    if problem.tasks:
        raise ValueError("the reference encodes constraints and separation only, not tasks")
    enc = _Encoder(problem)
    spec = problem.mission.objective.margin
    r = enc.milp.column(spec.minimum, np.inf if spec.maximize else spec.minimum)
    enc.milp.cost[r] = spec.weight if spec.maximize else 0.0
    parts = _requirements(problem)
    held = {(fam, f, k) for fam, f, k, _ in parts if _half_planes(f)}
    for family, formula, k, binding in parts:
        segment = problem.inter_sample and _half_planes(formula)
        if segment and (family, formula, k + 1) in held:
            rho = enc.on_segment(formula, k, binding)  # type: ignore[arg-type]
        elif segment and (family, formula, k - 1) in held:
            continue  # covered by the segment ending at k
        else:
            rho = enc.robustness(formula, k, binding)
        enc.milp.row({rho: 1.0, r: -1.0}, 0.0, np.inf)
    status, objective, values = enc.milp.solve(time_limit)
    if status != "optimal":
        return Reference(status)
    return Reference(status, objective, values[r])
