"""The crowd missions: the generator's output is what ships, each is an antipodal swap past four
pillars, and a plan meeting every requirement exists (the circle turning half a turn)."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest

from stlplan import crowd
from stlplan.mission.loader import load_problem, problem_from_text
from stlplan.mission.problem import Problem
from stlplan.monitor.verdicts import check
from stlplan.result import Trajectory
from tests.helpers.paths import MISSIONS

CROWD = MISSIONS / "crowd"


def _load(n: int) -> Problem:
    return load_problem(CROWD / f"crowd-{n}.yaml")


def _box_centre(problem: Problem, region: str) -> np.ndarray:
    box = problem.mission.regions[region].box
    assert box is not None
    return np.array([(lo + hi) / 2 for lo, hi in box])


def test_the_shipped_crowds_are_the_generators_output() -> None:
    assert sorted(p.name for p in CROWD.glob("*.yaml")) == sorted(
        f"crowd-{n}.yaml" for n in crowd.SIZES
    )
    for n in crowd.SIZES:
        shipped = (CROWD / f"crowd-{n}.yaml").read_text(encoding="utf-8")
        assert shipped == crowd.mission_text(n), f"crowd-{n}: run `make crowd`"


@pytest.mark.parametrize("n", crowd.SIZES)
def test_each_agent_crosses_to_the_antipode_of_its_start(n: int) -> None:
    problem, room = _load(n), crowd.ROOM
    assert len(problem.agents) == len(problem.tasks) == n
    assert problem.separation == room.separation and problem.horizon == room.horizon
    centre = np.full(2, room.centre)
    for agent, task in zip(problem.agents, problem.tasks, strict=True):
        assert task.elements == ((agent.name,),)  # its own task, pinned
        start = agent.initial_state
        assert np.linalg.norm(start - centre) == pytest.approx(room.radius, abs=1e-3)
        goal = _box_centre(problem, f"goal_{agent.name}")
        np.testing.assert_allclose(goal, 2 * centre - start, atol=1e-9)
    for a, b in itertools.combinations(problem.agents, 2):
        assert np.max(np.abs(a.initial_state - b.initial_state)) > room.separation


def test_the_pillars_stand_between_the_circle_and_the_centre() -> None:
    problem, room = _load(16), crowd.ROOM
    for name in crowd.PILLARS:
        box = np.array(problem.mission.regions[name].box)
        corners = np.array(list(itertools.product(*box)))
        distances = np.linalg.norm(corners - room.centre, axis=1)
        assert room.pillar_offset / 2 < distances.min() and distances.max() < room.radius
    diagonal = next(a for a in problem.agents if a.name == "a03")  # at 45 degrees
    direction = (room.centre - diagonal.initial_state) / room.radius
    path = diagonal.initial_state + np.outer(np.linspace(0, 2 * room.radius, 200), direction)
    (x_lo, x_hi), (y_lo, y_hi) = problem.mission.regions["pillar_sw"].box or ()
    inside = (x_lo < path[:, 0]) & (path[:, 0] < x_hi) & (y_lo < path[:, 1]) & (path[:, 1] < y_hi)
    assert inside.any()  # a straight diagonal crossing runs into a pillar


@pytest.mark.parametrize("n", crowd.SIZES)
def test_the_circle_turning_half_a_turn_meets_the_mission(n: int) -> None:
    problem = _load(n)
    plan = crowd.rotation_plan(n)
    inputs = {name: np.diff(states, axis=0) for name, states in plan.items()}
    report = check(problem, Trajectory(problem.horizon, plan, inputs))
    assert problem.inter_sample  # separation and pillars judged on the segments too
    assert report.satisfied, [v.detail for v in report.verdicts if not v.satisfied]
    assert report.verdict("separation").robustness > 0


def test_a_team_without_a_partner_for_everyone_is_refused() -> None:
    with pytest.raises(ValueError, match="even number"):
        crowd.mission_text(7)


def test_the_generator_writes_a_mission_stlplan_reads(tmp_path: Path) -> None:
    assert crowd.main(["--out", str(tmp_path), "--agents", "4", "6"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["crowd-4.yaml", "crowd-6.yaml"]
    problem = load_problem(tmp_path / "crowd-6.yaml")
    assert [a.name for a in problem.agents] == ["a1", "a2", "a3", "a4", "a5", "a6"]
    assert problem.mission.name == "crowd-6"


def test_an_order_seed_lists_the_same_agents_in_another_order(tmp_path: Path) -> None:
    assert crowd.main(["--out", str(tmp_path), "--agents", "8", "--orders", "0", "1"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["crowd-8-o0.yaml", "crowd-8-o1.yaml"]
    plain = problem_from_text(crowd.mission_text(8), "crowd-8.yaml")
    starts = {a.name: tuple(a.initial_state) for a in plain.agents}
    orders = []
    for seed in (0, 1):
        problem = load_problem(tmp_path / f"crowd-8-o{seed}.yaml")
        names = [a.name for a in problem.agents]
        assert sorted(names) == [a.name for a in plain.agents] and names != sorted(names)
        assert {a.name: tuple(a.initial_state) for a in problem.agents} == starts
        orders.append(names)
    assert orders[0] != orders[1]
