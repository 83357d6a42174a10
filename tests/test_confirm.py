"""Confirmation of HiGHS's infeasible verdicts (stlplan.planner.backend.confirm)."""

from __future__ import annotations

import json
from pathlib import Path

import highspy
import numpy as np
import pytest

from stlplan import api
from stlplan.api import Overrides
from stlplan.planner.backend.confirm import attempts, has_plan, option, verdict
from stlplan.result import PlanStatus
from tests.helpers.confirming import solve_confirmed
from tests.helpers.paths import DATA, MISSIONS

# both plans proven to the true optimum, so that they can be compared to 1e-6
EXACT = Overrides(threads=1, gap=1e-9)


def _highs(path: Path) -> highspy.Highs:
    # earlier solves in this process may have sized HiGHS's thread pool for more threads
    highspy.Highs.resetGlobalScheduler(True)
    highs = highspy.Highs()
    highs.setOptionValue("output_flag", False)
    highs.setOptionValue("threads", 1)
    highs.setOptionValue("presolve", "on")
    highs.readModel(str(path))
    return highs


def test_false_infeasible_regression_ends_feasible_with_the_optimum() -> None:
    highs = _highs(DATA / "highs-false-infeasible.mps")
    confirmation = solve_confirmed(highs, seed=0, time_limit=120)
    assert verdict(highs) == "Optimal" and has_plan(highs)
    sense = 1.0 if highs.getLp().sense_ == highspy.ObjSense.kMaximize else -1.0
    margin = sense * highs.getInfo().objective_function_value
    assert margin == pytest.approx(0.4, abs=1e-6)
    if confirmation is not None:  # this HiGHS said infeasible at first: the checks overturned it
        assert confirmation.outcome == "overturned"
        assert confirmation.checks[0].verdict == "Infeasible"
        assert confirmation.checks[-1].verdict == "Optimal"
    # the usual options are back after the checks
    assert option(highs, "presolve") == "on"
    assert option(highs, "random_seed") == 0


def test_a_truly_infeasible_model_is_confirmed_by_every_check() -> None:
    highs = highspy.Highs()
    highs.setOptionValue("output_flag", False)
    x = highs.addIntegral(lb=0, ub=10)
    y = highs.addIntegral(lb=0, ub=10)
    highs.addConstr(2 * x + 2 * y == 7)  # no integers make an odd number even
    confirmation = solve_confirmed(highs, seed=3)
    assert confirmation is not None and confirmation.outcome == "confirmed"
    assert [c.verdict for c in confirmation.checks] == ["Infeasible"] * (1 + len(attempts(3)))
    assert [dict(c.settings)["random_seed"] for c in confirmation.checks] == [3, 4, 5]
    assert [dict(c.settings)["presolve"] for c in confirmation.checks[1:]] == ["off", "on"]
    assert np.isfinite(sum(c.seconds for c in confirmation.checks))


INFEASIBLE = """
name: both-at-once
horizon: 8
dynamics:
  di:
    A: [[1, 0, 1, 0], [0, 1, 0, 1], [0, 0, 1, 0], [0, 0, 0, 1]]
    B: [[0.5, 0], [0, 0.5], [1, 0], [0, 1]]
    position: [0, 1]
    state_bounds: [[0, 10], [0, 10], [-2, 2], [-2, 2]]
    input_bounds: [[-1, 1], [-1, 1]]
agents:
  - {name: robot, dynamics: di, capabilities: [ground], initial_state: [5, 5, 0, 0]}
regions:
  A: {box: [[6, 8], [6, 8]]}
  B: {box: [[2, 4], [2, 4]]}
constraints:
  both:
    formula: F[0,8] (in(p, A) & in(p, B))
    roles: {p: robot}
objective: {beta: 0.01, effort: l1, two_step: false}
solver: {time_limit: 60, threads: 1}
"""


