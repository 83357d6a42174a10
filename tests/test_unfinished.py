"""A continuous stage out of time: step 1's plan is kept only when it meets its predicates."""

from __future__ import annotations

import numpy as np
import pytest

from stlplan import api
from stlplan.api import Overrides
from stlplan.formula.tree import Predicate, Term
from stlplan.planner.encoding.continuous import broken_predicates
from stlplan.planner.encoding.model import PlanModel, build_model
from stlplan.result import PlanStatus
from tests.helpers.configs import paper_model
from tests.helpers.missions import mission
from tests.helpers.paths import MISSIONS


def _reach(margin: float) -> PlanModel:
    problem = mission(
        horizon=3,
        agents=[{"name": "a", "dynamics": "si", "initial_state": [0, 0]}],
        regions={"R": {"box": [[2, 3], [-0.5, 0.5]]}},
        tasks={"reach": {"formula": "F[3,3] in(p, R)", "roles": {"p": {"agent": "a"}}}},
        objective={"beta": 1.0, "effort": "l1", "margin": {"minimum": margin}},
    )
    return build_model(problem, paper_model(lazy__enabled=True, model__encoding="standard"))


@pytest.mark.parametrize(
    ("past_edge", "broken"),
    [(0.25, 0), (0.25 - 5e-8, 0), (0.25 - 1e-6, 1), (0.0, 1)],
)
def test_a_predicate_met_short_of_its_margin_by_more_than_the_tolerance_is_broken(
    past_edge: float, broken: int
) -> None:
    # x - 2 >= r at step 3, with r = 0.25: met within HiGHS's 1e-7, or not
    pm = _reach(0.25)
    west_edge = Predicate((Term(1.0, "p", 0),), 2.0)
    states = {"a": np.zeros((4, 2))}
    states["a"][3, 0] = 2.0 + past_edge
    assert broken_predicates(pm, [(west_edge, 3, {"p": "a"})], states) == broken


@pytest.mark.parametrize(("limit", "first_plan"), [(1.0, False), (1.0, False), (1.5, True)])
def test_a_plan_no_stage_had_the_time_to_finish_is_no_plan_when_it_needs_it(
    limit: float, first_plan: bool
) -> None:
    # many-targets: step 1's incumbent often sits on a target's edge with the margin at 0 (its
    # binaries met within 1e-6). At 1 s the continuous stage has no time; with a first plan
    # only at 1.5 s, it finds the decisions admit no plan and the strict retry has no time.
    # The monitor rejected the plan kept, an error; now the run has no plan, and says why
    mission = MISSIONS / "stl" / "many-targets.yaml"
    _, result = api.plan(mission, Overrides(time_limit=limit, first_plan=first_plan))
    assert result.status in (PlanStatus.NO_PLAN, PlanStatus.FEASIBLE, PlanStatus.OPTIMAL)
    if result.status is PlanStatus.NO_PLAN:
        assert result.trajectory is None
        assert "not finished in time" in result.message or "no plan found" in result.message
    else:
        assert result.report is not None and result.report.satisfied
