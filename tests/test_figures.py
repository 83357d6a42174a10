"""One value per quantity: reported figures are the written plan's (stlplan.verify)."""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path

import pytest
import yaml
from rich.console import Console
from typer.testing import CliRunner

from stlplan import api
from stlplan.api import Overrides
from stlplan.cli import app
from stlplan.errors import SolverError
from stlplan.outputs.render import print_plan
from stlplan.result import Fallback, PlanResult, PlanStatus, SolverFigures
from stlplan.verify import plan_objective, reported
from tests.helpers.paths import DATA, MISSIONS


@pytest.mark.heavy
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
    assert f"margin     {monitor:.4g} (monitor)" in result.output
    assert _longest_figure(result.output) <= 6


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
    assert (
        "failed (the continuous solve ended maxTimeLimit): the plan written is the step-1 plan"
        in (result.message)
    )
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


def _longest_figure(text: str) -> int:
    """The most significant digits of a number printed in ``text`` (a run's terminal output)."""
    digits = [
        len(mantissa.replace(".", "").lstrip("0"))
        for mantissa in re.findall(r"(?<![\w.])(\d+\.\d+|\d+)(?:e[-+]?\d+)?(?![\w.])", text)
    ]
    return max(digits, default=0)


def test_the_status_block_tells_one_story_in_figures_as_they_mean() -> None:
    # step 2 lowered the written plan's step-1 objective; its margin is the boundary's epsilon;
    # the fallback's cost is round-off
    result = PlanResult(
        PlanStatus.OPTIMAL,
        "optimal plan; step 2 minimized the l2 effort",
        objective=2.999230832,
        bound=3.16267,
        gap=0.0,
        effort=5.419047619,
        margin=9.999999424e-07,
        steps=2,
        solver=SolverFigures(3.162666248, 1e-06),
        fallback=Fallback("step 2", "maxTimeLimit", "the step-1 plan", {"margin": -1.67e-16}),
        stage_seconds={"step 1": 12.31, "continuous": 0.5, "verify": 0.01},
    )
    console = Console(record=True, width=200)
    print_plan(console, result, seconds=14.2)
    lines = console.export_text().splitlines()
    assert "step 1     objective 3.163, bound 3.163, gap 0.00%" in lines
    assert "step 2     effort 5.419; the plan written scores 2.999 on step 1's objective" in lines
    assert "margin     1e-06 (the boundary epsilon; monitor)" in lines
    assert any(line.endswith("costing margin 0") for line in lines)
    assert (
        "time       14.20 s in all: step 1 12.31 s, continuous 0.50 s, verify 0.01 s; "
        "reading and writing 1.38 s" in lines
    )
    assert _longest_figure("\n".join(lines)) <= 6


def test_the_task_line_and_the_monitor_name_one_synchronized_run(tmp_path: Path) -> None:
    # agents starting in the goal, their run counted up to gamma = 1: the solver needs only a
    # short run, the plan keeps a longer one, and both lines name the monitor's
    data = yaml.safe_load((MISSIONS / "sync-pair.yaml").read_text(encoding="utf-8"))
    for agent, start in zip(data["agents"], ([4.5, 1.5, 0, 0], [5.0, 2.5, 0, 0]), strict=True):
        agent["initial_state"] = start
    data["tasks"]["meet"]["synchronous"].update(within=[0, 5], gamma=1)
    mission = tmp_path / "in-goal.yaml"
    mission.write_text(yaml.safe_dump(data), encoding="utf-8")
    _, result = api.plan(mission, overrides=Overrides(threads=1))
    assert result.report is not None and result.report.satisfied
    (meet,) = result.assignments
    verdict = result.report.verdict("meet")
    assert (meet.run_start, meet.run_length) == (verdict.run_start, verdict.run_length) == (0, 9)
    assert meet.rho_s == verdict.rho_s == result.rho_s["meet"]
    assert result.solver is not None and result.solver.rho_s["meet"] <= verdict.rho_s
