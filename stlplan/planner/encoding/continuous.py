"""The continuous stage after step 1: step 2 (effort) or the one-step polish, decisions fixed.

Once step 1's binaries are fixed, the enforced predicates are known (the indicators the
decisions force to 1; see :func:`stlplan.planner.solve.enforced_predicates`) and the rest of the MILP is
inert. This module builds the small model that remains:

    x_p(k+1) = A_p x_p(k) + B_p u_p(k),  x_p(0) = x_p^0,  boxes,  s >= |u|,
    alpha(x(k)) - r >= 0   for every enforced predicate,

with ``r`` the step-1 margin (never below ``EPSILON``, :mod:`stlplan.formula.boundary`), and either the effort of DESIGN 2.3 (``l2``: ``sum u^2``, a convex
QP; ``l1``: ``sum s``; ``linf``: ``sum_p v_p`` with ``v_p >= s_{p,k,j}``) to minimize, or the
step-1 objective restricted to the fixed decisions (``w r - beta sum s``) to maximize. Runs of the
synchronous tasks, hence every ``rho_s^l``, are fixed with the decisions.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Literal

import numpy as np
from pyomo.environ import ConcreteModel, Constraint, ConstraintList, Objective, Var, value
from pyomo.environ import maximize as maximize_sense
from pyomo.environ import minimize as minimize_sense

from stlplan.analysis.reach import reachable_boxes
from stlplan.formula.boundary import required_margin
from stlplan.planner.encoding.ledger import Enforced
from stlplan.planner.encoding.model import PlanModel
from stlplan.planner.encoding.stl import alpha
from stlplan.planner.tolerances import FEASIBILITY

Stage = Literal["effort", "polish"]


def effort_objective(model: ConcreteModel, agents: Sequence[str], norm: str) -> Any:
    """The effort of step 2 in ``norm``, to minimize.

    ``l2``: ``sum u^2``; ``l1``: ``sum s`` with ``s >= |u|``; ``linf``: ``sum_p v_p`` with
    ``v_p >= s_{p,k,j}`` for every ``k, j``.
    """
    if norm == "l2":
        return sum(u * u for u in model.u.values())
    if norm == "l1":
        return sum(model.s.values())
    model.peak = Var(list(agents), bounds=(0.0, None))
    model.peak_rows = Constraint(list(model.s), rule=lambda m, p, k, j: m.peak[p] >= m.s[p, k, j])
    return sum(model.peak.values())


def _unique(enforced: Sequence[Enforced]) -> list[Enforced]:
    seen: dict[tuple[Any, ...], Enforced] = {}
    for node, k, binding in enforced:
        seen.setdefault((node, k, tuple(sorted(binding.items()))), (node, k, binding))
    return list(seen.values())


def condensed_states(model: ConcreteModel, pm: PlanModel) -> dict[tuple[str, int, int], Any]:
    """Inputs ``model.u`` with their boxes, and the states as affine expressions of them.

    ``x_p(k) = A^k x_p^0 + sum_{i<k} A^(k-1-i) B u_p(i)``, with the reachable boxes as ranged rows
    ``lo <= x_p(k) <= hi``; a replan's known states are constants, and the sum starts there. With the states eliminated, ``sum u^2`` has a positive definite
    Hessian, which HiGHS's QP solver needs to converge reliably.
    """
    problem = pm.problem
    keys = [
        (a.name, k, j) for a in problem.agents for k in range(problem.horizon) for j in range(a.m)
    ]
    u_box = {
        (a.name, k, j): (
            float(a.input_lo[j] + problem.input_room(a, k)[j]),
            float(a.input_hi[j] - problem.input_room(a, k)[j]),
        )
        for a in problem.agents
        for k in range(problem.horizon)
        for j in range(a.m)
    }
    model.u = Var(keys, bounds=lambda _, p, k, j: u_box[p, k, j])
    model.box = ConstraintList()
    states: dict[tuple[str, int, int], Any] = {}
    boxes = reachable_boxes(problem)
    for a in problem.agents:
        known = problem.known_through(a.name)
        for k in range(known + 1):
            x = boxes[a.name][0][k]  # a point: the initial state, or a replan's past
            states.update({(a.name, k, i): float(x[i]) for i in range(a.n)})
        for k, j in ((k, j) for k in range(known) for j in range(a.m)):
            model.u[a.name, k, j].fix(0.0)  # before a replan's step: not planned
        free = np.asarray(boxes[a.name][0][known], dtype=float)
        gains: list[np.ndarray] = []  # gains[i] = A^(k-1-i) B, from the last known step
        for k in range(known + 1, problem.horizon + 1):
            free = a.A @ free
            gains = [a.A @ g for g in gains] + [a.B]
            for i in range(a.n):
                terms = [
                    g[i, j] * model.u[a.name, known + t, j]
                    for t, g in enumerate(gains)
                    for j in range(a.m)
                    if g[i, j]
                ]
                states[a.name, k, i] = float(free[i]) + sum(terms)
                if terms:
                    lo, hi = boxes[a.name][0][k, i], boxes[a.name][1][k, i]
                    model.box.add((float(lo), states[a.name, k, i], float(hi)))
        if known < problem.horizon:
            _rest(model, a, states, problem.horizon)
    return states


def _rest(model: ConcreteModel, agent: Any, states: Mapping[Any, Any], horizon: int) -> None:
    """``(A - I) x(H) = 0`` over the condensed states, for an agent that ends at rest."""
    if not agent.at_rest:
        return
    for row in agent.rest_rows():
        expr = sum(c * states[agent.name, horizon, i] for i, c in enumerate(row) if c)
        if not isinstance(expr, (int, float)):
            model.box.add(expr == 0)


def _absolute_inputs(model: ConcreteModel) -> None:
    """``s >= u`` and ``s >= -u``, so ``s = |u|`` where ``s`` is minimized."""
    model.s = Var(list(model.u), bounds=(0.0, None))
    model.s_rows = ConstraintList()
    for key, u in model.u.items():
        model.s_rows.add(model.s[key] >= u)
        model.s_rows.add(model.s[key] >= -u)


def _predicate_rows(model: ConcreteModel, enforced: Sequence[Enforced], pm: PlanModel) -> None:
    """``alpha(x(k)) - r >= 0`` for every enforced predicate, over the condensed states (its
    margin raised as step 1 raised it, :meth:`Problem.tightening`)."""
    model.predicates = ConstraintList()
    add_predicate_rows(model, enforced, pm)


def add_predicate_rows(model: ConcreteModel, enforced: Sequence[Enforced], pm: PlanModel) -> None:
    """Add to a continuous (or landing) model the rows of more enforced predicates."""
    margin = _row_margin(model, pm)
    for node, k, binding in _unique(enforced):
        raised = pm.problem.tightening(node, k)
        slack = alpha(node, k, binding, model.states) - margin - raised
        if not isinstance(slack, float):  # a number: decided by the initial state alone
            model.predicates.add(slack >= 0)


def broken_predicates(
    pm: PlanModel, enforced: Sequence[Enforced], states: Mapping[str, np.ndarray]
) -> int:
    """How many of the ``enforced`` predicates the trajectory ``states`` (agent name to an
    (H+1, n) array) breaks: ``alpha(x(k)) - r`` below ``-FEASIBILITY``, with the margin the
    continuous rows hold (raised as step 1 raised it). A step-1 plan can, its binaries met only
    within HiGHS's integrality tolerance (a big-M row relaxed by ``M 1e-6``)."""
    margin = _fixed_margin(pm)
    read = {(a, k, i): float(x[k, i]) for a, x in states.items() for k, i in np.ndindex(x.shape)}
    slacks = (
        alpha(node, k, binding, read) - margin - pm.problem.tightening(node, k)
        for node, k, binding in _unique(enforced)
    )
    return sum(1 for slack in slacks if slack < -FEASIBILITY)


