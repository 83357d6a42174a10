"""The planning MILP: agents' dynamics, the global specification, and the objective of step 1.

Problem (step1) of the paper with DESIGN 2.2 (L1 effort, which keeps the model linear):

    maximize    t - beta * sum_{p,k,j} s_{p,k,j}  (+ w * r when the margin is maximized)
    subject to  x_p(k+1) = A_p x_p(k) + B_p u_p(k),  x_p(0) = x_p^0,  state and input boxes,
                s >= u, s >= -u                      (s = |u| at the optimum),
                every task, constraint and separation requirement (stl.py, tasks.py),
                t <= rho_s(T_s^l), 0 <= rho_s(T_s^l) <= gamma_l for every synchronous task,
                r >= max(margin.minimum, EPSILON)     (r fixed there when not maximized).

Every predicate is enforced as ``alpha(x) - r >= 0``, so with ``r >= EPSILON`` a region's boundary
is never both inside and outside (:mod:`stlplan.formula.boundary`).

``t = rho_s(Phi) = min_l rho_s(T_s^l)`` at the optimum; the term is absent without synchronous
tasks.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from pyomo.environ import (
    Binary,
    Block,
    ConcreteModel,
    Constraint,
    ConstraintList,
    Objective,
    Var,
    VarList,
    maximize,
)

from stlplan.analysis.reach import reachable_boxes
from stlplan.formula.boundary import required_margin
from stlplan.mission.problem import AgentModel, Problem
from stlplan.planner.config import Encoding, PlannerConfig, TaskForm
from stlplan.planner.encoding.deferred import Deferral, defer, segment_requirements
from stlplan.planner.encoding.floors import add_effort_floors
from stlplan.planner.encoding.ledger import Ledger
from stlplan.planner.encoding.selection import (
    Selection,
    SyncSelection,
    select_synchronous,
    select_task,
)
from stlplan.planner.encoding.sos1 import gray_code, sos1_block
from stlplan.planner.encoding.stl import StlContext, margin_ceiling, require
from stlplan.planner.encoding.symmetry import order_classes
from stlplan.planner.encoding.tasks import (
    SyncEncoding,
    TaskEncoding,
    all_formulas,
    encode_constraints,
    encode_separation,
    encode_synchronous,
    encode_task,
)

TaskChoice = TaskEncoding | Selection
"""A task's choice: group indicators, or element selections."""
SyncChoice = SyncEncoding | SyncSelection
"""A synchronous task's choice and ``rho_s``: counted runs per group, or a selected window."""


@dataclass(frozen=True, eq=False)
class PlanModel:
    """The Pyomo model of problem (step1) and the variables the solver reads back.

    Attributes
    ----------
    model
        The ``ConcreteModel``; ``model.x[p, k, i]``, ``model.u[p, k, j]``, ``model.s[p, k, j]``.
    problem
        The problem it encodes.
    tasks
        Group indicators of each ordinary task.
    synchronous
        ``rho_s`` and counting variables of each synchronous task.
    t
        ``rho_s(Phi)`` lower bound variable, or None without synchronous tasks.
    margin
        Spatial margin ``r``: a variable when maximized, else the required minimum.
    encoding
        ``"log"`` or ``"standard"`` SOS1.
    ledger
        Every predicate the encoding placed (for step 2).
    context, deferral, added, parts
        For a lazy model: the encoding context, the step requirements left out of the model,
        which of them were added later and their variables.
    """

    model: ConcreteModel
    problem: Problem
    tasks: tuple[TaskChoice, ...]
    synchronous: tuple[SyncChoice, ...]
    t: Any
    margin: Any
    encoding: Encoding
    ledger: Ledger
    context: StlContext | None = None
    """Where the lazy loop encodes the requirements it adds (lazy models only)."""
    deferral: Deferral | None = None
    """Requirements left out of the model (lazy models only)."""
    added: set[int] = field(default_factory=set)
    """Indices of the lazy requirements added to the model since."""
    parts: dict[int, LazyPart] = field(default_factory=dict)
    """The variables each added requirement brought (see :func:`assign_side`)."""

    def pending(self) -> list[int]:
        """Indices of the lazy requirements not in the model (none for an up-front model)."""
        if self.deferral is None:
            return []
        return [n for n in range(len(self.deferral.lazy)) if n not in self.added]

    def states(self, agent: AgentModel) -> list[list[Any]]:
        """``x_p(k)[i]`` variables, ``k = 0..H``."""
        return [
            [self.model.x[agent.name, k, i] for i in range(agent.n)]
            for k in range(self.problem.horizon + 1)
        ]

    def inputs(self, agent: AgentModel) -> list[list[Any]]:
        """``u_p(k)[j]`` variables, ``k = 0..H-1``."""
        return [
            [self.model.u[agent.name, k, j] for j in range(agent.m)]
            for k in range(self.problem.horizon)
        ]


