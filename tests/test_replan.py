"""Replanning: the executed past is data, lost agents and closed regions are events."""

from __future__ import annotations

import numpy as np
import pytest

from stlplan.analysis.diagnose import cheap_reasons
from stlplan.errors import EventError, TrajectoryError
from stlplan.mission.past import replanned
from stlplan.mission.problem import Problem
from stlplan.monitor.verdicts import check
from stlplan.planner.overrides import Overrides
from stlplan.replanning import replan
from stlplan.result import PlanStatus, Trajectory
from tests.helpers.missions import detour_for_free, mission

R = {"box": [[2.9, 3.1], [-0.1, 0.1]]}


def _walk(problem: Problem, moves: dict[str, list[tuple[float, float]]]) -> Trajectory:
    """A trajectory of single integrators from their initial states by the given inputs (the
    rest of the horizon standing still)."""
    H, states, inputs = problem.horizon, {}, {}
    for agent in problem.agents:
        u = np.zeros((H, 2))
        given = moves.get(agent.name, [])
        if given:
            u[: len(given)] = given
        x = np.vstack([agent.initial_state, agent.initial_state + np.cumsum(u, axis=0)])
        states[agent.name], inputs[agent.name] = x, u
    return Trajectory(H, states, inputs)


def _visit(count: int = 1, agents: int = 1) -> Problem:
    team = [
        {"name": n, "dynamics": "si", "capabilities": ["X"], "initial_state": [0, 2 * i]}
        for i, n in enumerate("ab"[:agents])
    ]
    return mission(
        horizon=6,
        agents=team,
        regions={"R": R, "C": {"box": [[0.8, 2.2], [-0.6, 0.6]]}},
        tasks={"visit": {"formula": "F[0,6] in(p, R)", "count": count, "roles": {"p": "X"}}},
        objective={"beta": 1.0, "effort": "l1"},
    )


def _replan(problem: Problem, executed: Trajectory, step: int, **events: list[str]):  # type: ignore[no-untyped-def]
    again, result = replan(problem, executed, step, overrides=Overrides(time_limit=60), **events)
    assert result.report is not None and result.report.satisfied, result.message
    return again, result


def test_an_eventually_met_in_the_past_is_not_demanded_again() -> None:
    problem = _visit()
    # a reaches R at step 3 and steps back out; from step 4 nothing more is needed
    executed = _walk(problem, {"a": [(1, 0), (1, 0), (1, 0), (-1, 0)]})
    _, result = _replan(problem, executed, 4)
    assert result.objective == pytest.approx(0.0, abs=1e-6)  # no input planned
    assert result.replan is not None and result.replan.past_effort == pytest.approx(4.0)


def test_without_the_visit_the_replan_goes_back() -> None:
    problem = _visit()
    executed = _walk(problem, {"a": [(1, 0), (1, 0), (0, 0), (0, 0)]})  # stops at x = 2
    _, result = _replan(problem, executed, 4)
    assert result.objective is not None and result.objective < -0.85  # back to R: 0.9 at least


def test_a_lost_agents_past_contribution_still_counts() -> None:
    problem = _visit(count=2, agents=2)
    # b (from (0, 2)) is in R at step 3 and lost at step 4, outside it; a must still go
    moves = {"b": [(1, -1), (1, -1), (1, 0), (-0.5, 0)], "a": [(1, 0), (1, 0)]}
    executed = _walk(problem, moves)
    again, result = _replan(problem, executed, 4, lost=["b"])
    assert result.trajectory is not None
    kept = result.trajectory.states["b"][4:]
    assert np.allclose(kept, executed.states["b"][4])  # stays where it was last seen
    assert again.past is not None and again.past.lost == {"b"}
    a_later = result.trajectory.states["a"][5:, 0]
    assert np.any(np.abs(a_later - 3.0) <= 0.1 + 1e-6)  # a still has to visit R


def test_a_closed_region_is_avoided_from_the_replan_on() -> None:
    problem = _visit()
    executed = _walk(problem, {})  # a has not moved
    _, straight = _replan(problem, executed, 1)
    _, around = _replan(problem, executed, 1, closed=["C"])
    assert straight.trajectory is not None and around.trajectory is not None
    inside = [_in_c(p) for p in straight.trajectory.states["a"][1:]]
    assert any(inside)  # the straight plan crosses C
    assert not any(_in_c(p) for p in around.trajectory.states["a"][1:])
    assert around.report is not None and around.report.verdict("closed C").satisfied
    assert around.objective is not None and straight.objective is not None
    assert around.objective < straight.objective  # the detour costs effort


