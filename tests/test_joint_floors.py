"""Floors of one agent serving two tasks and of an element of several agents: valid (the same
optimum) and tighter (a better LP bound)."""

from __future__ import annotations

from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pyomo.environ import Reals, Var

from stlplan.planner.backend.session import HighsSession
from stlplan.planner.config import PlannerConfig
from stlplan.planner.encoding import floors, team_floors
from stlplan.planner.encoding.model import build_model
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.clock import Clock
from stlplan.planner.solve import plan
from stlplan.result import PlanStatus
from tests.helpers.configs import paper_model
from tests.helpers.examples import examples
from tests.helpers.missions import mission
from tests.helpers.solving import up_front_optimum


def tasks_apart(starts: list[float], corners: list[list[float]], late: int) -> Any:
    """Agents of one capability on the x axis; one task per unit box (lower-left corners
    ``corners``); with more tasks than agents some agent serves two."""
    agents = [
        {"name": f"r{i}", "dynamics": "si", "capabilities": ["X"], "initial_state": [x, 0]}
        for i, x in enumerate(starts)
    ]
    regions = {f"R{i}": {"box": [[x, x + 1], [y, y + 1]]} for i, (x, y) in enumerate(corners)}
    formulas = ["F[1,4] G[0,1] in(p, R0)", f"F[{late},8] in(p, R1)", "F[2,8] in(p, R2)"]
    tasks = {f"t{i}": {"formula": formulas[i], "roles": {"p": "X"}} for i in range(len(corners))}
    return mission(
        horizon=8,
        agents=agents,
        regions=regions,
        tasks=tasks,
        objective={"beta": 1.0, "effort": "l1"},
    )


def assert_floors_keep_the_optimum(problem: Any) -> None:
    """Proven to 1e-7, with and without every floor: the same status and optimum."""
    exact = PlannerConfig().with_overrides(
        {"solver.time_limit": 60.0, "solver.gap": 1e-7, "lazy.enabled": False,
         "continuous.two_step": False}
    )  # fmt: skip
    floored = plan(problem, exact.with_overrides({"model.floors": True}))
    plain = plan(problem, exact.with_overrides({"model.floors": False}))
    assert floored.status == plain.status
    if plain.status is PlanStatus.OPTIMAL:
        assert floored.objective == pytest.approx(plain.objective, abs=1e-5)


def lp_bound(problem: Any) -> float:
    """The LP relaxation's optimum of problem (step1)."""
    pm = build_model(
        problem,
        paper_model(model__floors=True, model__tasks="selection", model__encoding="standard"),
    )
    for v in pm.model.component_data_objects(Var):
        if v.is_binary():
            v.domain = Reals
            v.setlb(0)
            v.setub(1)
    solved = HighsSession(pm.model, PlannerConfig(), Clock(0.0, None), "step1", mip=False).solve(
        Budget.of_seconds(60)
    )
    objective = solved.results.incumbent_objective
    assert objective is not None
    return float(objective)


