"""Plans robust to a bounded disturbance: margins one step of it cannot break."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from stlplan.monitor.verdicts import check
from stlplan.online import OnlinePlanner
from stlplan.outputs.summary import summary_dict
from stlplan.pipeline import plan
from stlplan.planner.config import ConfigError, PlannerConfig
from stlplan.planner.overrides import Overrides
from stlplan.result import PlanStatus, Trajectory
from stlplan.simulation import report
from stlplan.simulation.run import disturbances, execute, judge
from stlplan.simulation.settings import Event, Simulated
from tests.helpers.missions import mission

W = 0.05


def _crossing() -> object:
    """a reaches a small goal past an obstacle, b crosses its path; separation 0.3."""
    team = [
        {"name": "a", "dynamics": "si", "initial_state": [0, 0]},
        {"name": "b", "dynamics": "si", "initial_state": [2, -1.5]},
    ]
    regions = {
        "Goal": {"box": [[3.8, 4.2], [-0.2, 0.2]]},
        "Rock": {"box": [[1.5, 2.5], [-0.5, 0.5]]},
        "Dock": {"box": [[1.8, 2.2], [1.3, 1.7]]},
    }
    tasks = {
        "goal": {"formula": "F[4,6] G[0,1] in(p, Goal)", "roles": {"p": {"agent": "a"}}},
        "dock": {"formula": "F[3,7] in(p, Dock)", "roles": {"p": {"agent": "b"}}},
    }
    constraints = {"avoid": {"formula": "G[0,7] !in(p, Rock)", "for_each": "p"}}
    return mission(
        horizon=7, agents=team, regions=regions, tasks=tasks, constraints=constraints,
        separation=0.3, objective={"beta": 1.0, "effort": "l1"},
    )  # fmt: skip


def _verdicts_hold(problem, trajectory: Trajectory) -> bool:  # type: ignore[no-untyped-def]
    report = check(problem, trajectory)  # the dynamics are off by the disturbance: not judged
    return all(v.satisfied for v in report.verdicts if v.kind != "dynamics")


def test_a_robust_plan_keeps_the_margin_it_was_asked_for() -> None:
    problem = _crossing()
    _, nominal = plan(problem, Overrides(time_limit=60))
    _, robust = plan(problem, Overrides(time_limit=60, robust_to=W))
    assert nominal.margin is not None and nominal.margin < 1e-3  # on its boundaries
    assert robust.margin is not None and robust.margin >= W - 1e-6
    assert robust.objective is not None and nominal.objective is not None
    assert robust.objective < nominal.objective  # the price of robustness


@pytest.mark.heavy
@pytest.mark.parametrize("corner", list(itertools.product((-1.0, 1.0), repeat=2)) + ["alternate"])
def test_replanned_every_step_a_robust_plan_survives_the_worst_corners(corner) -> None:  # type: ignore[no-untyped-def]
    problem = _crossing()
    loop = OnlinePlanner(problem, overrides=Overrides(time_limit=60, robust_to=W), policy="every")
    x = {a.name: a.initial_state.copy() for a in problem.agents}
    for k in range(problem.horizon + 1):
        step = loop.step(k, x)
        if k == problem.horizon:
            break
        sign = np.array(corner) if corner != "alternate" else np.array([1.0, -1.0]) * (-1) ** k
        for a in problem.agents:
            x[a.name] = a.A @ x[a.name] + a.B @ step.inputs[a.name] + W * sign
    assert _verdicts_hold(problem, loop.history())
    assert loop.replans == problem.horizon - 1  # every step but the first


def _narrow_goal() -> object:
    """a must be in a goal 0.2 wide at step 2: margins above 0.1 leave no room in it."""
    agents = [{"name": "a", "dynamics": "si", "initial_state": [0, 0]}]
    regions = {"Goal": {"box": [[0.9, 1.1], [-0.1, 0.1]]}}
    tasks = {"goal": {"formula": "F[2,2] in(p, Goal)", "roles": {"p": {"agent": "a"}}}}
    return mission(horizon=3, agents=agents, regions=regions, tasks=tasks)


def test_a_degraded_plan_reduces_its_margins_before_it_drops_a_task() -> None:
    problem = _narrow_goal()
    _, strict = plan(problem, Overrides(time_limit=60, robust_to=0.15))
    assert strict.status is PlanStatus.INFEASIBLE  # no room for margins of 0.15
    planned, result = plan(problem, Overrides(time_limit=60, robust_to=0.15, degrade=True))
    assert result.status is PlanStatus.OPTIMAL and not result.dropped
    assert result.robust_to == pytest.approx(0.075) == planned.robust_to  # half the margins
    assert "margins reduced to 0.075" in result.message
    assert summary_dict(planned, result, {})["robust_to"] == pytest.approx(0.075)
    assert result.margin is not None and result.margin >= 0.075 - 1e-6
    assert result.report is not None and result.report.satisfied


def test_when_no_smaller_margins_do_the_degraded_plan_keeps_the_full_ones() -> None:
    # 0.3 and half of it, 0.15, both leave no room in the goal: the task is dropped
    config = {"diagnosis.margin_fractions": [0.5]}
    overrides = Overrides(time_limit=60, robust_to=0.3, degrade=True, config=config)
    planned, result = plan(_narrow_goal(), overrides)
    assert result.status is PlanStatus.DEGRADED and [d.task for d in result.dropped] == ["goal"]
    assert result.robust_to == 0.3 == planned.robust_to
    assert "smaller margins" in result.stage_seconds
    assert any(c.where.startswith("margins 0.15, ") for c in result.confirmations)
    assert not any("margins reduced" in e for e in result.events)


def test_margins_reduced_are_an_event_of_the_run() -> None:
    _, result = plan(_narrow_goal(), Overrides(time_limit=60, robust_to=0.15, degrade=True))
    assert "margins reduced to 0.075 (no plan keeps every task with margins of 0.15)" in (
        result.events
    )


def test_margin_fractions_must_decrease() -> None:
    with pytest.raises(ConfigError, match="decreasing order"):
        PlannerConfig().with_overrides({"diagnosis.margin_fractions": [0.0, 0.5]})


def test_without_margin_fractions_a_degraded_plan_drops_the_task() -> None:
    config = {"diagnosis.margin_fractions": []}
    overrides = Overrides(time_limit=60, robust_to=0.15, degrade=True, config=config)
    _, result = plan(_narrow_goal(), overrides)
    assert result.status is PlanStatus.DEGRADED and [d.task for d in result.dropped] == ["goal"]
    assert result.robust_to == 0.15


def test_a_plan_keeps_the_margins_it_was_asked_for_when_it_can() -> None:
    _, result = plan(_narrow_goal(), Overrides(time_limit=60, robust_to=0.05, degrade=True))
    assert result.status is PlanStatus.OPTIMAL and result.robust_to == 0.05
    assert "margins reduced" not in result.message


def test_a_run_records_the_replans_that_planned_with_smaller_margins() -> None:
    # a may end in Wide or in Narrow (0.2 wide); Wide closes at step 1, leaving no room in
    # Narrow for margins of 0.15: the replan there halves them, the next ones keep halving
    agents = [{"name": "a", "dynamics": "si", "initial_state": [0, 0]}]
    regions = {
        "Wide": {"box": [[0.5, 1.5], [0.5, 1.5]]},
        "Narrow": {"box": [[0.9, 1.1], [-1.1, -0.9]]},
    }
    formula = "F[3,4] (in(p, Wide) | in(p, Narrow))"
    tasks = {"end": {"formula": formula, "roles": {"p": {"agent": "a"}}}}
    problem = mission(horizon=4, agents=agents, regions=regions, tasks=tasks)
    overrides = Overrides(time_limit=60, robust_to=0.15)
    _, first = plan(problem, overrides)
    simulated = Simulated(0.0, "every", (Event("close", "Wide", 1),))
    run = execute(problem, first, overrides, simulated, disturbances(problem, 0.0, 0, 0))
    assert first.robust_to == 0.15 and run.reduced and set(run.reduced) == {0.075}
    assert not run.dropped and judge(problem, run.executed, simulated).satisfied
    found = report.overall([{"reduced_margins": list(run.reduced), "replan_seconds": [1.0]}])
    assert found["reduced_margins"] == len(run.reduced)
    assert report.line(found).endswith(f"; {len(run.reduced)} with smaller margins")
