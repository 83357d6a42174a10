"""Tasks by selection and by groups decide the same optimum (DESIGN 2.12).

The selection encoding (:mod:`stlplan.planner.encoding.selection`) enumerates no group; these tests
solve the same missions with both encodings, proven to the true optimum, and compare.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from stlplan import api
from stlplan.mission.problem import Problem, build_problem
from stlplan.mission.schema import Mission
from stlplan.planner.overrides import Overrides
from stlplan.result import PlanResult, PlanStatus
from tests.helpers.dynamics import single_integrator
from tests.helpers.paths import MISSIONS

EXACT = {"threads": 1, "gap": 1e-6, "two_step": False}


def both(problem: Problem | Path, **extra: Any) -> tuple[PlanResult, PlanResult]:
    """The plans of the group and the selection encoding."""
    out = []
    for tasks in ("groups", "selection"):
        _, result = api.plan(problem, overrides=Overrides(tasks=tasks, **(EXACT | extra)))
        out.append(result)
    return out[0], out[1]


def assert_same_optimum(groups: PlanResult, selection: PlanResult) -> None:
    assert groups.status == selection.status, (groups.message, selection.message)
    if groups.status is PlanStatus.INFEASIBLE:
        return
    assert groups.status is PlanStatus.OPTIMAL
    assert selection.objective == pytest.approx(groups.objective, abs=1e-5)  # both within 1e-6
    for result in (groups, selection):
        assert result.report is not None and result.report.satisfied, result.message


def team_mission(
    speeds: list[float], caps: list[str], goal: list[float], task: dict[str, Any]
) -> Problem:
    """Single integrators on a line of start points, one task; effort and margin traded off."""
    agents = [
        {
            "name": f"r{i}",
            "dynamics": f"si{i}",
            "capabilities": [cap],
            "initial_state": [0.0, 0.6 * i],
        }
        for i, cap in enumerate(caps)
    ]
    dynamics = {f"si{i}": single_integrator(v, ((-1, 6), (-1, 4))) for i, v in enumerate(speeds)}
    return build_problem(
        Mission.model_validate(
            {
                "name": "team",
                "horizon": 6,
                "dynamics": dynamics,
                "agents": agents,
                "regions": {"Goal": {"box": [goal[:2], goal[2:]]}},
                "tasks": {"visit": task},
                "separation": 0.1,
                "objective": {"beta": 0.05, "gamma": 3, "effort": "l1"},
            }
        )
    )


TASKS = st.one_of(
    st.builds(
        lambda c: {"formula": "F[0,6] in(p, Goal)", "count": c, "roles": {"p": "A"}},
        st.integers(1, 3),
    ),
    st.builds(
        lambda c: {
            "formula": "F[0,5] (in(p, Goal) & dist(p, q) <= 0.8)",
            "count": c,
            "roles": {"p": "A", "q": "B"},
        },
        st.integers(1, 2),
    ),
    st.builds(
        lambda c, a, d: {
            "formula": "in(p, Goal)",
            "count": c,
            "roles": {"p": "A"},
            "synchronous": {"within": [a, a + 1], "hold": d},
        },
        st.integers(1, 3),
        st.integers(1, 3),
        st.integers(0, 1),
    ),
)


@pytest.mark.heavy
@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    speeds=st.lists(st.sampled_from([0.5, 1.0, 1.5]), min_size=5, max_size=5),
    caps=st.lists(st.sampled_from(["A", "B"]), min_size=5, max_size=5),
    goal_x=st.sampled_from([1.5, 2.5, 4.0]),
    task=TASKS,
)
def test_random_teams_get_the_same_optimum_from_both_encodings(
    speeds: list[float], caps: list[str], goal_x: float, task: dict[str, Any]
) -> None:
    caps = ["A", "B", *caps[2:]]  # both capabilities present
    try:
        problem = team_mission(speeds, caps, [goal_x, goal_x + 1.0, 0.0, 2.5], task)
    except Exception as exc:  # a Pattern without a group: refused alike by both encodings
        assert "count" in str(exc)
        return
    assert_same_optimum(*both(problem))


@pytest.mark.heavy
@settings(max_examples=5, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    speeds=st.lists(st.sampled_from([0.5, 1.0, 1.5]), min_size=5, max_size=5),
    caps=st.lists(st.sampled_from(["A", "B"]), min_size=3, max_size=3),
    count=st.integers(1, 2),
)
def test_subformulas_shared_by_elements_keep_the_optimum(
    speeds: list[float], caps: list[str], count: int
) -> None:
    # in(p, Goal) reads p only: the elements with the same p share it unless told apart
    task = {
        "formula": "F[0,5] (in(p, Goal) & dist(p, q) <= 0.8)",
        "count": count,
        "roles": {"p": "A", "q": "B"},
    }
    try:
        problem = team_mission(speeds, ["A", "B", *caps], [2.5, 3.5, 0.0, 2.5], task)
    except Exception as exc:  # no group of `count` disjoint elements
        assert "count" in str(exc)
        return
    shared, apart = (
        api.plan(problem, overrides=Overrides(config={"model.shared_subformulas": on}, **EXACT))[1]
        for on in (True, False)
    )
    assert_same_optimum(shared, apart)


@pytest.mark.parametrize("name", ["sync-pair", "reach-avoid"])
def test_shipped_small_missions_agree(name: str) -> None:
    assert_same_optimum(*both(MISSIONS / f"{name}.yaml"))


def test_selection_names_the_group_that_serves_each_task() -> None:
    problem = team_mission(
        [1.0] * 5,
        ["A", "B", "A", "B", "A"],
        [1.5, 2.5, 0.0, 2.5],
        {"formula": "F[0,6] in(p, Goal)", "count": 3, "roles": {"p": "A"}},
    )
    _, result = api.plan(problem, overrides=Overrides(tasks="selection", **EXACT))
    (assignment,) = result.assignments
    assert sorted(assignment.group) == [("r0",), ("r2",), ("r4",)]
    assert result.report is not None
    (verdict,) = [v for v in result.report.verdicts if v.name == "visit"]
    assert verdict.satisfied and len(verdict.group) == 3


@pytest.mark.slow
@pytest.mark.timeout(2700)  # two solves of up to 1200 s each
@pytest.mark.parametrize("case", ["farm", "farm-case2", "farm-case3"])
def test_paper_cases_agree(case: str) -> None:
    assert_same_optimum(*both(MISSIONS / f"{case}.yaml", gap=1e-6, time_limit=1200))
