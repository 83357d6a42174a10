"""Replans on a deadline: a new plan, a degraded plan or the shifted plan, by the deadline."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from stlplan.deadline import Deadline, DeadlineError, deadline_seconds, replan_by
from stlplan.mission.loader import load_problem
from stlplan.mission.past import replanned
from stlplan.monitor.verdicts import check
from stlplan.online import OnlinePlanner
from stlplan.outputs.trajio import write_trajectory_csv
from stlplan.pipeline import plan
from stlplan.planner.overrides import Overrides
from stlplan.result import PlanResult, PlanStatus, Trajectory
from stlplan.shifted import rejoining, shifted_trajectory
from tests.helpers.paths import PAIR, ROOT

SLACK = 1.0
"""How far past its deadline a test lets an answer come on a loaded machine (a hang is what it
catches; the benchmark measures the real lateness)."""


@pytest.fixture(scope="module")
def first() -> PlanResult:
    return plan(PAIR, Overrides(time_limit=60))[1]


def _moved(trajectory: Trajectory, step: int, by: float) -> Trajectory:
    """``trajectory`` with every agent's state at ``step`` moved by ``by`` in x."""
    states = {}
    for name, x in trajectory.states.items():
        x = np.array(x, dtype=float)
        x[step, 0] += by
        states[name] = x
    return dataclasses.replace(trajectory, states=states)


@pytest.mark.parametrize("text", ["0", "-1", "abc", "nan", "inf", ""])
def test_a_deadline_must_be_a_number_of_seconds_above_zero(text: str) -> None:
    with pytest.raises(DeadlineError, match="expected a number of seconds above 0") as caught:
        deadline_seconds(text)
    assert caught.value.exit_code == 3


def test_a_deadline_already_spent_by_loading_is_refused() -> None:
    deadline = Deadline.starting(0.5, time.perf_counter() - 1.0)
    with pytest.raises(DeadlineError, match=r"shorter than loading the mission took \(1\.0"):
        deadline.check_loaded()


def test_the_correction_rejoins_the_plan_one_step_after_the_fewest_that_can() -> None:
    problem = load_problem(PAIR)
    agent = problem.agents[0]  # a double integrator: two steps at least, so three
    deviation = np.array([0.02, -0.02, 0.02, 0.02])
    correction = rejoining(agent, agent.A @ deviation, steps=5)
    assert correction.shape == (3, agent.m)
    after, on_the_way = deviation, []
    for du in correction:
        after = agent.A @ after + agent.B @ du
        on_the_way.append(np.max(np.abs(after[:2])))
    assert np.allclose(after, 0.0, atol=1e-9)
    # off by less on the way than the two-step correction, 0.5 e_p + 0.25 e_v per axis
    assert max(on_the_way[:2]) < 0.5 * 0.02 + 0.25 * 0.02 - 1e-3
    single = dataclasses.replace(agent, A=np.eye(2), B=np.eye(2), position=(0, 1))
    assert np.allclose(
        rejoining(single, np.array([0.1, -0.2]), 5), [[-0.1, 0.2], [0, 0]], atol=1e-5
    )
    assert rejoining(agent, deviation, steps=1).shape == (1, agent.m)  # the horizon's end


def test_the_shifted_plan_meets_the_plans_states_again_from_three_steps_on(
    first: PlanResult,
) -> None:
    assert first.trajectory is not None
    executed = _moved(first.trajectory, 3, 0.02)
    again = replanned(load_problem(PAIR), executed, 3)
    shifted = shifted_trajectory(again, first.trajectory, executed, 3)
    for agent in again.agents:
        x, planned = shifted.states[agent.name], first.trajectory.states[agent.name]
        assert np.allclose(x[3], executed.states[agent.name][3])
        assert np.allclose(x[6:], planned[6:], atol=1e-9)
        assert not np.allclose(x[4], planned[4])  # off the plan on the way back
        for k in range(3, again.horizon):  # the inputs drive the states
            u = shifted.inputs[agent.name][k]
            assert np.allclose(x[k + 1], agent.A @ x[k] + agent.B @ u)
            assert np.all(u >= agent.input_lo - 1e-12) and np.all(u <= agent.input_hi + 1e-12)