def _row_margin(model: ConcreteModel, pm: PlanModel) -> Any:
    """The margin ``r`` of the predicate rows: the polish's variable, else step 1's margin."""
    return model.r if model.component("r") is not None else _fixed_margin(pm)


def plan_states(model: ConcreteModel, pm: PlanModel) -> dict[str, np.ndarray]:
    """The states of a solved continuous (or landing) model, agent name to an (H+1, n) array."""
    horizon = pm.problem.horizon
    return {
        a.name: np.array(
            [
                [float(value(model.states[a.name, k, i])) for i in range(a.n)]
                for k in range(horizon + 1)
            ]
        )
        for a in pm.problem.agents
    }


def plan_margin(model: ConcreteModel, pm: PlanModel) -> float:
    """The margin ``r`` the predicate rows of a solved continuous (or landing) model hold."""
    return float(value(_row_margin(model, pm)))


def _fixed_margin(pm: PlanModel) -> float:
    """Step 1's margin ``r``; when maximized, less :data:`FEASIBILITY`, never below the
    required margin."""
    margin = float(value(pm.margin))
    if isinstance(pm.margin, float):
        return margin
    floor = required_margin(pm.problem.mission.objective.margin.minimum)
    return max(floor, margin - FEASIBILITY)


def continuous_model(pm: PlanModel, enforced: Sequence[Enforced], stage: Stage) -> ConcreteModel:
    """The continuous model of step 2 (``effort``) or of the one-step polish (``polish``).

    Parameters
    ----------
    pm
        The step-1 model, its solution loaded (for the margin ``r``).
    enforced
        The predicates the fixed decisions enforce.
    stage
        ``effort``: minimize the mission's effort norm with ``r`` fixed at its step-1 value;
        ``polish``: maximize ``w r - beta sum s`` with ``r`` at least its step-1 value.
    """
    problem = pm.problem
    objective = problem.mission.objective
    model = ConcreteModel(name=f"{problem.mission.name}-{stage}")
    model.states = condensed_states(model, pm)
    if stage == "polish" or objective.effort != "l2":
        _absolute_inputs(model)
    margin: Any = _fixed_margin(pm)
    if stage == "polish" and not isinstance(pm.margin, float):
        model.r = Var(bounds=(margin, None))
        margin = model.r
    _predicate_rows(model, enforced, pm)
    if stage == "effort":
        names = [a.name for a in problem.agents]
        expr = effort_objective(model, names, objective.effort)
        model.goal = Objective(expr=expr, sense=minimize_sense)
    else:
        score: Any = -objective.beta * sum(model.s.values())
        if objective.margin.maximize:
            score = score + objective.margin.weight * margin
        model.goal = Objective(expr=score, sense=maximize_sense)
    return model


