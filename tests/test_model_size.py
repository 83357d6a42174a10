"""The model size a plan reports is the size of step 1's MILP, binaries included."""

from __future__ import annotations

from stlplan import api
from stlplan.planner.encoding.model import build_model
from stlplan.planner.solve import model_size
from tests.helpers.paths import MISSIONS


def test_a_solved_plan_reports_the_binaries_of_step_one() -> None:
    problem = api.validate(MISSIONS / "sync-pair.yaml")
    _, result = api.plan(problem, api.Overrides(time_limit=60))
    assert result.steps == 2 and result.model_size is not None
    built = model_size(build_model(problem).model)
    # lazy rows only add binaries to the model as built
    assert result.model_size.binaries >= built.binaries > 0
