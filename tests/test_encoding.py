"""The STL encoding: boolean truth tables, predicates, temporal operators, model structure."""

from __future__ import annotations

import itertools
import random
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pyomo.contrib.solver.common.results import TerminationCondition
from pyomo.contrib.solver.solvers.highs import Highs
from pyomo.environ import (
    Binary,
    Block,
    ConcreteModel,
    ConstraintList,
    Objective,
    Var,
    VarList,
    maximize,
    minimize,
    value,
)

from stlplan.analysis.reach import reachable_boxes
from stlplan.formula.parser import parse
from stlplan.mission.problem import Problem, build_problem
from stlplan.mission.schema import Mission
from stlplan.planner.config import PlannerConfig
from stlplan.planner.encoding.model import build_model
from stlplan.planner.encoding.sos1 import sos1_block
from stlplan.planner.encoding.stl import (
    StlContext,
    conjunction,
    disjunction,
    encode,
    predicate_range,
)
from tests.helpers.configs import paper_model
from tests.helpers.dynamics import SINGLE_INTEGRATOR_U1, double_integrator, single_integrator
from tests.helpers.solving import ENCODINGS


def _solve(model: ConcreteModel, target, sense) -> float | None:
    """Optimum of ``target`` over ``model``, or None when infeasible."""
    if hasattr(model, "goal"):
        model.del_component("goal")
    model.goal = Objective(expr=target, sense=sense)
    solver = Highs()
    solver.config.load_solutions = False
    solver.config.raise_exception_on_nonoptimal_result = False
    results = solver.solve(model)
    if results.termination_condition != TerminationCondition.convergenceCriteriaSatisfied:
        return None
    return float(results.incumbent_objective)


def _context(model: ConcreteModel, encoding: str, problem: Problem | None = None) -> StlContext:
    model.spec = Block()
    model.spec.indicators = VarList(bounds=(0, 1))
    model.spec.reals = VarList()
    model.spec.binaries = VarList(domain=Binary)
    model.spec.rows = ConstraintList()
    model.sos = sos1_block()
    boxes = reachable_boxes(problem) if problem else {}
    return StlContext(
        block=model.spec,
        sos=model.sos,
        states=getattr(model, "x", None),
        boxes=boxes,
        horizon=problem.horizon if problem else 0,
        margin=0.0,
        margin_ceiling=0.0,
        encoding=encoding,
    )  # type: ignore[arg-type]


Builder = Callable[[StlContext, Sequence], object]
CASES: list[tuple[str, int, Builder, Callable[[Sequence[int]], bool]]] = [
    *[(f"and{n}", n, lambda c, z: conjunction(c, z), all) for n in range(2, 6)],
    *[(f"or{n}", n, lambda c, z: disjunction(c, z), any) for n in range(2, 6)],
    (
        "(a & b) | c",
        3,
        lambda c, z: disjunction(c, [conjunction(c, z[:2]), z[2]]),
        lambda v: (v[0] and v[1]) or v[2],
    ),
    (
        "(a | b) & (b | c)",
        3,
        lambda c, z: conjunction(c, [disjunction(c, z[:2]), disjunction(c, z[1:])]),
        lambda v: (v[0] or v[1]) and (v[1] or v[2]),
    ),
    (
        "(a | b) & a & b  (shared children)",
        2,
        lambda c, z: conjunction(c, [disjunction(c, z), z[0], z[1]]),
        lambda v: bool(v[0] and v[1]),
    ),
    (
        "((a | b) & c) | (d & (a | c))",
        4,
        lambda c, z: disjunction(
            c,
            [
                conjunction(c, [disjunction(c, z[:2]), z[2]]),
                conjunction(c, [z[3], disjunction(c, [z[0], z[2]])]),
            ],
        ),
        lambda v: bool(((v[0] or v[1]) and v[2]) or (v[3] and (v[0] or v[2]))),
    ),
]


@pytest.mark.parametrize("encoding", ENCODINGS)
@pytest.mark.parametrize(("name", "arity", "build", "truth"), CASES, ids=[c[0] for c in CASES])
def test_boolean_encoding_truth_table(name, arity, build, truth, encoding) -> None:
    model = ConcreteModel()
    model.child = Var(range(arity), bounds=(0, 1))
    ctx = _context(model, encoding)
    parent = build(ctx, [model.child[i] for i in range(arity)])
    for bits in itertools.product((0, 1), repeat=arity):
        for i, bit in enumerate(bits):
            model.child[i].fix(bit)
        best = _solve(model, parent, maximize)
        assert best is not None
        assert abs(best - (1.0 if truth(bits) else 0.0)) < 1e-9, (name, bits)
        assert abs(_solve(model, parent, minimize) or 0.0) < 1e-9  # z = 0 is always allowed


