"""stlplan export-rtamt: the exported specifications parse in RTAMT and score stlplan's plans as
stlplan's monitor does."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import rtamt
from typer.testing import CliRunner

from stlplan import api
from stlplan.api import Overrides
from stlplan.cli import app
from stlplan.formula.normal import lower
from stlplan.formula.parser import parse
from stlplan.monitor.robustness import robustness
from stlplan.monitor.verdicts import check
from stlplan.outputs.rtamt import rtamt_text, spec_signals
from stlplan.result import PlanStatus
from tests.helpers.paths import MISSIONS

REACH_AVOID = MISSIONS / "reach-avoid.yaml"

pytestmark = pytest.mark.filterwarnings("ignore:typing.io is deprecated:DeprecationWarning")


def _rtamt_robustness(text: str, variables: tuple[str, ...], states: np.ndarray) -> float:
    """RTAMT's discrete-time offline robustness of ``text`` at time 0."""
    spec = rtamt.StlDiscreteTimeOfflineSpecification()
    for name in variables:
        spec.declare_var(name, "float")
    spec.spec = text
    spec.parse()
    data = spec_signals(states)
    return float(spec.evaluate(dict(data))[0][1])


def test_rtamt_scores_a_plan_as_the_monitor_does() -> None:
    problem, result = api.plan(REACH_AVOID, overrides=Overrides(threads=1))
    assert result.status is PlanStatus.OPTIMAL and result.trajectory is not None
    specs, _ = api.export_rtamt(REACH_AVOID)
    assert [s.name for s in specs] == ["reach_avoid"]
    (spec,) = specs
    sampled = check(problem.with_inter_sample(False), result.trajectory)
    mine = sampled.verdict("reach_avoid").robustness
    theirs = _rtamt_robustness(spec.text, spec.variables, result.trajectory.states["robot"])
    assert theirs == pytest.approx(mine, abs=1e-9)
    assert theirs >= 0


@pytest.mark.parametrize(
    "formula",
    [
        "p.x[0] >= 1 U[1,3] p.x[1] >= 2",
        "p.x[0] >= 1 U*[0,3] p.x[1] >= 2",
        "G[0,2] (p.x[0] <= 3 | F[1,2] p.x[1] >= 1) & !(p.x[0] >= 4)",
    ],
)
def test_both_untils_and_boolean_operators_agree_with_rtamt(formula: str) -> None:
    lowered = lower(parse(formula), {}, {"p": (0, 1)})
    rng = np.random.default_rng(3)
    for _ in range(20):
        states = rng.uniform(0, 4, size=(7, 2))
        mine = float(robustness(lowered, {"p": states}, 6)[0])
        theirs = _rtamt_robustness(rtamt_text(lowered), ("x0", "x1"), states)
        assert theirs == pytest.approx(mine, abs=1e-9)


def test_export_rtamt_writes_a_file_and_lists_what_it_leaves_out(tmp_path: Path) -> None:
    out = tmp_path / "farm.rtamt"
    found = CliRunner().invoke(
        app, ["export-rtamt", str(MISSIONS / "farm.yaml"), "--out", str(out)]
    )
    assert found.exit_code == 0, found.output
    text = out.read_text(encoding="utf-8")
    assert "# not exported: crop_B (several roles)" in text
    assert "# not exported: crop_C (synchronous)" in text
    assert "always[0:9](" in text and "# constraint avoid_obstacle, role p = " in text


SINGLE_AGENT_SUITE = (
    "bounded-until", "door-key", "dwell", "dwell-sequence", "either-or", "many-targets",
    "narrow-passage", "patrol", "stepping-stones",
)  # fmt: skip


@pytest.mark.slow
@pytest.mark.parametrize("name", SINGLE_AGENT_SUITE)
def test_rtamt_scores_the_single_agent_suite_as_the_monitor_does(name: str) -> None:
    path = MISSIONS / "stl" / f"{name}.yaml"
    problem, result = api.plan(path, overrides=Overrides(threads=1))
    assert result.status is PlanStatus.OPTIMAL and result.trajectory is not None
    specs, text = api.export_rtamt(path)
    # one agent: every task and constraint is exported, once, and none is left out
    requirements = [t.name for t in problem.tasks] + [c.name for c in problem.constraints]
    assert sorted(s.name for s in specs) == sorted(requirements)
    assert "# not exported" not in text
    # RTAMT judges samples: compare with the monitor's sampled robustness of the same plan
    sampled = check(problem.with_inter_sample(False), result.trajectory)
    for spec in specs:
        (agent,) = spec.agents
        mine = sampled.verdict(spec.name).robustness
        theirs = _rtamt_robustness(spec.text, spec.variables, result.trajectory.states[agent])
        assert theirs == pytest.approx(mine, abs=1e-9), spec.name
        assert theirs >= 0, spec.name