def test_one_agent_serving_two_far_tasks_tightens_the_relaxation(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # two agents at the origin, three tasks far apart: one agent serves two of them
    problem = tasks_apart([0.0, 0.5], [[-3.0, 1.0], [2.0, 1.0], [-0.5, -3.0]], late=5)
    with_cuts = lp_bound(problem)
    monkeypatch.setattr(floors, "service_floors", lambda *args: (0, set()))
    without = lp_bound(problem)
    assert with_cuts < without - 1.0  # a maximization: the bound is lower by the way between
    exact = up_front_optimum(problem)
    assert exact.objective is not None and exact.objective <= with_cuts + 1e-6


# two MILPs proven to 1e-7 per example: 6 by default, more with STLPLAN_HYPOTHESIS=explore
@pytest.mark.heavy
@settings(
    max_examples=examples(6, explore=60),
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
@given(
    starts=st.lists(st.sampled_from([-2.0, 0.0, 1.0, 3.0]), min_size=1, max_size=2, unique=True),
    corners=st.lists(
        st.tuples(st.integers(-4, 3), st.integers(-4, 3)).map(list), min_size=2, max_size=3
    ),
    late=st.integers(2, 8),
)
def test_service_floors_keep_the_optimum(
    starts: list[float], corners: list[list[int]], late: int
) -> None:
    problem = tasks_apart(starts, [[float(c) for c in xy] for xy in corners], late)
    assert_floors_keep_the_optimum(problem)


def formations(starts: list[tuple[float, float]], goal: float) -> Any:
    """Two P and two Q agents at ``starts``; one P+Q formation must meet within 0.5 and then
    be in the band ``goal <= y <= goal + 1`` together."""
    agents = [
        {"name": n, "dynamics": "si", "capabilities": [n[0].upper()], "initial_state": list(xy)}
        for n, xy in zip(["p1", "p2", "q1", "q2"], starts, strict=True)
    ]
    return mission(
        horizon=6,
        agents=agents,
        regions={"Goal": {"box": [[-4, 4], [goal, goal + 1]]}},
        tasks={
            "pair": {
                "formula": "G[3,4] dist(p, q) <= 0.5 & F[5,6] (in(p, Goal) & in(q, Goal))",
                "roles": {"p": "P", "q": "Q"},
            }
        },
        objective={"beta": 1.0, "effort": "l1"},
    )


def test_a_formation_of_agents_far_apart_tightens_the_relaxation(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # the band is near every agent, but each P is far from each Q: whichever pair forms, both
    # must cross the gap between them to meet, which no agent's own floor sees
    problem = formations([(-2.5, 2.0), (-2.5, -2.0), (2.5, 2.0), (2.5, -2.0)], goal=-0.5)
    with_cuts = lp_bound(problem)
    monkeypatch.setattr(team_floors, "add_team_floors", lambda *args: 0)
    monkeypatch.setattr(floors, "add_team_floors", lambda *args: 0)
    without = lp_bound(problem)
    assert with_cuts < without - 0.5  # (-3.87 against -3.00)
    exact = up_front_optimum(problem)
    assert exact.objective is not None and exact.objective <= with_cuts + 1e-6


def grid_points(n: int) -> st.SearchStrategy[list[tuple[float, float]]]:
    """``n`` points with integer coordinates in ``[-4, 4]^2``."""
    point = st.tuples(st.integers(-4, 4), st.integers(-4, 4))
    return st.lists(point.map(lambda t: (float(t[0]), float(t[1]))), min_size=n, max_size=n)


@pytest.mark.heavy
@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    starts=grid_points(4),
    goal=st.integers(-3, 2),
)
def test_team_floors_keep_the_optimum(starts: list[tuple[float, float]], goal: int) -> None:
    problem = formations(starts, float(goal))
    assert_floors_keep_the_optimum(problem)


def formations_to_choose(starts: list[tuple[float, float]], goal: float, count: int) -> Any:
    """Three P and three Q agents at ``starts``; ``count`` P+Q formations must meet within 0.5
    and then be in the band ``goal <= y <= goal + 1`` together; one P agent must visit the box
    ``Far`` at step 5 or 6 (a formation in a low band cannot be there too)."""
    names = ["p1", "p2", "p3", "q1", "q2", "q3"]
    agents = [
        {"name": n, "dynamics": "si", "capabilities": [n[0].upper()], "initial_state": list(xy)}
        for n, xy in zip(names, starts, strict=True)
    ]
    return mission(
        horizon=6,
        agents=agents,
        regions={
            "Goal": {"box": [[-4, 4], [goal, goal + 1]]},
            "Far": {"box": [[-4, -3.5], [4, 5]]},
        },
        tasks={
            "pair": {
                "formula": "G[3,4] dist(p, q) <= 0.5 & F[5,6] (in(p, Goal) & in(q, Goal))",
                "count": count,
                "roles": {"p": "P", "q": "Q"},
            },
            "far": {"formula": "F[5,6] in(p, Far)", "roles": {"p": "P"}},
        },
        objective={"beta": 1.0, "effort": "l1"},
    )


def test_shares_bound_a_fractional_choice_of_formations(monkeypatch: pytest.MonkeyPatch) -> None:
    # every P is far from every Q: whichever two formations are chosen, four agents cross the
    # gap; split across the nine elements, the element rows alone let each agent pay a ninth
    problem = formations_to_choose(
        [(-3.0, 3.0), (-3.0, 0.0), (-3.0, -3.0), (3.0, 3.0), (3.0, 0.0), (3.0, -3.0)], 0.0, 2
    )
    with_shares = lp_bound(problem)
    monkeypatch.setattr(team_floors, "shared_tasks", lambda ledger: {})
    without = lp_bound(problem)
    assert with_shares < without - 1.0
    exact = up_front_optimum(problem)
    assert exact.objective is not None and exact.objective <= with_shares + 1e-6


# two MILPs proven to 1e-7 per example: 4 by default, more with STLPLAN_HYPOTHESIS=explore
@pytest.mark.heavy
@settings(
    max_examples=examples(4, explore=40),
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
@given(
    starts=grid_points(6),
    goal=st.integers(-3, 2),
    count=st.integers(1, 2),
)
def test_shares_keep_the_optimum(starts: list[tuple[float, float]], goal: int, count: int) -> None:
    assert_floors_keep_the_optimum(formations_to_choose(starts, float(goal), count))