def add_agents(
    model: ConcreteModel, problem: Problem, boxes: Mapping[str, tuple[np.ndarray, np.ndarray]]
) -> None:
    """Variables ``x`` (bounded by ``boxes``), ``u``, ``s``; dynamics and initial state.

    ``x_p(k+1) = A_p x_p(k) + B_p u_p(k)``, ``x_p(0) = x_p^0`` (fixed), ``s >= |u|`` with
    ``0 <= s <= max(|u_lo|, |u_hi|)``, and ``(A_p - I) x_p(H) = 0`` for an agent that ends at rest.
    In a replan, the states known (:meth:`Problem.known_through`) are fixed and the dynamics and
    inputs start there.
    """
    H = problem.horizon
    x_box = {
        (a.name, k, i): (float(boxes[a.name][0][k, i]), float(boxes[a.name][1][k, i]))
        for a in problem.agents
        for k in range(H + 1)
        for i in range(a.n)
    }
    u_box = {
        (a.name, k, j): (
            float(a.input_lo[j] + problem.input_room(a, k)[j]),
            float(a.input_hi[j] - problem.input_room(a, k)[j]),
        )
        for a in problem.agents
        for k in range(H)
        for j in range(a.m)
    }
    model.x = Var(list(x_box), bounds=lambda _, *key: x_box[key])
    model.u = Var(list(u_box), bounds=lambda _, *key: u_box[key])
    model.s = Var(list(u_box), bounds=lambda _, *key: (0.0, max(map(abs, u_box[key]))))
    model.dynamics = ConstraintList()
    model.effort_rows = ConstraintList()
    for a in problem.agents:
        known = problem.known_through(a.name)
        _fix_known(model, problem, a, known)
        for k in range(known, H):
            for i in range(a.n):
                drift = sum(a.A[i, c] * model.x[a.name, k, c] for c in range(a.n) if a.A[i, c])
                push = sum(a.B[i, c] * model.u[a.name, k, c] for c in range(a.m) if a.B[i, c])
                model.dynamics.add(model.x[a.name, k + 1, i] == drift + push)
        if a.at_rest and known < H:
            for row in a.rest_rows():
                model.dynamics.add(
                    sum(c * model.x[a.name, H, i] for i, c in enumerate(row) if c) == 0
                )
        for k, j in ((k, j) for k in range(known, H) for j in range(a.m)):
            model.effort_rows.add(model.s[a.name, k, j] >= model.u[a.name, k, j])
            model.effort_rows.add(model.s[a.name, k, j] >= -model.u[a.name, k, j])


def _fix_known(model: ConcreteModel, problem: Problem, agent: AgentModel, known: int) -> None:
    """Fix the states of steps ``0..known`` (the initial state, or a replan's executed past) and
    the inputs before ``known`` at 0: the objective counts the planned inputs only."""
    for k in range(known + 1):
        x = agent.initial_state if problem.past is None else problem.past.state(agent.name, k)
        for i in range(agent.n):
            model.x[agent.name, k, i].fix(float(x[i]))
    for k, j in ((k, j) for k in range(known) for j in range(agent.m)):
        model.u[agent.name, k, j].fix(0.0)
        model.s[agent.name, k, j].fix(0.0)


