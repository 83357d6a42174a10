"""Closed-loop simulation: a plan executed under a bounded disturbance, with events, judged."""

from __future__ import annotations

import numpy as np
import pytest

from stlplan.mission.loader import load_problem
from stlplan.pipeline import plan
from stlplan.planner.overrides import Overrides
from stlplan.result import PlanResult
from stlplan.simulation.run import disturbances, execute, judge
from stlplan.simulation.settings import Event, Simulated
from tests.helpers.paths import PAIR

SETTINGS = Overrides(threads=1, time_limit=60)


@pytest.fixture(scope="module")
def first() -> PlanResult:
    return plan(load_problem(PAIR), SETTINGS)[1]


@pytest.mark.parametrize("policy", ["every", "on-deviation", "never"])
def test_without_disturbance_or_events_the_plan_is_executed_exactly(
    first: PlanResult, policy: str
) -> None:
    problem = load_problem(PAIR)
    simulated = Simulated(0.0, policy)  # type: ignore[arg-type]
    run = execute(problem, first, SETTINGS, simulated, disturbances(problem, 0.0, 0, 0))
    assert first.trajectory is not None
    for agent in problem.agents:
        planned = first.trajectory
        assert np.allclose(run.executed.states[agent.name], planned.states[agent.name], atol=1e-9)
        assert np.allclose(run.executed.inputs[agent.name], planned.inputs[agent.name], atol=1e-9)
    assert len(run.replan_seconds) == (problem.horizon - 1 if policy == "every" else 0)
    report = judge(problem, run.executed, simulated)
    assert report.satisfied and report.rho_s == first.report.rho_s  # type: ignore[union-attr]


def test_the_disturbance_is_reproducible_from_the_seed_and_differs_between_runs() -> None:
    problem = load_problem(PAIR)
    w = disturbances(problem, 0.05, seed=3, run=1)
    assert all(np.array_equal(w[n], v) for n, v in disturbances(problem, 0.05, 3, 1).items())
    others = [disturbances(problem, 0.05, 3, r) for r in (0, 2)] + [
        disturbances(problem, 0.05, 4, 1)
    ]
    for other in others:
        assert not any(np.allclose(w[a.name], other[a.name]) for a in problem.agents)
    for agent in problem.agents:  # one draw per state component and step, within [-W, W]
        assert w[agent.name].shape == (problem.horizon, agent.n)
        assert np.all(np.abs(w[agent.name]) <= 0.05) and np.ptp(w[agent.name]) > 0.05
    assert not np.allclose(w["south"], w["north"])


def test_each_step_applies_the_dynamics_plus_the_drawn_disturbance(first: PlanResult) -> None:
    problem = load_problem(PAIR)
    w = disturbances(problem, 0.02, seed=0, run=5)
    run = execute(problem, first, SETTINGS, Simulated(0.02, "never"), w)
    for a in problem.agents:
        x, u = run.executed.states[a.name], run.executed.inputs[a.name]
        expected = np.clip(x[:-1] @ a.A.T + u @ a.B.T + w[a.name], a.state_lo, a.state_hi)
        assert np.allclose(x[1:], expected, atol=1e-12)
        assert not np.allclose(x, first.trajectory.states[a.name])  # type: ignore[union-attr]


def test_dynamics_are_judged_up_to_the_disturbance_bound(first: PlanResult) -> None:
    problem = load_problem(PAIR)
    w = disturbances(problem, 0.02, seed=0, run=0)
    simulated = Simulated(0.02, "never")
    executed = execute(problem, first, SETTINGS, simulated, w).executed
    within = judge(problem, executed, simulated)
    assert all(v.satisfied for v in within.verdicts if v.kind == "dynamics")
    tighter = judge(problem, executed, Simulated(0.002, "never"))
    broken = [v for v in tighter.verdicts if v.kind == "dynamics" and not v.satisfied]
    assert broken and "up to the disturbance 0.002" in broken[0].detail


def test_a_lost_agent_stays_and_a_closed_region_is_judged_from_its_step(
    first: PlanResult,
) -> None:
    problem = load_problem(PAIR)
    events = (Event("lose", "north", 3), Event("close", "Goal", 6))
    simulated = Simulated(0.0, "on-deviation", events)
    run = execute(problem, first, SETTINGS, simulated, disturbances(problem, 0.0, 0, 0))
    x = run.executed.states["north"]
    assert np.allclose(x[3:], x[3]) and not np.allclose(x[2], x[3])
    assert np.all(run.executed.inputs["north"][3:] == 0)
    assert len(run.replan_seconds) == 2  # at each event
    assert [d.task for d in run.dropped] == ["meet"]  # north, lost, cannot reach Goal
    report = judge(problem, run.executed, simulated)
    assert report.verdict("dynamics north").satisfied
    assert report.verdict("closed Goal (leaving)").satisfied  # south leaves Goal at step 7
    assert [v.name for v in report.verdicts if not v.satisfied] == ["meet"]


def test_with_a_deadline_each_replan_says_what_came_back_by_it() -> None:
    from stlplan.simulation.report import line, overall
    from stlplan.simulation.run import figures

    problem = load_problem(PAIR)
    simulated = Simulated(0.01, "every", deadline=5.0)
    assert simulated.describe()["deadline"] == 5.0 and "deadline" not in Simulated().describe()
    robust = Overrides(threads=1, time_limit=60, robust_to=0.01)
    planned = plan(problem, robust)[1]
    run = execute(problem, planned, robust, simulated, disturbances(problem, 0.01, 0, 0))
    assert len(run.came_back) == len(run.replan_seconds) == problem.horizon - 1
    assert set(run.came_back) <= {"new plan", "degraded plan", "shifted plan"}
    # a shifted plan keeps no margins of its own, but it is no replan with smaller margins
    hurried = Simulated(0.01, "every", deadline=0.05)
    rushed = execute(problem, planned, robust, hurried, disturbances(problem, 0.01, 0, 0))
    assert "shifted plan" in rushed.came_back
    assert len(rushed.reduced) <= sum(1 for c in rushed.came_back if c != "shifted plan")
    record = figures(judge(problem, run.executed, simulated), run)
    assert sum(record["came_back"].values()) == problem.horizon - 1
    summary = overall([record, record])
    assert sum(summary["came_back"].values()) == 2 * (problem.horizon - 1)
    assert "by the deadline: " in line(summary)