def _in_c(position: np.ndarray) -> bool:
    return bool(0.8 < position[0] < 2.2 and -0.6 < position[1] < 0.6)


@pytest.mark.parametrize("step", [1, 2, 3])
def test_a_replan_with_nothing_changed_keeps_the_objective(step: int) -> None:
    problem = detour_for_free()
    one_step = Overrides(time_limit=60, two_step=False)
    from stlplan.pipeline import plan

    problem, first = plan(problem, one_step)
    assert first.trajectory is not None and first.objective is not None
    again, result = replan(problem, first.trajectory, step, overrides=one_step)
    assert result.status is PlanStatus.OPTIMAL and result.objective is not None
    assert result.replan is not None
    whole = result.objective - problem.mission.objective.beta * result.replan.past_effort
    assert whole == pytest.approx(first.objective, rel=1e-4, abs=1e-6)


@pytest.mark.parametrize("seed", range(4))
def test_the_replans_verdicts_are_the_missions_on_the_whole_trajectory(seed: int) -> None:
    problem = _visit(count=2, agents=2)
    rng = np.random.default_rng(seed)
    step = int(rng.integers(1, 4))  # every such past leaves the mission feasible
    toward = {"a": (-0.25, 0.25), "b": (-0.5, 0.0)}
    moves = {
        name: [(rng.uniform(0, 1), rng.uniform(*y)) for _ in range(step)]
        for name, y in toward.items()
    }
    executed = _walk(problem, moves)
    _, result = replan(problem, executed, step, overrides=Overrides(time_limit=60))
    assert result.trajectory is not None and result.report is not None
    plain = check(problem, result.trajectory)  # the mission's monitor, knowing no past
    for task in problem.tasks:
        assert plain.verdict(task.name).satisfied == result.report.verdict(task.name).satisfied
    assert plain.verdict("visit").satisfied


@pytest.mark.parametrize(
    ("step", "events", "expected"),
    [
        (6, {}, r"--at 6: expected a step in 0\.\.5"),
        (-1, {}, r"--at -1: expected a step in 0\.\.5"),
        (2, {"lost": ["z"]}, "--lost z: no such agent; agents: a, b"),
        (2, {"lost": ["a", "a"]}, "--lost a: the agent is lost twice"),
        (2, {"lost": ["a", "b"]}, "--lost names every agent"),
        (2, {"closed": ["Nowhere"]}, "--closed Nowhere: no such region; regions: R, C"),
        (2, {"closed": ["C", "C"]}, "--closed C: the region is closed twice"),
    ],
)
def test_bad_events_are_refused(step: int, events: dict[str, list[str]], expected: str) -> None:
    problem = _visit(count=1, agents=2)
    with pytest.raises(EventError, match=expected):
        replanned(problem, _walk(problem, {}), step, **events)


def test_an_executed_state_outside_its_bounds_names_the_agent_and_step() -> None:
    problem = _visit()
    executed = _walk(problem, {})
    executed.states["a"][2] = (7.0, 0.0)
    with pytest.raises(TrajectoryError, match=r"agent 'a' step 2: x0 = 7 is outside its state"):
        replanned(problem, executed, 3)


def _pair(separation: float = 0.5) -> Problem:
    team = [
        {"name": "a", "dynamics": "si", "capabilities": ["X"], "initial_state": [0, 0]},
        {"name": "b", "dynamics": "si", "capabilities": ["X"], "initial_state": [0, 2]},
    ]
    task = {"formula": "F[0,6] in(p, R)", "roles": {"p": {"agent": "a"}}}
    guard = {"formula": "G[0,6] in(p, Yard)", "roles": {"p": {"agent": "b"}}}
    regions = {"R": R, "Yard": {"box": [[-1, 1], [1, 3]]}}
    return mission(
        horizon=6, agents=team, regions=regions, tasks={"visit": task, "guard": guard},
        separation=separation, objective={"beta": 1.0, "effort": "l1"},
    )  # fmt: skip


def test_a_separation_the_past_broke_degrades_the_plan_and_is_named_once() -> None:
    problem = _pair()
    executed = _walk(problem, {})
    executed.states["a"][2] = (0.2, 0.8)  # both drifted: within 0.5 of each other at step 2
    executed.states["b"][2] = (0.0, 1.1)
    again, result = replan(problem, executed, 2, overrides=Overrides(time_limit=60))
    assert result.status is PlanStatus.DEGRADED
    assert result.broken_by_the_past == ("separation",) and result.dropped == ()
    assert "the executed past breaks separation" in result.message
    assert result.trajectory is not None  # after the replan's step, the pair is apart again
    gap = np.abs(result.trajectory.states["a"] - result.trajectory.states["b"]).max(axis=1)
    assert np.all(gap[3:] >= 0.5 - 1e-6)


