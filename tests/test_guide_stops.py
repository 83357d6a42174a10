"""The moves of a guide's grid search that requirements stop, examined together."""

from __future__ import annotations

import dataclasses

import numpy as np

from stlplan import crowd
from stlplan.analysis.reach import reachable_boxes
from stlplan.mission.loader import problem_from_text
from stlplan.planner.encoding.deferred import defer
from stlplan.planner.first_plan import guide, guide_stops
from tests.reference.half_planes import half_planes

ROOM = crowd.Room(side=4.0, radius=1.6, pillar_offset=0.6, pillar_half=0.25, horizon=12, hold=2)


def _everywhere(hps: list, grid: guide_stops.Grid, t: int, shifts: np.ndarray) -> np.ndarray:
    """Each requirement examined alone at every cell of the grid."""
    out = np.zeros((len(shifts), *grid.shape), dtype=bool)
    for hp in hps:
        out |= guide_stops.moves_failed(hp.a[None], hp.c[None], grid, t, shifts, 0, 0, grid.shape)[
            0
        ]
    return out


def test_half_planes_at_once_are_those_of_each_requirement_term_by_term() -> None:
    problem = problem_from_text(crowd.mission_text(8, ROOM), "crowd-8.yaml")
    problem = dataclasses.replace(problem, robust_to=0.01)  # tightened half-planes too
    lazy = defer(problem, reachable_boxes(problem), 10.0).lazy
    agent, *others = problem.agents
    rng = np.random.default_rng(1)
    states = {
        a.name: a.initial_state + rng.uniform(-1, 1, (problem.horizon + 1, 2)) for a in others
    }
    for known in (others, others[::2]):  # every other agent's plan, and half of them
        fixed = {a.name: states[a.name] for a in known}
        found = guide.readable_planes(lazy, agent.name, fixed, 0.05)
        planes = [half_planes(r, agent.name, fixed, 0.05) for r in lazy]
        alone = [hp for hp in planes if hp is not None]
        assert len(alone) < len(lazy) or len(known) == len(others)
        assert [(p.k, p.span, p.reads) for p in found] == [(p.k, p.span, p.reads) for p in alone]
        for hp, plain in zip(found, alone, strict=True):
            np.testing.assert_allclose(hp.a, plain.a, atol=1e-12)
            np.testing.assert_allclose(hp.c, plain.c, atol=1e-12)


def test_requirements_examined_together_stop_the_moves_each_stops_anywhere() -> None:
    problem = problem_from_text(crowd.mission_text(8, ROOM), "crowd-8.yaml")
    lazy = defer(problem, reachable_boxes(problem), 10.0).lazy
    agent, *others = problem.agents
    rng = np.random.default_rng(0)
    fixed = {a.name: a.initial_state + rng.uniform(-1, 1, (problem.horizon + 1, 2)) for a in others}
    reference = np.repeat(agent.initial_state[None], problem.horizon + 1, axis=0)
    grid = guide.make_grid(agent, reference)
    found = guide.readable_planes(lazy, agent.name, fixed, 1e-6)
    stopping = 0
    for t in range(problem.horizon):
        hps = [hp for hp in found if (hp.k if hp.span else hp.k - 1) == t]
        shifts = grid.moves(t)[1]
        near = (slice(5, 60), slice(10, 73))
        together = guide_stops.stopped(hps, grid, t, shifts, near, guide.CELLS_PER_MOVE + 1)
        alone = _everywhere(hps, grid, t, shifts)
        inside = np.zeros(grid.shape, dtype=bool)
        inside[near] = True
        assert np.array_equal(together[:, inside], alone[:, inside])
        assert not (together & ~alone).any()  # nothing marked that breaks nothing
        stopping += int(alone[:, inside].any())
    assert stopping > 3  # the check saw requirements that stop moves
