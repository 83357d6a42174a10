"""Lazy obstacle and collision rows, and effort floors: the same optimum as the up-front model."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from stlplan.analysis.reach import reachable_boxes
from stlplan.formula.boundary import EPSILON
from stlplan.formula.parser import parse
from stlplan.formula.tree import step_parts
from stlplan.mission.loader import load_problem
from stlplan.mission.problem import Problem
from stlplan.pipeline import plan
from stlplan.planner.config import PlannerConfig
from stlplan.planner.core.lazy import LazySolver
from stlplan.planner.core.watch import Watch
from stlplan.planner.encoding.alphas import alpha_maxima, alpha_values, best_sides, violated
from stlplan.planner.encoding.deferred import (
    SEPARATION,
    best_side,
    defer,
    families,
)
from stlplan.planner.encoding.model import build_model
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.clock import Clock
from stlplan.planner.run.outcome import Plan, lowest
from stlplan.result import PlanStatus
from tests.helpers.configs import paper_model
from tests.helpers.missions import mission, swap_problem
from tests.helpers.paths import MISSIONS
from tests.helpers.solving import accepted, solve


def detour_problem(with_obstacle: bool, inter_sample: bool = True) -> Problem:
    # the straight way to the goal crosses the obstacle, 1.6 wide: no step of 1 hops over it, so
    # one step has |y| >= 1 (a detour of 1 up and 0.9 back)
    return mission(
        safety={"inter_sample": inter_sample},
        horizon=6,
        agents=[{"name": "a", "dynamics": "si", "initial_state": [0, 0]}],
        regions={
            "Goal": {"box": [[3.9, 4.1], [-0.1, 0.1]]},
            "Obs": {"box": [[1.2, 2.8], [-1, 1]]},
        },
        tasks={"reach": {"formula": "F[4,6] in(p, Goal)", "roles": {"p": {"agent": "a"}}}},
        constraints={"avoid": {"formula": "G[0,6] !in(p, Obs)", "for_each": "p"}}
        if with_obstacle
        else {},
        objective={"beta": 1.0, "effort": "l1"},
    )


@pytest.mark.parametrize("encoding", ["standard", "log"])
def test_collision_binds_and_lazy_matches_up_front(encoding: str) -> None:
    problem = swap_problem(separation=0.5)
    free, _ = solve(swap_problem(separation=None), {"model.encoding": encoding})
    lazy, rounds = solve(problem, {"model.encoding": encoding, "lazy.enabled": True})
    up_front, _ = solve(
        problem, {"model.encoding": encoding, "lazy.enabled": False, "model.floors": False}
    )
    assert lazy.status is up_front.status is PlanStatus.OPTIMAL
    assert lazy.objective is not None and up_front.objective is not None
    assert free.objective is not None and free.objective > up_front.objective + 0.1  # it binds
    assert lazy.objective == pytest.approx(up_front.objective, abs=1e-6)
    # every predicate holds with the margin EPSILON: x reaches 1.9 + e, y goes 0.25 + e/2 out
    # (a gap of 0.5 + e) and 0.15 + 3e/2 back (to within 0.1 - e of the axis)
    assert up_front.objective == pytest.approx(-(2 * 1.9 + 2 * 0.4 + 6 * EPSILON), abs=1e-9)
    assert rounds >= 2  # the first plan collided
    assert accepted(problem, lazy) and accepted(problem, up_front)


def test_obstacle_binds_and_lazy_matches_up_front() -> None:
    problem = detour_problem(with_obstacle=True)
    free, _ = solve(detour_problem(with_obstacle=False))
    lazy, rounds = solve(
        problem,
        {
            "lazy.enabled": True,
            "repair.after_round_seconds": None,
            "repair.crowd_agents": None,
        },
    )
    repaired, _ = solve(problem, {"lazy.enabled": True, "repair.after_round_seconds": 0.0})
    up_front, _ = solve(problem, {"lazy.enabled": False, "model.floors": False})
    assert lazy.status is repaired.status is up_front.status is PlanStatus.OPTIMAL
    assert lazy.objective is not None and up_front.objective is not None
    assert free.objective is not None and free.objective > up_front.objective + 0.1
    assert lazy.objective == pytest.approx(up_front.objective, abs=1e-6)
    assert repaired.objective == pytest.approx(up_front.objective, abs=1e-6)
    # with the margin EPSILON: x reaches 3.9 + e, y goes 1 + e up and 0.9 + 2e back
    assert up_front.objective == pytest.approx(-(3.9 + 1.9 + 4 * EPSILON), abs=1e-9)
    assert rounds >= 2  # the first plan went through the obstacle
    assert accepted(problem, lazy) and accepted(problem, repaired)


@pytest.mark.parametrize("lazy", [True, False])
def test_effort_floors_keep_the_optimum(lazy: bool) -> None:
    problem = swap_problem(separation=0.5)
    with_floors, _ = solve(problem, {"lazy.enabled": lazy, "model.floors": True})
    without, _ = solve(problem, {"lazy.enabled": lazy, "model.floors": False})
    assert with_floors.objective == pytest.approx(without.objective, abs=1e-6)


def test_floors_add_rows_and_fix_unreachable_indicators() -> None:
    # a may reach East at step 1 or 2
    problem = swap_problem(separation=0.5, east_from=1)
    plain = build_model(problem, paper_model(model__encoding="standard"))
    floored = build_model(problem, paper_model(model__floors=True, model__encoding="standard"))
    assert not hasattr(plain.model, "effort_floors")
    assert len(floored.model.effort_floors) > len(problem.agents)  # e_p rows and cuts
    # East is 1.9 away from a: unreachable at step 1 with |u| <= 1, so that disjunct (the
    # conjunction of East's four half-planes for a at step 1) is fixed off, the step-2 one is not
    fixed = [
        c.body
        for c in floored.model.effort_floors.values()
        if c.upper == 0 and c.lower is None and c.body.is_variable_type()
    ]
    ledger = floored.ledger
    children = {id(z): leaves for z, leaves in ledger.conjunctions}
    guarded = {id(z): (node, k, dict(binding)) for z, (node, k, binding) in ledger.guarded}
    (off,) = fixed
    enforced = [guarded[id(leaf)] for leaf in children[id(off)]]
    assert len(enforced) == 4
    assert {(k, binding["p"]) for _, k, binding in enforced} == {(1, "a")}
    # East = [1.9, 2.1] x [-0.1, 0.1]: x >= 1.9, -x >= -2.1, y >= -0.1, -y >= -0.1
    bounds = sorted(node.bound for node, _, _ in enforced)
    assert bounds == pytest.approx([-2.1, -0.1, -0.1, 1.9])


def test_step_parts_unrolls_always_and_and() -> None:
    formula = parse("G[1,3] (p.x[0] >= 1 & p.x[1] >= 2)")
    parts = list(step_parts(formula, 0))
    assert sorted(k for _, k in parts) == [1, 1, 2, 2, 3, 3]


def test_defer_drops_requirements_reachability_proves() -> None:
    problem = detour_problem(with_obstacle=True, inter_sample=False)
    boxes = reachable_boxes(problem)
    deferral = defer(problem, boxes, margin_ceiling=0.0)
    # from x = 0 with |u| <= 1 the obstacle (x >= 1.2) is out of reach at steps 0 and 1
    assert deferral.dropped == 2
    assert sorted(r.k for r in deferral.lazy) == [2, 3, 4, 5, 6]
    assert {r.span for r in deferral.lazy} == {0}
    assert not deferral.eager


def test_defer_joins_steps_into_segments() -> None:
    problem = detour_problem(with_obstacle=True)
    deferral = defer(problem, reachable_boxes(problem), margin_ceiling=0.0)
    # segments 0 -> 1 .. 5 -> 6; only 0 -> 1 lies wholly west of the obstacle
    assert deferral.dropped == 1
    assert sorted(r.k for r in deferral.lazy) == [1, 2, 3, 4, 5]
    assert {r.span for r in deferral.lazy} == {1}


def test_violations_and_their_families() -> None:
    problem = swap_problem(separation=0.5, horizon=4)
    deferral = defer(problem, reachable_boxes(problem), margin_ceiling=0.0)
    assert {r.source for r in deferral.lazy} == {SEPARATION}
    line = np.linspace(0, 2, 5)
    states = {
        "a": np.column_stack([line, np.zeros(5)]),
        "b": np.column_stack([line[::-1], np.zeros(5)]),
    }
    bad = violated(deferral.lazy, states, margin=0.0, tolerance=1e-9)
    assert [deferral.lazy[n].k for n in bad] == [2]  # both at x = 1 at step 2
    assert len(families(deferral.lazy, bad)) == len(deferral.lazy)


def test_segment_violations_between_safe_samples() -> None:
    problem = swap_problem(separation=0.5, horizon=4, inter_sample=True)
    deferral = defer(problem, reachable_boxes(problem), margin_ceiling=0.0)
    assert {r.span for r in deferral.lazy} == {1}
    # a passes b: apart at every step but 2, through each other on the segments 1-2 and 2-3
    line = np.linspace(0, 2, 5)
    states = {
        "a": np.column_stack([line, np.zeros(5)]),
        "b": np.column_stack([line[::-1], np.zeros(5)]),
    }
    bad = violated(deferral.lazy, states, margin=0.0, tolerance=1e-9)
    assert [deferral.lazy[n].k for n in bad] == [1, 2]
    # b steps aside at step 2: every sample keeps 0.5 apart, yet the segments 1-2 and 2-3 cut
    # the corner of the separation box
    states["b"] = np.array([[2, 0], [1.5, 0], [1, 0.6], [0.5, 0], [0, 0]], dtype=float)
    states["a"] = np.array([[0, 0], [0.5, 0], [1, 0], [1.5, 0], [2, 0]], dtype=float)
    sampled = swap_problem(separation=0.5, horizon=4, inter_sample=False)
    steps = defer(sampled, reachable_boxes(sampled), margin_ceiling=0.0)
    assert violated(steps.lazy, states, margin=0.0, tolerance=1e-9) == []
    bad = violated(deferral.lazy, states, margin=0.0, tolerance=1e-9)
    assert [deferral.lazy[n].k for n in bad] == [1, 2]


def test_a_known_ceiling_closes_the_loop() -> None:
    watch = Watch(pm=None, columns={}, gap=1e-4, ceiling=2.0)  # type: ignore[arg-type]
    watch.best = Plan(1.9999, {}, frozenset())
    assert watch.closed(5.0)  # HiGHS's own bound is loose; the ceiling is within the gap
    assert watch.closed(None)  # the ceiling alone bounds the problem
    watch.ceiling = None
    assert not watch.closed(5.0)
    assert lowest(None, None) is None and lowest(3.0, None) == 3.0 and lowest(3.0, 2.0) == 2.0


def test_a_completion_out_of_time_adds_no_requirement_and_has_no_plan() -> None:
    from stlplan.planner.backend.session import HighsSession
    from stlplan.planner.config import PlannerConfig
    from stlplan.planner.core import completion
    from stlplan.planner.run.budget import Budget
    from stlplan.planner.run.clock import Clock

    pm = build_model(swap_problem(0.5, horizon=3, inter_sample=True), PlannerConfig())
    session = HighsSession(pm.model, PlannerConfig(), Clock(0.0, None), "step1")
    rows = session.highs.getNumRow()
    pending = len(pm.pending())
    assert pending > 0
    assert not completion.added_in_time(pm, session, Budget.of_seconds(-1.0))
    assert len(pm.pending()) == pending
    assert completion.added_in_time(pm, session, Budget.of_seconds(60.0))
    assert pm.pending() == []
    assert session.highs.getNumRow() > rows  # loaded into HiGHS as they were added


def test_a_completion_fixes_decisions_by_bounds_and_restores_them() -> None:
    # a fixed Pyomo variable would make the persistent interface remove and add again every
    # row it is in; bounds change one column each
    from pyomo.environ import Var

    from stlplan.planner.backend.session import HighsSession, has_solution
    from stlplan.planner.backend.values import model_values
    from stlplan.planner.config import PlannerConfig
    from stlplan.planner.core import completion
    from stlplan.planner.run.budget import Budget
    from stlplan.planner.run.clock import Clock

    pm = build_model(swap_problem(0.5, horizon=3, inter_sample=True), PlannerConfig())
    session = HighsSession(pm.model, PlannerConfig(), Clock(0.0, None), "step1")
    assert has_solution(session.solve(Budget.of_seconds(30.0)).results)
    binaries = [v for v in pm.model.component_data_objects(Var) if v.is_binary() and not v.fixed]
    bounds = [v.bounds for v in binaries]
    assert completion.added_in_time(pm, session, Budget.of_seconds(60.0))  # rows with binaries
    rows, removed = session.highs.getNumRow(), []
    remove = session.solver.remove_constraints
    session.solver.remove_constraints = lambda found: (removed.extend(found), remove(found))[1]
    for _ in range(2):  # (the second time, the decisions changed nothing)
        solved = completion.fix_and_solve(
            pm, session, model_values(pm.model), Budget.of_seconds(30)
        )
        assert solved is not None and has_solution(solved.results)
    assert removed == [] and session.highs.getNumRow() == rows  # no row taken out, added again
    assert not any(v.fixed for v in binaries)
    assert [v.bounds for v in binaries] == bounds


def _two_agents(b_at: float, inter_sample: bool) -> Problem:
    """a reaches a goal at step 3 while b waits at ``b_at`` on the x axis (a starts at -4)."""
    return mission(
        horizon=3, safety={"inter_sample": inter_sample}, separation=0.5,
        agents=[{"name": "a", "dynamics": "si", "initial_state": [-4, 0]},
                {"name": "b", "dynamics": "si", "initial_state": [b_at, 0]}],
        regions={"G": {"box": [[-4.1, -3.9], [0.9, 1.1]]}},
        tasks={"g": {"formula": "F[3,3] in(p, G)", "roles": {"p": {"agent": "a"}}}},
    )  # fmt: skip


@pytest.mark.parametrize("inter_sample, pair_steps", [(False, 4), (True, 3)])
def test_pairs_that_cannot_meet_are_counted_unneeded_not_candidates(
    inter_sample: bool, pair_steps: int
) -> None:
    # |u| <= 1 per step: 8 apart they never meet; 2 apart they may from step 1 on
    _, far = plan(_two_agents(4.0, inter_sample))
    assert (far.requirements_candidates, far.requirements_unneeded) == (0, pair_steps)
    _, near = plan(_two_agents(-2.0, inter_sample))
    assert near.requirements_candidates + near.requirements_unneeded == pair_steps
    assert near.requirements_candidates == 3  # steps (or segments) 1-3 are within reach
    assert near.requirements_added <= near.requirements_candidates


@pytest.mark.parametrize("mission_path", ["farm.yaml", "crowd/crowd-16.yaml"])
def test_many_requirements_evaluated_at_once_agree_with_each_alone(mission_path: str) -> None:
    problem = load_problem(MISSIONS / mission_path)
    problem = dataclasses.replace(problem, robust_to=0.01)  # tightened half-planes too
    lazy = defer(problem, reachable_boxes(problem), 10.0).lazy
    rng = np.random.default_rng(0)
    for _ in range(3):
        states = {
            a.name: rng.uniform(a.state_lo, a.state_hi, (problem.horizon + 1, a.n))
            for a in problem.agents
        }
        alone = np.array([alpha_values(r, states).max() for r in lazy])
        np.testing.assert_allclose(alpha_maxima(lazy, states), alone, atol=1e-12)
        some = list(lazy[::7])
        np.testing.assert_allclose(alpha_maxima(some, states), alone[::7], atol=1e-12)
        sides = [best_side(r, states) for r in lazy]
        assert best_sides(lazy, states).tolist() == sides


def test_the_best_sides_at_once_take_the_first_of_equal_half_planes() -> None:
    problem = load_problem(MISSIONS / "crowd/crowd-16.yaml")
    lazy = defer(problem, reachable_boxes(problem), 10.0).lazy
    # every agent at one point: every separation half-plane has the same alpha, -d_col
    states = {a.name: np.zeros((problem.horizon + 1, a.n)) for a in problem.agents}
    sides = best_sides(lazy, states)
    assert sides.tolist() == [best_side(r, states) for r in lazy]
    pairs = [n for n, r in enumerate(lazy) if r.source == SEPARATION]
    assert pairs and sides[pairs].tolist() == [0] * len(pairs)


def test_a_lent_session_solves_without_the_loops_watch_and_gets_it_back() -> None:
    config = PlannerConfig()
    solver = LazySolver(build_model(swap_problem(0.5, horizon=3), config), config, Clock(0.0, None))
    usual, watch = solver.session.rel_gap, solver.watch
    assert watch is not None and solver.session.listening(watch.on_plan, watch.maybe_stop)
    with pytest.raises(RuntimeError), solver.lent(0.05) as session:
        assert session is solver.session and session.trial
        assert session.rel_gap == max(0.05, usual)
        assert not session.listening(watch.on_plan, watch.maybe_stop)
        session.solve(Budget.of_seconds(10.0))  # a plan, without offering it to the watch
        assert solver.watch.best is None
        raise RuntimeError  # the session comes back however the block ends
    assert solver.session.listening(watch.on_plan, watch.maybe_stop)
    assert not solver.session.trial and solver.session.rel_gap == usual
    assert solver.run(Budget.of_seconds(10.0)).objective is not None
    assert solver.watch.best is not None  # the loop's own solves offer their plans again