def test_an_always_the_past_broke_is_named_at_once() -> None:
    problem = _pair(separation=0.0)
    executed = _walk(problem, {"b": [(0, 1), (0, 1)]})  # b leaves the Yard at step 2
    again, result = replan(problem, executed, 3, overrides=Overrides(time_limit=60))
    assert result.status is PlanStatus.DEGRADED
    assert [d.task for d in result.dropped] == ["guard"]
    assert "can no longer be met after the executed past" in result.dropped[0].reason
    assert result.report is not None and result.report.verdict("visit").satisfied


@pytest.mark.parametrize("step", [2, 5])
def test_a_drifted_replan_of_a_mission_with_a_margin_floor_is_judged_by_what_it_planned(
    step: int,
) -> None:
    # sync-pair asks every predicate to hold by 0.2; the drifted states at K hold less, which is
    # the executed past's, not the plan's: the plan still keeps 0.2 from K+1 on
    from stlplan.mission.loader import load_problem
    from stlplan.pipeline import plan as verified_plan
    from stlplan.replan_bench import moved
    from tests.helpers.paths import PAIR

    problem = load_problem(PAIR)
    _, first = verified_plan(problem, Overrides(time_limit=60))
    assert first.trajectory is not None
    executed = moved(problem, first.trajectory, step, 0.05, 0)
    _, result = replan(problem, executed, step, overrides=Overrides(time_limit=60))
    assert result.status.has_plan and result.report is not None
    assert result.margin is not None and result.margin >= 0.2 - 1e-6


def test_a_task_in_a_closed_region_is_dropped_without_a_solve() -> None:
    # R closed at step 1, before a could get there: the task's region is out of bounds for good
    problem = _visit()
    executed = _walk(problem, {})
    again = replanned(problem, executed, 1, closed=["R"])
    reasons = cheap_reasons(again)
    assert [r.item for r in reasons] == ["visit"]
    assert "constraint 'closed R'" in reasons[0].text
    assert not cheap_reasons(replanned(problem, executed, 1, closed=["C"]))
    _, result = _replan(problem, executed, 1, closed=["R"])
    assert result.status is PlanStatus.DEGRADED
    assert [d.task for d in result.dropped] == ["visit"]
    assert "constraint 'closed R'" in result.dropped[0].reason
    assert not any("diagnosis probe" in c.where for c in result.confirmations)


def test_a_replan_keeps_a_constraints_eventually_that_starts_at_its_step() -> None:
    """``G[0,5] F[0,1] in(p, A)`` at step K = 5, outside A: the agent must be back in A at 6
    (the part at K reads step K+1, which is planned, not data)."""
    from stlplan.mission.past import replanned
    from stlplan.monitor.verdicts import check as judge
    from stlplan.result import Trajectory
    from tests.helpers.dynamics import single_integrator
    from tests.helpers.missions import mission
    from tests.helpers.solving import up_front_optimum

    problem = mission(
        horizon=8,
        agents=[{"name": "a", "dynamics": "si", "capabilities": ["c"], "initial_state": [2.5, 0]}],
        regions={"A": {"box": [[2, 3], [-1, 1]]}, "Far": {"box": [[4.8, 6], [-1, 1]]}},
        tasks={"go": {"formula": "F[8,8] in(p, Far)", "roles": {"p": "c"}}},
        constraints={"near_A": {"formula": "G[0,5] F[0,1] in(p, A)", "for_each": "p"}},
        dynamics={"si": single_integrator(1, ((0, 7), (-2, 2)))},
    )
    xs = [2.5, 2.5, 2.5, 2.5, 2.5, 3.4, 4.4, 5.4, 5.5]  # out of A at 5
    states = {"a": np.array([[x, 0.0] for x in xs])}
    executed = Trajectory(8, states, {"a": np.diff(states["a"], axis=0)})
    again = replanned(problem, executed, 5)
    result = up_front_optimum(again)  # every constraint written out, none left to the lazy loop
    assert result.trajectory is not None
    assert judge(again, result.trajectory).satisfied
    assert result.trajectory.states["a"][6, 0] <= 3.0
