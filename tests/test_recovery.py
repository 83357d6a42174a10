"""A separation the executed past broke is recovered: the pair comes no closer, on the steps
and on the segments, and is apart again as soon as the dynamics allow."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from stlplan.analysis.recovery import with_recoveries
from stlplan.api import solve
from stlplan.mission.loader import load_problem
from stlplan.mission.past import replanned
from stlplan.mission.problem import Problem, Recovery
from stlplan.monitor.verdicts import check
from stlplan.planner.overrides import Overrides
from stlplan.replanning import replan
from stlplan.result import PlanResult, PlanStatus, Trajectory
from tests.helpers.dynamics import single_integrator
from tests.helpers.missions import mission
from tests.helpers.paths import PAIR

STEP = 4
APART = 0.03


def _closest(trajectory: Trajectory, first: int) -> tuple[float, np.ndarray]:
    """The pair's smallest infinity-norm distance over the segments from ``first`` (sampled
    finely), and its distance at every step."""
    rel = trajectory.states["north"][:, :2] - trajectory.states["south"][:, :2]
    s = np.linspace(0.0, 1.0, 2001)[:, None]
    lows = [
        np.abs(rel[k] * (1 - s) + rel[k + 1] * s).max(axis=1).min()
        for k in range(first, len(rel) - 1)
    ]
    return float(min(lows)), np.abs(rel).max(axis=1)


@pytest.fixture(scope="module")
def pushed() -> tuple[Problem, Trajectory]:
    """sync-pair's plan with north moved to 0.03 above south at step 4."""
    problem = load_problem(PAIR)
    plan = solve(problem).trajectory
    assert plan is not None
    states = {name: x.copy() for name, x in plan.states.items()}
    states["north"][STEP, :2] = states["south"][STEP, :2] + (0.0, APART)
    return problem, dataclasses.replace(plan, states=states)


@pytest.fixture(scope="module")
def recovered(pushed: tuple[Problem, Trajectory]) -> tuple[Problem, PlanResult]:
    problem, executed = pushed
    return replan(problem, executed, STEP, overrides=Overrides(time_limit=60))


def test_the_replan_comes_no_closer_and_is_apart_again_by_the_horizon(
    recovered: tuple[Problem, PlanResult],
) -> None:
    _, result = recovered
    assert result.trajectory is not None
    closest, at_steps = _closest(result.trajectory, STEP)
    assert closest >= APART - 1e-6
    assert at_steps[-1] >= 0.1 and _closest(result.trajectory, 7)[0] >= 0.1


def test_the_broken_separation_is_named_once_with_the_step_it_is_restored(
    recovered: tuple[Problem, PlanResult],
) -> None:
    again, result = recovered
    assert result.status is PlanStatus.DEGRADED
    assert result.broken_by_the_past == ("separation",) and result.dropped == ()
    assert result.report is not None
    rows = [v for v in result.report.verdicts if v.name == "separation"]
    assert len(rows) == 1 and not rows[0].satisfied
    restored = again.past.recovering[("south", "north")].restored if again.past else None
    assert restored == STEP + 1  # the boxes let them be 0.1 + 0.2 apart at once (along x)
    assert f"0.1 apart again from step {restored}" in rows[0].detail
    assert "no closer than 0.03 after it" in rows[0].detail


def test_the_monitor_rejects_a_plan_that_brings_the_pair_closer(
    recovered: tuple[Problem, PlanResult],
) -> None:
    again, result = recovered
    assert result.trajectory is not None
    closer = {name: x.copy() for name, x in result.trajectory.states.items()}
    closer["north"][STEP + 1, :2] = closer["south"][STEP + 1, :2] + (0.0, APART / 2)
    moved = dataclasses.replace(result.trajectory, states=closer, known="states")
    verdict = check(again, moved, planned_only=True).verdict("separation")
    assert not verdict.satisfied
    assert "come closer than their 0.03 at step 4" in verdict.detail
    kept = check(again, dataclasses.replace(result.trajectory), planned_only=True)
    assert kept.verdict("separation").satisfied


