"""Boundaries: a predicate the planner relies on holds with the margin EPSILON, and the monitor
counts a region's edge as neither inside nor outside (DESIGN 2.10)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from stlplan import api
from stlplan.api import Overrides
from stlplan.formula.boundary import EPSILON, HOLDS_AT, holds, required_margin
from stlplan.mission.problem import Problem, build_problem
from stlplan.mission.schema import Mission
from stlplan.monitor.robustness import robustness
from stlplan.monitor.verdicts import check
from stlplan.result import PlanStatus, Trajectory
from tests.helpers.dynamics import SINGLE_INTEGRATOR_U2
from tests.helpers.paths import MISSIONS

HIGHS_FEASIBILITY = 1e-7
"""HiGHS's primal feasibility tolerance: how far a solved row may miss."""

ONE = Overrides(threads=1)


def corridor(formula: str, effort: str = "l1", two_step: bool = True) -> Problem:
    """One single integrator from (0, 0); Goal = [1, 2] x [-1, 1] has its west edge at x = 1."""
    return build_problem(
        Mission.model_validate(
            {
                "name": "corridor",
                "horizon": 3,
                "dynamics": {"si": SINGLE_INTEGRATOR_U2},
                "agents": [{"name": "a", "dynamics": "si", "initial_state": [0, 0]}],
                "regions": {"Goal": {"box": [[1, 2], [-1, 1]]}},
                "tasks": {"goal": {"formula": formula, "roles": {"p": {"agent": "a"}}}},
                "objective": {"beta": 1.0, "effort": effort, "two_step": two_step},
            }
        )
    )


def still(problem: Problem, x: float) -> Trajectory:
    """Agent ``a`` jumps to ``(x, 0)`` at step 1 and stays."""
    states = np.array([[0.0, 0.0]] + [[x, 0.0]] * problem.horizon)
    inputs = np.diff(states, axis=0)
    return Trajectory(problem.horizon, {"a": states}, {"a": inputs})


def test_the_rule_sits_between_zero_and_what_the_planner_enforces() -> None:
    assert 0 < HOLDS_AT < EPSILON - HIGHS_FEASIBILITY
    assert required_margin(0.0) == EPSILON and required_margin(0.3) == 0.3
    assert not holds(0.0) and holds(EPSILON - HIGHS_FEASIBILITY)
    assert holds(np.array([-1.0, 0.0, EPSILON])).tolist() == [False, False, True]
    assert not holds(float("nan"))


@settings(max_examples=200)
@given(st.floats(allow_nan=False, allow_infinity=False, min_value=-10, max_value=10))
def test_a_predicate_and_its_negation_never_both_hold(value: float) -> None:
    assert not (holds(value) and holds(-value))


def test_on_the_edge_is_neither_inside_nor_outside_and_robustness_is_exact() -> None:
    inside, outside = corridor("G[1,3] in(p, Goal)"), corridor("G[1,3] !in(p, Goal)")
    for x, seen in [(1.0, (False, False)), (1 + 3e-7, (False, False)), (1 + 2e-6, (True, False))]:
        trajectory = still(inside, x)
        verdicts = (
            check(inside, trajectory).verdict("goal"),
            check(outside, trajectory).verdict("goal"),
        )
        assert (verdicts[0].satisfied, verdicts[1].satisfied) == seen
        assert verdicts[0].robustness == x - 1  # reported as computed, never rounded
        assert verdicts[1].robustness == 1 - x
    assert check(outside, still(outside, 1 - 2e-6)).verdict("goal").satisfied


@pytest.mark.parametrize(
    ("effort", "two_step"), [("l1", True), ("l2", True), ("linf", True), ("l1", False)]
)
def test_a_plan_at_the_edge_holds_with_the_margin(effort: str, two_step: bool) -> None:
    # the cheapest plan stops at the west edge of Goal: x(1) = 1 + EPSILON, the effort's minimum
    problem = corridor("F[1,1] in(p, Goal)", effort, two_step)
    _, result = api.plan(problem, overrides=ONE)
    assert result.status is PlanStatus.OPTIMAL and result.fallback is None
    assert result.trajectory is not None and result.report is not None
    x = result.trajectory.states["a"][1, 0]
    assert x - 1 >= EPSILON - HIGHS_FEASIBILITY
    assert x == pytest.approx(1 + EPSILON, abs=HIGHS_FEASIBILITY)
    assert result.report.verdict("goal").robustness == x - 1