def landing_model(
    pm: PlanModel, enforced: Sequence[Enforced], target: Mapping[tuple[str, int, int], float]
) -> ConcreteModel:
    """The plan nearest ``target`` (inputs) that meets every enforced predicate: an LP.

    ``minimize sum |u - u_target|`` subject to the rows of :func:`continuous_model` with ``r``
    fixed; it lands the point of a continuous solve that ended short of optimality (HiGHS's QP
    solver can stop a hair outside a row) exactly on the predicates, as a simplex vertex.
    """
    model = ConcreteModel(name=f"{pm.problem.mission.name}-landing")
    model.states = condensed_states(model, pm)
    _predicate_rows(model, enforced, pm)
    model.far = Var(list(model.u), bounds=(0.0, None))
    model.far_rows = ConstraintList()
    for key, u in model.u.items():
        model.far_rows.add(model.far[key] >= u - target[key])
        model.far_rows.add(model.far[key] >= target[key] - u)
    model.goal = Objective(expr=sum(model.far.values()), sense=minimize_sense)
    return model


def copy_plan(source: ConcreteModel, pm: PlanModel) -> None:
    """Copy ``x``, ``u`` (and a maximized margin) of a solved continuous model into ``pm``."""
    for key, expr in source.states.items():
        if not pm.model.x[key].fixed:
            pm.model.x[key].set_value(float(value(expr)), skip_validation=True)
    for key, var in source.u.items():
        pm.model.u[key].set_value(var.value, skip_validation=True)
        pm.model.s[key].set_value(abs(var.value), skip_validation=True)
    if hasattr(source, "r") and not isinstance(pm.margin, float):
        pm.margin.set_value(source.r.value, skip_validation=True)