def _line_mission(
    steps: int, regions: dict[str, list[list[float]]], start: float = 0, tasks: dict | None = None
) -> Problem:
    """One single-integrator agent on the plane, position = state, starting at ``(start, 0)``."""
    return build_problem(
        Mission.model_validate(
            {
                "name": "line",
                "horizon": steps,
                "dynamics": {"si": single_integrator(10)},
                "agents": [{"name": "a1", "dynamics": "si", "initial_state": [start, 0]}],
                "regions": {n: {"box": b} for n, b in regions.items()},
                "tasks": tasks or {},
            }
        )
    )


def _fixed_path_model(problem: Problem, xs: Sequence[float], encoding: str):
    model = ConcreteModel()
    keys = [("a1", k, i) for k in range(problem.horizon + 1) for i in range(2)]
    model.x = Var(keys, bounds=(-5, 5))
    for k, px in enumerate(xs):
        model.x["a1", k, 0].fix(px)
        model.x["a1", k, 1].fix(0.0)
    return model, _context(model, encoding, problem)


REGIONS = {"A": [[0, 2], [-1, 1]], "B": [[1, 3], [-1, 1]]}
SPOTS = {"a": 0.5, "ab": 1.5, "b": 2.5, "none": 4.0}  # x position: in A only, both, B only, none
TEMPORAL: list[tuple[str, Callable[[Sequence[str]], bool]]] = [
    ("F[1,3] in(p, B)", lambda s: any("b" in s[k] for k in range(1, 4))),
    ("G[0,2] in(p, A)", lambda s: all("a" in s[k] for k in range(3))),
    (
        "in(p, A) U[1,3] in(p, B)",
        lambda s: any("b" in s[t] and all("a" in s[u] for u in range(t + 1)) for t in range(1, 4)),
    ),
    (
        "in(p, A) U*[1,3] in(p, B)",
        lambda s: any("b" in s[t] and all("a" in s[u] for u in range(t)) for t in range(1, 4)),
    ),
    (
        "in(p, B) U*[0,2] !in(p, A)",
        lambda s: any("a" not in s[t] and all("b" in s[u] for u in range(t)) for t in range(3)),
    ),
    ("F[0,2] G[0,1] in(p, A)", lambda s: any("a" in s[t] and "a" in s[t + 1] for t in range(3))),
    (
        "G[0,1] (in(p, A) | F[1,2] in(p, B))",
        lambda s: all(
            "a" in s[t] or any("b" in s[u] for u in range(t + 1, t + 3)) for t in range(2)
        ),
    ),
    (
        "!in(p, A) & F[2,4] !in(p, B)",
        lambda s: "a" not in s[0] and any("b" not in s[t] for t in range(2, 5)),
    ),
]


@pytest.mark.parametrize("encoding", ENCODINGS)
@pytest.mark.parametrize(("text", "truth"), TEMPORAL, ids=[t[0] for t in TEMPORAL])
def test_temporal_indicator_matches_semantics_on_fixed_paths(text, truth, encoding) -> None:
    rng = random.Random(7)
    paths = [tuple(rng.choice(list(SPOTS)) for _ in range(5)) for _ in range(12)]
    for spots in paths:
        problem = _line_mission(4, REGIONS, start=SPOTS[spots[0]])
        formula = problem.lowered(parse(text), {"p": "a1"})
        model, ctx = _fixed_path_model(problem, [SPOTS[s] for s in spots], encoding)
        z = encode(formula, 0, ctx.bound({"p": "a1"}))
        best = _solve(model, z, maximize)
        assert best is not None
        # z = 1 enforces the formula; below 1 (possibly fractional) enforces nothing
        assert (best > 1 - 1e-7) == truth(spots), (text, spots, best)


def test_predicate_big_m_comes_from_reachable_boxes() -> None:
    # single integrator from (1, 0), |u| <= 10 per axis, state box [-5, 5]^2
    problem = _line_mission(2, REGIONS, start=1.0)
    boxes = reachable_boxes(problem)
    np.testing.assert_allclose(boxes["a1"][0][0], [1, 0])
    np.testing.assert_allclose(boxes["a1"][0][1], [-5, -5])
    pred = problem.lowered(parse("p.x[0] - 2 * p.x[1] >= 1"), {"p": "a1"})
    assert predicate_range(pred, 1, {"p": "a1"}, boxes) == (-5 - 10 - 1, 5 + 10 - 1)
    assert predicate_range(pred, 0, {"p": "a1"}, boxes) == (0, 0)


def test_reachable_boxes_of_a_double_integrator() -> None:
    # from rest at 0 with |u| <= 1: p(1) in [-0.5, 0.5], v(1) in [-1, 1], p(2) in [-2, 2]
    problem = build_problem(
        Mission.model_validate(
            {
                "name": "di",
                "horizon": 2,
                "dynamics": {"di": double_integrator(1, ((-1.5, 5), (-5, 5)))},
                "agents": [{"name": "a", "dynamics": "di", "initial_state": [0, 0, 0, 0]}],
            }
        )
    )
    lo, hi = reachable_boxes(problem)["a"]
    np.testing.assert_allclose(hi[1], [0.5, 0.5, 1, 1])
    np.testing.assert_allclose(hi[2], [2, 2, 2, 2])
    np.testing.assert_allclose(lo[2], [-1.5, -2, -2, -2])  # clipped by the state box


