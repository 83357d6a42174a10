"""A 10 x 10 map with two boxes, R and C, for trajectories walked by hand and judged by the monitor."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from stlplan.mission.problem import Problem, build_problem
from stlplan.mission.schema import Mission
from stlplan.result import Trajectory
from tests.helpers.dynamics import single_integrator

BOXES = {"R": ((2.0, 4.0), (2.0, 4.0)), "C": ((6.0, 8.0), (6.0, 8.0))}
DYNAMICS = single_integrator(5, ((0, 10), (0, 10)))
"""Single integrators on the map, ``|u| <= 5`` per axis."""
AVOID = {"avoid": {"formula": "G[0,3] !in(p, R)", "for_each": "p"}}
"""Every agent stays out of R on steps 0..3."""

Path2 = Sequence[tuple[float, float]]


def make_problem(
    paths: Mapping[str, Path2],
    capabilities: Mapping[str, str],
    tasks: Mapping[str, Any] | None = None,
    constraints: Mapping[str, Any] | None = None,
    separation: float | None = None,
) -> Problem:
    """A single-integrator mission on a 10 x 10 map; each agent starts where its path starts."""
    horizon = len(next(iter(paths.values()))) - 1
    agents = [
        {
            "name": n,
            "dynamics": "si",
            "capabilities": [capabilities[n]],
            "initial_state": list(p[0]),
        }
        for n, p in paths.items()
    ]
    mission = Mission.model_validate(
        {
            "name": "test",
            "horizon": horizon,
            "dynamics": {"si": DYNAMICS},
            "agents": agents,
            "regions": {name: {"box": [list(x), list(y)]} for name, (x, y) in BOXES.items()},
            "tasks": dict(tasks or {}),
            "constraints": dict(constraints or {}),
            "separation": separation,
        }
    )
    return build_problem(mission)


def walk(paths: Mapping[str, Path2]) -> Trajectory:
    """States along ``paths``, inputs ``u(k) = x(k+1) - x(k)`` so the dynamics hold exactly."""
    states = {n: np.array(p, dtype=float) for n, p in paths.items()}
    inputs = {n: np.diff(x, axis=0) for n, x in states.items()}
    return Trajectory(len(next(iter(paths.values()))) - 1, states, inputs)