def _lowered_predicates(problem: Problem) -> list[tuple[Any, dict[str, str]]]:
    out = []
    for constraint in problem.constraints:
        for binding in constraint.bindings:
            out.append((problem.lowered(constraint.formula, binding), dict(binding)))
    return out


def test_every_enforced_predicate_of_a_solved_plan_holds_exactly() -> None:
    # every verdict holds with the margin, and each constraint's exact robustness is >= 0
    problem, result = api.plan(MISSIONS / "sync-pair.yaml", overrides=ONE)
    assert result.status is PlanStatus.OPTIMAL and result.report is not None
    assert result.trajectory is not None
    for verdict in result.report.verdicts:
        if verdict.kind == "dynamics":
            continue
        assert verdict.satisfied and verdict.robustness >= EPSILON - HIGHS_FEASIBILITY
    for formula, binding in _lowered_predicates(problem):
        signals = {role: result.trajectory.states[name] for role, name in binding.items()}
        assert robustness(formula, signals, problem.horizon)[0] >= 0


def _variant(tmp_path: Path, name: str, edit: Any) -> Path:
    data = yaml.safe_load((MISSIONS / name).read_text())
    edit(data)
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data))
    return path


def test_in_and_not_in_one_region_is_infeasible(tmp_path: Path) -> None:
    def contradiction(data: dict[str, Any]) -> None:
        data["constraints"] = {}
        data["tasks"] = {
            "both": {
                "formula": "F[0,8] (in(p, Goal) & !in(p, Goal))",
                "roles": {"p": {"agent": "robot"}},
            }
        }

    _, result = api.plan(_variant(tmp_path, "reach-avoid.yaml", contradiction), overrides=ONE)
    assert result.status is PlanStatus.INFEASIBLE
    assert result.diagnosis is not None and result.diagnosis.conflict == ("both",)


def _uv_out_of_b(data: dict[str, Any]) -> None:
    data["constraints"]["uv_out_of_B"] = {
        "formula": "G[0,9] !in(p, B)",
        "for_each": "p",
        "agents": ["uv1", "uv2", "uv3"],
    }


def test_keeping_the_uv_agent_out_of_b_contradicts_crop_b(tmp_path: Path) -> None:
    # the farm's crop B with one UV and one IR agent: the UV agent must be in B, not on its edge
    def small(data: dict[str, Any]) -> None:
        data["agents"] = [a for a in data["agents"] if a["name"] in ("uv1", "ir1")]
        data["tasks"] = {"crop_B": {**data["tasks"]["crop_B"], "count": 1}}
        data["constraints"] = {}
        _uv_out_of_b(data)
        data["constraints"]["uv_out_of_B"]["agents"] = ["uv1"]

    _, result = api.plan(_variant(tmp_path, "farm.yaml", small), overrides=ONE)
    assert result.status is PlanStatus.INFEASIBLE
    assert result.diagnosis is not None and result.diagnosis.complete
    assert set(result.diagnosis.conflict) == {"crop_B", "uv_out_of_B"}


@pytest.mark.slow
@pytest.mark.timeout(600)  # the farm's time limit of 300 s, and the diagnosis after it
def test_the_farm_with_uv_agents_out_of_b_is_infeasible(tmp_path: Path) -> None:
    _, result = api.plan(_variant(tmp_path, "farm.yaml", _uv_out_of_b), overrides=ONE)
    assert result.status is PlanStatus.INFEASIBLE
    assert result.diagnosis is not None
    assert set(result.diagnosis.conflict) == {"crop_B", "uv_out_of_B"}
