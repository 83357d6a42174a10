"""Every shipped mission loads, and the farm cases have the paper's agents and groups."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest

from stlplan.formula.tree import horizon
from stlplan.mission.groups import pack
from stlplan.mission.loader import load_problem
from stlplan.mission.problem import Problem
from tests.helpers.paths import MISSIONS

SHIPPED = sorted(MISSIONS.glob("*.yaml"))
SCALED = sorted((MISSIONS / "scale").glob("farm-x*.yaml"))
CROWDS = sorted((MISSIONS / "crowd").glob("*.yaml"))
FARMS = {"farm": (3, 2, 3), "farm-case2": (3, 2, 4), "farm-case3": (4, 2, 3)}
GRID = [(x, y) for y in (4.8, 4.5, 4.2) for x in (0.2, 0.5, 0.8)]


def _load(name: str) -> Problem:
    return load_problem(MISSIONS / f"{name}.yaml")


def _groups(problem: Problem) -> dict[str, int]:
    return {task.name: len(task.groups) for task in problem.tasks}


def test_the_shipped_missions_are_there() -> None:
    names = {p.stem for p in SHIPPED}
    assert {"farm", "farm-case2", "farm-case3", "reach-avoid", "sync-pair"} <= names


@pytest.mark.parametrize("path", SHIPPED + SCALED + CROWDS, ids=lambda p: p.stem)
def test_mission_loads(path: Path) -> None:
    problem = load_problem(path)
    assert problem.agents
    assert problem.mission.name == path.stem
    for task in problem.tasks:
        assert pack(task.elements, range(len(task.elements)), task.count), task.name
    for constraint in problem.constraints:
        assert constraint.bindings, constraint.name
        assert horizon(constraint.formula) <= problem.horizon


@pytest.mark.parametrize("name", sorted(FARMS))
def test_farm_team_on_the_initial_grid(name: str) -> None:
    problem = _load(name)
    n_uv, n_ir, n_vis = FARMS[name]
    caps = [next(iter(a.capabilities)) for a in problem.agents]
    assert caps == ["UV"] * n_uv + ["IR"] * n_ir + ["Vis"] * n_vis
    positions = [tuple(float(v) for v in a.initial_state[:2]) for a in problem.agents]
    assert positions == GRID[: len(positions)]
    for agent in problem.agents:
        assert np.all(agent.initial_state[2:] == 0)  # at rest
    separation = problem.separation or 0.0
    for a, b in itertools.combinations(problem.agents, 2):
        assert np.max(np.abs(a.initial_state[:2] - b.initial_state[:2])) >= separation


def test_farm_case_one_groups() -> None:
    assert _groups(_load("farm")) == {"crop_A1": 3, "crop_A2": 3, "crop_B": 6, "crop_C": 3}


def test_farm_case_two_groups() -> None:
    problem = _load("farm-case2")
    assert len(problem.agents) == 9
    crop_c = next(t for t in problem.tasks if t.name == "crop_C")
    assert crop_c.count == 3 and crop_c.sync is not None
    assert _groups(problem) == {"crop_A1": 3, "crop_A2": 3, "crop_B": 6, "crop_C": 4}  # C(4,3)


def test_farm_case_three_groups() -> None:
    problem = _load("farm-case3")
    assert len(problem.agents) == 9
    # crop_A1/A2: C(4,2) = 6; crop_B: C(4,2) UV pairs times 2 ways to pair them with the 2 IR
    assert _groups(problem) == {"crop_A1": 6, "crop_A2": 6, "crop_B": 12, "crop_C": 3}


@pytest.mark.parametrize("k", [2, 3, 4])
def test_scaled_farms_replicate_case_one(k: int) -> None:
    base, scaled = _load("farm"), load_problem(MISSIONS / "scale" / f"farm-x{k}.yaml")
    caps = [next(iter(a.capabilities)) for a in scaled.agents]
    assert caps == ["UV"] * 3 * k + ["IR"] * 2 * k + ["Vis"] * 3 * k
    counts = {t.name: t.count for t in scaled.tasks}
    assert counts == {t.name: t.count * (k if t.name in ("crop_B", "crop_C") else 1)
                      for t in base.tasks}  # fmt: skip
    assert scaled.mission.dynamics == base.mission.dynamics
    assert scaled.mission.objective == base.mission.objective
    assert scaled.separation == base.separation
    assert {n: r for n, r in scaled.mission.regions.items() if n != "Init"} == {
        n: r for n, r in base.mission.regions.items() if n != "Init"
    }
    (init_lo_x, init_hi_x), (init_lo_y, init_hi_y) = scaled.mission.regions["Init"].box or ()
    for agent in scaled.agents:
        x, y = agent.initial_state[:2]
        assert init_lo_x <= x <= init_hi_x and init_lo_y <= y <= init_hi_y
    for a, b in itertools.combinations(scaled.agents, 2):
        assert np.max(np.abs(a.initial_state[:2] - b.initial_state[:2])) >= scaled.separation


def test_the_same_tasks_farm_is_farm_x2_with_case_one_counts() -> None:
    double, same = (
        load_problem(MISSIONS / "scale" / f"{n}.yaml") for n in ("farm-x2", "farm-x2-same")
    )
    assert [a.name for a in same.agents] == [a.name for a in double.agents]
    assert all(np.array_equal(a.initial_state, b.initial_state)
               for a, b in zip(same.agents, double.agents, strict=True))  # fmt: skip
    assert {t.name: t.count for t in same.tasks} == {t.name: t.count for t in _load("farm").tasks}
    assert [t.formula for t in same.tasks] == [t.formula for t in double.tasks]
    assert same.mission.regions == double.mission.regions
    assert same.separation == double.separation


def test_farm_cases_differ_from_case_one_only_where_the_paper_says() -> None:
    base = _load("farm").mission
    for name in ("farm-case2", "farm-case3"):
        case = _load(name).mission
        assert case.horizon == base.horizon == 9
        assert case.regions == base.regions
        assert case.dynamics == base.dynamics
        assert case.constraints == base.constraints
        assert case.objective == base.objective
        assert case.tasks["crop_B"] == base.tasks["crop_B"]


def test_reach_avoid_is_plain_stl_on_one_agent() -> None:
    problem = _load("reach-avoid")
    assert len(problem.agents) == 1 and not problem.tasks
    (constraint,) = problem.constraints
    assert constraint.bindings == ({"p": problem.agents[0].name},)
    assert 10 <= problem.horizon <= 15
    assert problem.mission.objective.margin.maximize
    assert problem.mission.objective.beta <= 0.01


def test_sync_pair_has_one_synchronous_task() -> None:
    problem = _load("sync-pair")
    assert len(problem.agents) == 2
    (task,) = problem.tasks
    assert task.count == 2 and task.sync is not None
    assert task.sync.b + task.sync.d + horizon(task.formula) <= problem.horizon
    assert len(task.groups) == 1
    assert problem.constraints and problem.separation