def _team(agents: Sequence[tuple[str, str]], regions: dict, tasks: dict) -> Problem:
    """Single integrators named and capable as ``agents``, started along a line, horizon 3."""
    return build_problem(
        Mission.model_validate(
            {
                "name": "team",
                "horizon": 3,
                "dynamics": {"si": SINGLE_INTEGRATOR_U1},
                "agents": [
                    {"name": n, "dynamics": "si", "capabilities": [c], "initial_state": [0, i]}
                    for i, (n, c) in enumerate(agents)
                ],
                "regions": {name: {"box": box} for name, box in regions.items()},
                "tasks": tasks,
            }
        )
    )


def _predicate_rows(pm: Any) -> int:
    return sum(1 for r in pm.model.spec.rows.values() if "x[" in str(r.body))


def test_shared_elements_are_encoded_once() -> None:
    problem = _team(
        [(f"a{i}", "V") for i in range(4)],
        {"G": [[1, 2], [-5, 5]]},
        {"reach": {"formula": "F[1,3] in(p, G)", "count": 2, "roles": {"p": "V"}}},
    )
    task = problem.tasks[0]
    assert len(task.elements) == 4 and len(task.groups) == 6
    pm = build_model(problem, paper_model(model__encoding="log"))
    # F over 3 steps per element: 3 steps x 4 half-planes predicates, one per element and step
    assert _predicate_rows(pm) == 4 * 3 * 4


@pytest.mark.parametrize(("shared", "expected"), [(True, 2 * 2 * 3 * 4), (False, 4 * 2 * 3 * 4)])
def test_elements_share_the_subformulas_of_their_common_agents(shared: bool, expected: int) -> None:
    problem = _team(
        [("v0", "V"), ("v1", "V"), ("w0", "W"), ("w1", "W")],
        {"G": [[1, 2], [-5, 5]], "H": [[-2, -1], [-5, 5]]},
        {
            "meet": {
                "formula": "F[1,3] in(p, G) & F[1,3] in(q, H)",
                "roles": {"p": "V", "q": "W"},
            }
        },
    )
    assert len(problem.tasks[0].elements) == 4  # (p, q) in {v0, v1} x {w0, w1}
    config = PlannerConfig().with_overrides(
        {"lazy.enabled": False, "model.floors": False, "model.shared_subformulas": shared}
    )
    # F over 3 steps, 4 half-planes a region: once per agent of a role, or once per element
    assert _predicate_rows(build_model(problem, config)) == expected


@pytest.mark.parametrize("encoding", ENCODINGS)
def test_log_encoding_uses_fewer_binaries(encoding) -> None:
    task = {"formula": "F[0,8] in(p, B) | F[0,8] in(p, A)", "roles": {"p": {"agent": "a1"}}}
    pm = build_model(
        _line_mission(8, REGIONS, tasks={"t": task}),
        paper_model(model__encoding=encoding),
    )
    binaries = [v for v in pm.model.component_data_objects(Var) if v.is_binary()]
    # required Or of 2 F's: SOS1 over 2 entries; each F[0,8]: SOS1 over {1 - z, 9 entries}
    expected = {"log": 1 + 2 * 4, "standard": 2 + 2 * 10}[encoding]
    assert len(binaries) == expected
    assert all(value(v.lb) == 0 for v in binaries)


def _until_holds(spots: Sequence[str], lo: int, hi: int, strict: bool) -> bool:
    """``in(p, A) U[lo,hi] in(p, B)`` (``U*`` when ``strict``) at 0, from its definition."""
    for t in range(lo, hi + 1):
        lefts = range(t) if strict else range(t + 1)
        if "b" in spots[t] and all("a" in spots[u] for u in lefts):
            return True
    return False


@settings(max_examples=40, deadline=None)
@given(
    spots=st.lists(st.sampled_from(list(SPOTS)), min_size=5, max_size=5),
    bounds=st.tuples(st.integers(0, 4), st.integers(0, 4)).map(sorted),
    strict=st.booleans(),
    encoding=st.sampled_from(ENCODINGS),
)
def test_both_untils_match_their_definition_in_the_milp(
    spots: list[str], bounds: list[int], strict: bool, encoding: str
) -> None:
    lo, hi = bounds
    op = "U*" if strict else "U"
    problem = _line_mission(4, REGIONS, start=SPOTS[spots[0]])
    formula = problem.lowered(parse(f"in(p, A) {op}[{lo},{hi}] in(p, B)"), {"p": "a1"})
    model, ctx = _fixed_path_model(problem, [SPOTS[s] for s in spots], encoding)
    best = _solve(model, encode(formula, 0, ctx.bound({"p": "a1"})), maximize)
    assert best is not None
    assert (best > 1 - 1e-7) == _until_holds(spots, lo, hi, strict)
