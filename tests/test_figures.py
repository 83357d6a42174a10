"""One value per quantity: reported figures are the written plan's (stlplan.verify)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from stlplan import api
from stlplan.api import Overrides
from stlplan.cli import app
from stlplan.errors import SolverError
from stlplan.verify import plan_objective, reported
from tests.helpers.paths import DATA, MISSIONS


def test_stepping_stones_summary_reports_the_monitors_margin(tmp_path: Path) -> None:
    out = tmp_path / "plan"
    args = [
        "solve",
        str(DATA / "stepping-stones.yaml"),
        "--encoding",
        "standard",
        "--out",
        str(out),
        "--no-animation",
    ]
    result = CliRunner().invoke(app, [*args, "--threads", "1"])
    assert result.exit_code == 0, result.output
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "optimal"
    monitor = summary["monitor"]["spatial_robustness"]
    assert summary["margin"] == monitor  # the same number, not a solver value near it
    assert summary["margin"] > 0.1
    assert summary["solver"]["margin"] == pytest.approx(monitor, abs=1e-6)
    # objective of the written plan: margin - beta * L1 effort of the inputs written
    problem, report = api.check(DATA / "stepping-stones.yaml", out / "trajectory.csv")
    assert report.spatial_robustness == pytest.approx(monitor, abs=1e-9)
    assert summary["objective"] == pytest.approx(monitor - 0.001 * summary["effort"]["value"])
    assert f"margin     {monitor:.10g} (monitor)" in result.output


def _fail_the_continuous_stage(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every continuous stage ends out of time: step 1's plan is kept as a fallback."""
    import stlplan.planner.solve
    from stlplan.planner.core.finish import Finish

    def failing(pm, config, clock, budget):  # type: ignore[no-untyped-def]
        return Finish("the continuous solve ended maxTimeLimit")

    monkeypatch.setattr(stlplan.planner.solve, "finish", failing)


def test_a_failed_continuous_solve_says_why_and_what_it_costs(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    _fail_the_continuous_stage(monkeypatch)
    _, result = api.plan(MISSIONS / "reach-avoid.yaml", overrides=Overrides(threads=1))
    assert result.status.has_plan and result.report is not None
    assert result.fallback is not None
    assert "maxTimeLimit" in result.fallback.reason and "maxTimeLimit" in result.message
    solver = result.solver
    assert solver is not None and solver.margin is not None and solver.objective is not None
    assert result.margin == result.report.spatial_robustness
    assert result.fallback.cost["margin"] == pytest.approx(solver.margin - result.margin)
    assert result.fallback.cost["objective"] == pytest.approx(solver.objective - result.objective)
    assert result.trajectory is not None
    assert result.objective == pytest.approx(
        plan_objective(
            api.validate(MISSIONS / "reach-avoid.yaml"), result.trajectory, result.report
        )
    )


def test_a_fallbacks_shortfall_is_its_cost_and_any_other_an_error(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # step 1's plan kept: its margin claimed within HiGHS's integrality slack (big-M * 1e-6)
    # of the plan's is the fallback's cost; the same claim of a plan not kept as a fallback is
    # an error
    _fail_the_continuous_stage(monkeypatch)
    problem, result = api.plan(MISSIONS / "reach-avoid.yaml", overrides=Overrides(threads=1))
    assert result.fallback is not None and result.solver is not None
    assert result.report is not None and result.margin is not None
    claimed = dataclasses.replace(
        result, margin=result.margin + 1e-2, objective=result.solver.objective
    )
    kept = reported(problem, claimed, result.report, 1e-4)
    assert kept.margin == result.margin and kept.fallback is not None
    assert kept.fallback.cost["margin"] == pytest.approx(1e-2)
    with pytest.raises(SolverError, match="spatial margin disagrees"):
        reported(problem, dataclasses.replace(claimed, fallback=None), result.report, 1e-4)