def test_a_truly_infeasible_mission_exits_4_with_its_confirmation_recorded(
    tmp_path: Path,
) -> None:
    from typer.testing import CliRunner

    from stlplan.cli import app

    mission = tmp_path / "both.yaml"
    mission.write_text(INFEASIBLE, encoding="utf-8")
    out = tmp_path / "out"
    result = CliRunner().invoke(app, ["solve", str(mission), "--out", str(out), "-q"])
    assert result.exit_code == 4, result.output
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "infeasible"
    checks = summary["infeasibility_checks"]
    main = [c for c in checks if not c["where"].startswith("diagnosis")]
    assert main and all(c["outcome"] == "confirmed" for c in main)
    solves = main[0]["solves"]
    assert [s["verdict"] for s in solves] == ["Infeasible"] * 3
    assert [s["settings"]["presolve"] for s in solves[1:]] == ["off", "on"]
    assert summary["diagnosis"]["conflict"] == ["both"]


def test_a_false_verdict_in_a_lazy_round_is_overturned_and_the_loop_goes_on(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The first step-1 solve is made infeasible by a row HiGHS alone sees, removed after it."""
    import highspy as hs

    from stlplan.planner.backend.session import HighsSession

    usual = HighsSession.solve_once
    spoiled = []

    def spoil_first(self, seconds, settings=None):  # type: ignore[no-untyped-def]
        if spoiled or self.phase != "step1":
            return usual(self, seconds, settings)
        spoiled.append(True)
        highs = self.highs
        column = next(iter(self.columns().values()))
        upper = highs.getLp().col_upper_[column]
        highs.addRow(upper + 1.0, hs.kHighsInf, 1, [column], [1.0])
        try:
            return usual(self, seconds, settings)
        finally:
            highs.deleteRows(1, [highs.getNumRow() - 1])

    _, reference = api.plan(MISSIONS / "reach-avoid.yaml", overrides=EXACT)
    assert reference.confirmations == ()
    monkeypatch.setattr(HighsSession, "solve_once", spoil_first)
    _, result = api.plan(MISSIONS / "reach-avoid.yaml", overrides=EXACT)
    assert spoiled and result.status.value == "optimal"
    assert result.report is not None and result.report.satisfied
    first = result.confirmations[0]
    assert first.where == "step1 round 1" and first.outcome == "overturned"
    assert first.checks[0].verdict == "Infeasible" and first.checks[1].verdict != "Infeasible"
    assert any("overturned" in event for event in result.events)
    assert result.objective == pytest.approx(reference.objective, abs=1e-6)


@pytest.mark.heavy
def test_a_solve_error_on_a_nearly_infeasible_model_is_solved_again_strictly(
    tmp_path: Path,
) -> None:
    # many-targets' robot has visited T1 and T2 by step 9; T4 closed from then on leaves its
    # visit impossible. HiGHS's fourth lazy round "optimum" broke its own rows by 2e-6 (a
    # binary 1.3e-7 from 1): "Solve error", and the run ended in an error. Solved again with
    # the integrality tolerance at round-off, HiGHS says infeasible, and the checks confirm it
    past = [(5, 5), (4, 4.5), (3.5, 3.5), (2.5, 3.5), (2.5, 2.5), (3.5, 2.5), (4.5, 2.5),
            (5.5, 2.5), (6.5, 2.5), (7.5, 2.5)]  # fmt: skip
    executed = tmp_path / "executed.csv"
    rows = [f"robot,{k},{x},{y}" for k, (x, y) in enumerate(past)]
    executed.write_text("\n".join(["agent,k,x0,x1", *rows]) + "\n", encoding="utf-8")
    mission = MISSIONS / "stl" / "many-targets.yaml"
    _, result = api.replan(mission, executed, 9, closed=["T4"], overrides=Overrides(time_limit=20))
    assert result.status is PlanStatus.INFEASIBLE, result.message
    assert result.confirmations and all(c.outcome == "confirmed" for c in result.confirmations)