def _margin(
    model: ConcreteModel, problem: Problem, boxes: Mapping[str, tuple[np.ndarray, np.ndarray]]
) -> tuple[Any, float]:
    """``r``: the required margin (a number), or a variable in ``[required, ceiling]``.

    The required margin is ``max(minimum, EPSILON)`` (:func:`stlplan.formula.boundary.required_margin`).
    """
    spec = problem.mission.objective.margin
    floor = required_margin(spec.minimum)
    if not spec.maximize:
        return floor, floor
    reach = margin_ceiling(all_formulas(problem), boxes, problem.horizon)
    ceiling = max(floor, reach)
    model.r = Var(bounds=(floor, ceiling))
    return model.r, ceiling


def _spec_block(model: ConcreteModel) -> Block:
    model.spec = Block()
    model.spec.indicators = VarList(bounds=(0, 1))
    model.spec.reals = VarList()
    model.spec.binaries = VarList(domain=Binary)
    model.spec.rows = ConstraintList()
    model.sos = sos1_block()
    return model.spec


def add_objective(
    model: ConcreteModel, problem: Problem, synchronous: tuple[SyncChoice, ...], margin: Any
) -> Any:
    """``maximize t - beta sum(s) (+ w r)`` with ``t <= rho_s^l``; returns ``t`` (or None)."""
    objective = problem.mission.objective
    score: Any = -objective.beta * sum(model.s.values())
    t = None
    if synchronous:
        model.t = Var(bounds=(0.0, min(e.rho_s.ub for e in synchronous)))
        model.t_rows = Constraint(
            range(len(synchronous)), rule=lambda m, i: m.t <= synchronous[i].rho_s
        )
        t = model.t
        score = score + t
    if objective.margin.maximize:
        score = score + objective.margin.weight * margin
    model.step1 = Objective(expr=score, sense=maximize)
    return t


def encode_tasks(
    ctx: StlContext, problem: Problem, task_encoding: TaskForm, symmetry: bool = False
) -> tuple[tuple[TaskChoice, ...], tuple[SyncChoice, ...]]:
    """Every task and synchronous task, by groups or by selection; with ``symmetry`` (selection
    only), one chain of ordering rows per class of interchangeable agents
    (:mod:`stlplan.planner.encoding.symmetry`)."""
    if task_encoding == "selection":
        plain = tuple(select_task(ctx, problem, t) for t in problem.tasks if t.sync is None)
        sync = tuple(select_synchronous(ctx, problem, t) for t in problem.tasks if t.sync)
        if symmetry:
            order_classes(ctx, problem, plain + sync)
        return plain, sync
    plain_g = tuple(encode_task(ctx, problem, t) for t in problem.tasks if t.sync is None)
    sync_g = tuple(encode_synchronous(ctx, problem, t) for t in problem.tasks if t.sync)
    return plain_g, sync_g


