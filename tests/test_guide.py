"""The guide of a prioritized turn: a grid path in the plane and in time around fixed agents."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest

from stlplan import crowd
from stlplan.analysis.reach import reachable_boxes
from stlplan.mission.loader import load_problem, problem_from_text
from stlplan.monitor.robustness import robustness
from stlplan.planner.encoding.alphas import violated
from stlplan.planner.encoding.deferred import defer
from stlplan.planner.first_plan import guide
from stlplan.planner.first_plan.guide_stops import reached
from tests.helpers.paths import FARM

ROOM = crowd.Room(side=4.0, radius=1.6, pillar_offset=0.6, pillar_half=0.25, horizon=12, hold=2)
MARGIN = 1e-6


@pytest.fixture(scope="module")
def pair() -> Any:
    """Two agents swapping places across a room with four pillars, and its lazy requirements."""
    problem = problem_from_text(crowd.mission_text(2, ROOM), "crowd-2.yaml")
    return problem, defer(problem, reachable_boxes(problem), 10.0).lazy


def _straight(start: np.ndarray, goal: np.ndarray, horizon: int, step: float) -> np.ndarray:
    """From ``start`` towards ``goal`` at most ``step`` along each axis per step, then still."""
    path = [np.asarray(start, float)]
    for _ in range(horizon):
        path.append(path[-1] + np.clip(goal - path[-1], -step, step))
    return np.array(path)


def _references(problem: Any) -> dict[str, np.ndarray]:
    step = float(problem.agents[0].input_hi[0])
    return {
        a.name: _straight(a.initial_state, ROOM.side - a.initial_state, problem.horizon, step)
        for a in problem.agents
    }


def test_single_integrators_in_the_plane_are_guided_and_double_integrators_are_not(
    pair: Any,
) -> None:
    problem, _ = pair
    assert all(guide.single_integrator(a) for a in problem.agents)
    farm = load_problem(FARM)
    assert not any(guide.single_integrator(a) for a in farm.agents)
    still = dataclasses.replace(
        problem.agents[0], input_lo=np.zeros(2), input_hi=np.array([0.5, 0])
    )
    assert not guide.single_integrator(still)  # no move along y: no grid


def test_with_nothing_in_the_way_the_path_is_the_reference(pair: Any) -> None:
    problem, _ = pair
    agent = problem.agents[0]
    reference = _references(problem)[agent.name]
    path = guide.guide_path(agent, 0, reference, [], {}, MARGIN).path
    assert path is not None
    np.testing.assert_allclose(path, reference, atol=1e-9)


def test_the_path_keeps_every_requirement_on_every_segment_within_the_input_bounds(
    pair: Any,
) -> None:
    problem, lazy = pair
    first, second = problem.agents
    references = _references(problem)
    fixed = {first.name: references[first.name]}
    # the straight references cross at the centre, through the pillars and each other
    assert violated(lazy, references, MARGIN, 0.0)
    path = guide.guide_path(second, 0, references[second.name], lazy, fixed, MARGIN).path
    assert path is not None
    states = {**fixed, second.name: path}
    mine = [r for r in lazy if second.name in r.binding.values()]
    assert mine and violated(mine, states, MARGIN, 0.0) == []
    moves = np.abs(np.diff(path, axis=0))
    assert np.all(moves <= second.input_hi + 1e-9)
    np.testing.assert_allclose(path[0], second.initial_state)


def test_a_later_start_within_the_earlier_step_is_kept_as_it_was(pair: Any) -> None:
    problem, lazy = pair
    first, second = problem.agents
    references = _references(problem)
    fixed = {first.name: references[first.name]}
    reference = references[second.name]
    path = guide.guide_path(second, 2, reference, lazy, fixed, MARGIN).path
    assert path is not None
    np.testing.assert_allclose(path[:3], reference[:3])


def test_an_agent_on_top_of_another_from_its_start_has_no_path_and_names_it(pair: Any) -> None:
    problem, lazy = pair
    first, second = problem.agents
    reference = _references(problem)[second.name]
    fixed = {first.name: reference.copy()}  # the earlier agent follows the very same path
    found = guide.guide_path(second, 0, reference, lazy, fixed, MARGIN)
    assert found.path is None and found.blockers == {first.name}
    pillars = [r for r in lazy if set(r.binding.values()) == {second.name}]
    assert guide.guide_path(second, 0, reference, pillars, {}, MARGIN).blockers == set()


def test_a_requirement_on_an_agent_not_yet_planned_is_not_read(pair: Any) -> None:
    problem, lazy = pair
    first, second = problem.agents
    separation = [r for r in lazy if set(r.binding.values()) == {first.name, second.name}]
    assert separation
    assert guide.readable_planes(separation[:1], second.name, {}, MARGIN) == []
    fixed = {first.name: np.zeros((problem.horizon + 1, 2))}
    assert len(guide.readable_planes(separation[:1], second.name, fixed, MARGIN)) == 1


def test_the_task_planes_are_where_and_when_the_reference_meets_its_task(pair: Any) -> None:
    problem, lazy = pair
    first, second = problem.agents
    references = _references(problem)
    reference = references[second.name]
    planes = guide.task_planes(problem, second.name, reference, MARGIN)
    steps = sorted({hp.k for hp in planes})  # the latest window of the hold the reference keeps
    assert steps == list(range(ROOM.arrival, ROOM.arrival + ROOM.hold + 1))
    for hp in planes:  # the reference keeps each, so the path may be the reference there
        assert float(hp.a[0] @ reference[hp.k]) >= float(hp.c[0, 0])
    fixed = {first.name: references[first.name]}
    path = guide.guide_path(second, 0, reference, lazy, fixed, MARGIN, task=planes).path
    assert path is not None
    task = next(t for t in problem.tasks if t.elements[0] == (second.name,))
    formula = problem.lowered(task.formula, task.binding(task.elements[0]))
    assert robustness(formula, {"p": path}, problem.horizon)[0] >= 0


def test_moves_are_examined_from_reached_cells_only_and_the_paths_are_the_same(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    problem = problem_from_text(crowd.mission_text(8, ROOM), "crowd-8.yaml")
    lazy = defer(problem, reachable_boxes(problem), 10.0).lazy
    references = _references(problem)

    def in_order() -> list[guide.Search]:
        fixed, found = dict[str, np.ndarray](), []
        for agent in problem.agents:  # each around the paths of those before it
            found.append(guide.guide_path(agent, 0, references[agent.name], lazy, fixed, MARGIN))
            if found[-1].path is not None:
                fixed[agent.name] = found[-1].path
        return found

    near = in_order()
    whole = reached(np.zeros(guide.make_grid(problem.agents[0], references["a1"]).shape))
    monkeypatch.setattr(guide, "reached", lambda cost: whole)  # every cell, as if reached
    everywhere = in_order()
    assert sum(s.path is not None for s in near) >= 4
    for a, b in zip(near, everywhere, strict=True):
        assert a.blockers == b.blockers
        assert (a.path is None) == (b.path is None)
        if a.path is not None:
            np.testing.assert_array_equal(a.path, b.path)