def _slow_pair() -> Problem:
    """Two single integrators that move 0.05 a step at most, with a separation of 0.5: a pair
    pushed 0.1 apart cannot be 0.5 apart again within two steps."""
    team = [
        {"name": "a", "dynamics": "slow", "initial_state": [0, 0]},
        {"name": "b", "dynamics": "slow", "initial_state": [1, 0]},
    ]
    return mission(
        horizon=6, dynamics={"slow": single_integrator(0.05)}, agents=team, separation=0.5,
        objective={"beta": 1.0, "effort": "l1"},
    )  # fmt: skip


def test_a_pair_too_close_to_be_apart_again_keeps_its_floor_to_the_horizon() -> None:
    problem = _slow_pair()
    states = {"a": np.zeros((7, 2)), "b": np.tile([1.0, 0.0], (7, 1))}
    states["b"][4] = (0.1, 0.0)  # pushed next to a at step 4
    executed = Trajectory(6, states, {n: np.zeros((6, 2)) for n in states}, known="states")
    again = with_recoveries(replanned(problem, executed, 4))
    assert again.past is not None
    assert again.past.recovering[("a", "b")] == Recovery(closest=0.1, restored=None)
    assert again.separated_from("a", "b") == problem.horizon + 1
    _, result = replan(problem, executed, 4, overrides=Overrides(time_limit=60))
    assert result.status is PlanStatus.DEGRADED and result.trajectory is not None
    rel = result.trajectory.states["b"] - result.trajectory.states["a"]
    assert np.all(np.abs(rel[4:]).max(axis=1) >= 0.1 - 1e-6)
    assert rel[4:, 0].min() >= 0.1 - 1e-6  # on the side it held at step 4: no crossing
    assert result.report is not None
    assert "never apart again" in result.report.verdict("separation").detail


def test_a_pair_its_constraints_keep_close_is_apart_again_as_late_as_they_need() -> None:
    """The boxes let the pair be 0.5 apart at once; their yards never do: the replan moves the
    step it restores the separation at to the horizon and past it, and keeps the floor."""
    team = [
        {"name": "a", "dynamics": "si", "initial_state": [0, 0]},
        {"name": "b", "dynamics": "si", "initial_state": [0.2, 0]},
    ]
    yards = {
        "A": {"box": [[-0.05, 0.05], [-0.05, 0.05]]},
        "B": {"box": [[0.1, 0.3], [-0.05, 0.05]]},
    }
    stay = {
        "a": {"formula": "G[0,4] in(p, A)", "roles": {"p": "a"}},
        "b": {"formula": "G[0,4] in(p, B)", "roles": {"p": "b"}},
    }
    problem = mission(
        horizon=4, agents=team, regions=yards, constraints=stay, separation=0.5,
        objective={"beta": 1.0, "effort": "l1"},
    )  # fmt: skip
    states = {"a": np.zeros((5, 2)), "b": np.tile([0.2, 0.0], (5, 1))}
    executed = Trajectory(4, states, {n: np.zeros((4, 2)) for n in states}, known="states")
    again = with_recoveries(replanned(problem, executed, 1))
    assert again.past is not None and again.past.recovering[("a", "b")].restored == 2
    _, result = replan(problem, executed, 1, overrides=Overrides(time_limit=60))
    assert result.status is PlanStatus.DEGRADED and result.trajectory is not None
    rel = result.trajectory.states["b"] - result.trajectory.states["a"]
    assert rel[1:, 0].min() >= 0.2 - 1e-6
    assert result.report is not None
    assert "never apart again" in result.report.verdict("separation").detail


def test_the_replan_bench_accepts_what_the_past_broke_and_nothing_else() -> None:
    from stlplan.replan_bench import row  # noqa: PLC0415
    from stlplan.result import MonitorReport, Verdict

    report = MonitorReport(
        (
            Verdict("meet", "synchronous", True, 0.2),
            Verdict("separation", "separation", False, -0.07),
        )
    )
    broken = PlanResult(PlanStatus.DEGRADED, "", report=report, broken_by_the_past=("separation",))
    assert row("moved", 4, broken, 1.0)["accepted"] is True
    unexplained = dataclasses.replace(broken, broken_by_the_past=())
    assert row("moved", 4, unexplained, 1.0)["accepted"] is False