def test_an_executed_files_later_rows_are_rejoined_as_the_plan(first: PlanResult) -> None:
    """``replan --deadline``: the file holds the measured state at K and the plan's later rows."""
    assert first.trajectory is not None
    executed = _moved(first.trajectory, 3, 0.02)
    again = replanned(load_problem(PAIR), executed, 3)
    shifted = shifted_trajectory(again, executed, executed, 3)
    for agent in again.agents:
        x, planned = shifted.states[agent.name], first.trajectory.states[agent.name]
        assert np.allclose(x[6:], planned[6:], atol=1e-9)


def test_a_search_that_cannot_finish_gives_the_shifted_plan(first: PlanResult) -> None:
    assert first.trajectory is not None
    problem, executed = load_problem(PAIR), _moved(first.trajectory, 3, 0.02)
    deadline = Deadline.starting(0.05)
    again, result = replan_by(deadline, problem, executed, 3, current=first.trajectory)
    assert time.perf_counter() - deadline.start < 0.05 + SLACK
    assert result.status is PlanStatus.SHIFTED
    assert result.replan is not None and result.replan.came_back == "shifted plan"
    assert result.replan.deadline == 0.05 and result.replan.why
    assert result.message.startswith("no new plan by the deadline of 0.05 s")
    assert result.report is not None and result.trajectory is not None
    assert check(again, result.trajectory).satisfied == result.report.satisfied
    # the search left behind stops, and a later run plans as usual
    assert plan(PAIR, Overrides(time_limit=60))[1].status is PlanStatus.OPTIMAL


def test_without_a_current_plan_nothing_comes_back(first: PlanResult) -> None:
    assert first.trajectory is not None
    problem = load_problem(PAIR)
    deadline = Deadline.starting(0.05)
    _, result = replan_by(deadline, problem, first.trajectory, 3)
    assert result.status is PlanStatus.NO_PLAN and result.trajectory is None
    assert result.replan is not None and result.replan.came_back == "nothing"
    assert "no plan to go on" in result.message


def test_with_time_enough_a_new_plan_comes_back(first: PlanResult) -> None:
    assert first.trajectory is not None
    problem, executed = load_problem(PAIR), _moved(first.trajectory, 3, 0.05)
    deadline = Deadline.starting(60.0)
    again, result = replan_by(deadline, problem, executed, 3, current=first.trajectory)
    assert result.status in (PlanStatus.OPTIMAL, PlanStatus.FEASIBLE)
    assert result.replan is not None and result.replan.came_back == "new plan"
    assert result.message.startswith("new plan by the deadline of 60 s")
    assert result.report is not None and result.report.satisfied
    for agent in again.agents:  # the measured past is kept
        assert result.trajectory is not None
        got = result.trajectory.states[agent.name][3]
        assert np.allclose(got, executed.states[agent.name][3])


@pytest.mark.heavy
def test_a_closed_goal_gives_a_degraded_plan_by_the_deadline(first: PlanResult) -> None:
    assert first.trajectory is not None
    deadline = Deadline.starting(60.0)
    _, result = replan_by(
        deadline, load_problem(PAIR), first.trajectory, 1, closed=("Goal",),
        current=first.trajectory,
    )  # fmt: skip
    assert result.status is PlanStatus.DEGRADED
    assert [d.task for d in result.dropped] == ["meet"]
    assert result.replan is not None and result.replan.came_back == "degraded plan"
    assert result.message.startswith("degraded plan by the deadline of 60 s; 1 task dropped")


