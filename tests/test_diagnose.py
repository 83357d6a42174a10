"""Infeasible missions are reported with a diagnosis: cheap reasons, then a minimal conflict."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from stlplan import api
from stlplan.analysis.diagnose import cheap_reasons, needs
from stlplan.formula.parser import parse
from stlplan.mission.loader import load_problem
from stlplan.mission.past import replanned
from stlplan.replanning import replan
from stlplan.result import PlanStatus, Trajectory
from tests.helpers.paths import MISSIONS


def _variant(tmp_path: Path, edit) -> Path:
    data = yaml.safe_load((MISSIONS / "sync-pair.yaml").read_text())
    edit(data)
    path = tmp_path / "variant.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_needs_follow_conjunctions_and_deadlines_but_not_disjunctions() -> None:
    formula = parse(
        "F[0,7] G[0,2] in(p, A) & G[2,4] in(q, B) & (in(p, C) | in(p, D)) "
        "& in(p, E) U[1,3] in(q, F)"
    )
    assert sorted(needs(formula)) == [("p", "A", 7), ("p", "E", 0), ("q", "B", 2), ("q", "F", 3)]
    assert list(needs(parse("G[0,9] !in(p, Obs)"))) == []


def test_farm_has_no_cheap_reason() -> None:
    assert cheap_reasons(load_problem(MISSIONS / "farm.yaml")) == ()


def test_a_window_too_early_to_reach_is_reported_before_solving(tmp_path: Path) -> None:
    def early(data: dict) -> None:
        data["tasks"]["meet"]["synchronous"]["within"] = [1, 2]

    _, result = api.plan(_variant(tmp_path, early))
    assert result.status is PlanStatus.INFEASIBLE
    assert result.model_size is None  # no model was built
    assert result.diagnosis is not None and result.diagnosis.conflict == ("meet",)
    assert "reach region 'Goal' by step 2" in result.diagnosis.reasons[0]


def test_a_conflict_between_a_task_and_a_constraint_is_minimal(tmp_path: Path) -> None:
    def fence(data: dict) -> None:
        data["constraints"]["stay_left"] = {"formula": "G[0,8] p.x[0] <= 3.5", "for_each": "p"}

    _, result = api.plan(_variant(tmp_path, fence))
    assert result.status is PlanStatus.INFEASIBLE
    assert result.diagnosis is not None
    assert result.diagnosis.complete
    assert set(result.diagnosis.conflict) == {"meet", "stay_left"}


def test_a_past_that_leaves_no_input_within_the_state_bounds_is_told_before_solving(
    capfd: pytest.CaptureFixture[str],
) -> None:
    # north driven to its bound at full speed outwards by a disturbance: no input keeps it in
    problem = load_problem(MISSIONS / "sync-pair.yaml")
    steps = problem.horizon + 1
    states = {a.name: np.tile(a.initial_state, (steps, 1)) for a in problem.agents}
    states["north"][1] = [6.0, 3.5, 1.5, 0.0]
    inputs = {a.name: np.zeros((problem.horizon, a.m)) for a in problem.agents}
    executed = Trajectory(problem.horizon, states, inputs)
    reasons = cheap_reasons(replanned(problem, executed, 1))
    bounds = [r.text for r in reasons if r.item == "state bounds"]
    assert bounds == [
        "agent 'north' cannot keep its state bounds at step 2 after the executed past (steps "
        "0..1): whatever its inputs, component 0 of its state is at least 7, above its bound 6"
    ]
    _, result = replan(problem, executed, 1)
    assert result.status is PlanStatus.INFEASIBLE and result.diagnosis is not None
    assert bounds[0] in result.diagnosis.reasons
    assert "state bounds" in result.diagnosis.named()
    printed = capfd.readouterr()
    assert "inconsistent bounds" not in printed.out + printed.err  # nothing reached the solver