def build_model(
    problem: Problem,
    config: PlannerConfig | None = None,
    floors_deadline: float = math.inf,
    deferral: Deferral | None = None,
) -> PlanModel:
    """Encode ``problem`` as the MILP of step 1, as ``config`` (default: the defaults of
    :class:`~stlplan.planner.config.PlannerConfig`, as planning has them) declares it.

    Parameters
    ----------
    problem
        A checked problem (:func:`stlplan.mission.problem.build_problem`).
    config
        ``model.encoding``: disjunctions and group choices as a logarithmic SOS1 (``"log"``) or
        with one binary per entry (``"standard"``). ``lazy.enabled``: leave the step
        requirements of constraints and separation out (see
        :mod:`stlplan.planner.encoding.deferred`); :func:`add_requirements` adds them on demand.
        ``model.floors``: add the effort floors of :mod:`stlplan.planner.encoding.floors` (valid
        cuts; with ``beta > 0``). ``model.tasks``: tasks by enumerating groups (``"groups"``,
        the paper's) or by selecting elements (``"selection"``,
        :mod:`stlplan.planner.encoding.selection`). ``model.symmetry``: with selection, order
        the task shares of interchangeable agents (:mod:`stlplan.planner.encoding.symmetry`).
        A replan (``problem.past``) gets neither floors nor symmetry rows: both read the agents
        as they stand at step 0.
    floors_deadline
        ``time.perf_counter()`` time after which no more floors are computed.
    deferral
        With ``lazy.enabled``, the split of ``problem``'s requirements made for another model of
        it (reused, its requirements shared; default: made here).
    """
    config = config or PlannerConfig()
    settings = config.model
    encoding, lazy = settings.encoding, config.lazy.enabled
    # a replan's agents differ by their pasts, and the floors assume a plan from step 0
    floors, symmetry = (
        (settings.floors, settings.symmetry) if problem.past is None else (False, False)
    )
    model = ConcreteModel(name=problem.mission.name)
    boxes = reachable_boxes(problem)
    add_agents(model, problem, boxes)
    margin, ceiling = _margin(model, problem, boxes)
    block = _spec_block(model)
    ctx = StlContext(
        block=block,
        sos=model.sos,
        states=model.x,
        boxes=boxes,
        horizon=problem.horizon,
        margin=margin,
        margin_ceiling=ceiling,
        encoding=encoding,
        tightening=problem.tightening,
        by_roles_read=settings.shared_subformulas,
    )
    tasks, synchronous = encode_tasks(ctx, problem, settings.tasks, symmetry)
    if lazy:
        deferral = deferral or defer(problem, boxes, ceiling)
        for formula, k, binding in deferral.eager:
            require(formula, k, ctx.bound(binding))
    else:
        deferral = None
        encode_constraints(ctx, problem)
        encode_separation(ctx, problem)
        for requirement in segment_requirements(problem):
            requirement.encode(ctx)
    t = add_objective(model, problem, synchronous, margin)
    if floors and problem.mission.objective.beta > 0:
        minimum = required_margin(problem.mission.objective.margin.minimum)
        add_effort_floors(model, problem, ctx.ledger, minimum, settings, floors_deadline)
    return PlanModel(
        model, problem, tasks, synchronous, t, margin, encoding, ctx.ledger, ctx, deferral
    )


@dataclass(frozen=True, eq=False)
class LazyPart:
    """What one added requirement brought: ``z_i`` per half-plane, ``w_i <= z_i``, SOS1 binaries."""

    indicators: list[Any]
    chosen: list[Any]
    binaries: list[Any]


def add_requirements(pm: PlanModel, indices: Iterable[int]) -> None:
    """Encode the lazy requirements ``indices`` into a lazy model, as :func:`build_model` would.

    Each ``OR_i alpha_i - r >= 0`` becomes an SOS1 over fresh ``w_i <= z_i`` (one binary per
    half-plane with the standard encoding), exactly as an up-front constraint; on a segment, each
    ``z_i`` enforces its half-plane at both ends. Indices already
    added are skipped.
    """
    assert pm.context is not None and pm.deferral is not None, "the model was built lazy"
    ctx = pm.context
    for n in sorted(set(indices) - pm.added):
        req = pm.deferral.lazy[n]
        first_binary, first_choice = len(ctx.sos.binaries), len(ctx.ledger.choices)
        req.encode(ctx)
        pm.added.add(n)
        if len(ctx.ledger.choices) > first_choice:
            _, indicators, chosen = ctx.ledger.choices[-1]
            binaries = [ctx.sos.binaries[i + 1] for i in range(first_binary, len(ctx.sos.binaries))]
            pm.parts[n] = LazyPart(indicators, chosen, binaries)


def assign_side(pm: PlanModel, n: int, side: int) -> None:
    """Set the variables of added requirement ``n`` to enforce its half-plane ``side``.

    ``z_side = w_side = 1``, the other ``w_i = 0``, and the SOS1 binaries that select ``side``
    (``b_i = [i = side]``, or the bits of the Gray code of ``side``).
    """
    part = pm.parts.get(n)
    if part is None:
        return
    part.indicators[side].set_value(1.0)
    for i, w in enumerate(part.chosen):
        w.set_value(1.0 if i == side else 0.0)
    if pm.encoding == "standard":
        bits = [1.0 if i == side else 0.0 for i in range(len(part.binaries))]
    else:
        code = gray_code(side)
        bits = [float(code >> bit & 1) for bit in range(len(part.binaries))]
    for y, bit in zip(part.binaries, bits, strict=True):
        y.set_value(bit)