def test_the_online_planner_answers_each_replan_by_its_deadline(first: PlanResult) -> None:
    loop = OnlinePlanner(PAIR, first, Overrides(time_limit=60), "every", deadline=0.2)
    problem, rng = loop.problem, np.random.default_rng(0)
    x = {a.name: a.initial_state.copy() for a in problem.agents}
    answers = []
    for k in range(problem.horizon + 1):
        tick = time.perf_counter()
        step = loop.step(k, x)
        if step.replanned:
            assert time.perf_counter() - tick < 0.2 + SLACK
            assert loop.replanned is not None and loop.replanned.replan is not None
            answers.append(loop.replanned.replan.came_back)
        for a in problem.agents:
            if k < problem.horizon:
                noise = rng.uniform(-0.005, 0.005, a.n)
                x[a.name] = a.A @ x[a.name] + a.B @ step.inputs[a.name] + noise
    assert len(answers) == problem.horizon - 1
    assert set(answers) <= {"new plan", "degraded plan", "shifted plan"}


def test_the_online_planner_refuses_a_deadline_of_zero(first: PlanResult) -> None:
    with pytest.raises(DeadlineError, match="deadline 0: expected"):
        OnlinePlanner(PAIR, first, deadline=0)


def _stlplan(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "stlplan", *args], capture_output=True, text=True, cwd=ROOT,
        timeout=300,
    )  # fmt: skip


@pytest.fixture(scope="module")
def planned(tmp_path_factory: pytest.TempPathFactory, first: PlanResult) -> Path:
    """The first plan's trajectory.csv, written as ``stlplan solve`` writes it."""
    assert first.trajectory is not None
    path = tmp_path_factory.mktemp("pair") / "trajectory.csv"
    write_trajectory_csv(load_problem(PAIR), first.trajectory, path)
    return path


@pytest.mark.heavy
def test_the_command_answers_by_its_deadline_and_writes_the_two_files(
    planned: Path, tmp_path: Path
) -> None:
    out = tmp_path / "again"
    tick = time.perf_counter()
    done = _stlplan(
        "replan", str(PAIR), str(planned), "--at", "3", "--closed", "Goal", "--deadline", "20",
        "--out", str(out), "--json",
    )  # fmt: skip
    assert time.perf_counter() - tick < 20 + SLACK
    summary = json.loads(done.stdout)
    assert summary["replan"]["deadline"] == 20
    assert summary["replan"]["came_back"] in ("degraded plan", "shifted plan")
    assert (
        done.returncode == {"degraded plan": 7, "shifted plan": 5}[summary["replan"]["came_back"]]
    )
    assert sorted(p.name for p in out.iterdir()) == ["summary.json", "trajectory.csv"]


@pytest.mark.parametrize(
    ("deadline", "said"),
    [
        ("0", "--deadline 0: expected a number of seconds above 0"),
        ("soon", "--deadline soon: expected a number of seconds above 0"),
        ("0.01", "--deadline 0.01: shorter than starting and loading the mission"),
    ],
)
def test_a_deadline_the_command_cannot_keep_is_bad_input(
    planned: Path, tmp_path: Path, deadline: str, said: str
) -> None:
    out = tmp_path / "never"
    done = _stlplan(
        "replan", str(PAIR), str(planned), "--at", "3", "--deadline", deadline, "--out", str(out)
    )
    assert done.returncode == 3, done.stderr
    assert said in done.stderr
    assert not out.exists()


def test_a_second_search_keeps_a_plan_only_when_it_is_better(first: PlanResult) -> None:
    from stlplan.deadline import better_answer, improvable
    from stlplan.result import Dropped

    plan_of = dataclasses.replace(first, status=PlanStatus.FEASIBLE, objective=1.0, gap=0.2)
    higher = dataclasses.replace(plan_of, objective=2.0)
    degraded = dataclasses.replace(
        higher, status=PlanStatus.DEGRADED, objective=3.0, dropped=(Dropped("meet", "why"),)
    )
    nothing = PlanResult(PlanStatus.NO_PLAN, "none")
    assert better_answer(higher, plan_of) and not better_answer(plan_of, higher)
    assert better_answer(plan_of, degraded) and not better_answer(
        degraded, plan_of
    )  # fewer tasks dropped
    assert better_answer(plan_of, nothing) and not better_answer(nothing, plan_of)
    assert improvable(plan_of) and improvable(degraded)
    assert not improvable(dataclasses.replace(plan_of, gap=1e-5))
    assert not improvable(nothing) and not improvable(first)  # (first is proven optimal)
