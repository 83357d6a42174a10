"""Random initial states: uniform in the mission's initial region, at rest, pairwise separated.

Run ``i`` of seed ``S`` draws from ``numpy.random.default_rng([S, i])``, so its initial state does
not depend on the number of workers or the order in which runs finish.
"""

from __future__ import annotations

import numpy as np

from stlplan.errors import MissionError
from stlplan.mission.problem import region_halfspaces
from stlplan.mission.schema import Agent, Mission
from stlplan.words import counted

MAX_TRIES = 100_000


def _inside(rows: np.ndarray, rhs: np.ndarray, z: np.ndarray) -> bool:
    return bool(np.all(rows @ z <= rhs + 1e-12))


def _bounding_box(rows: np.ndarray, rhs: np.ndarray, mission: Mission) -> np.ndarray:
    """Box to sample from: the workspace of the first agent's dynamics, tightened by axis rows."""
    dyn = mission.dynamics[mission.agents[0].dynamics]
    box = np.array([dyn.state_bounds[i] for i in dyn.position], dtype=float)
    for g, h in zip(rows, rhs, strict=False):
        for axis in (0, 1):
            if abs(g[axis]) > 0 and abs(g[1 - axis]) == 0:
                if g[axis] > 0:
                    box[axis, 1] = min(box[axis, 1], h / g[axis])
                else:
                    box[axis, 0] = max(box[axis, 0], h / g[axis])
    return box


def draw_positions(mission: Mission, seed: int, run: int) -> np.ndarray:
    """Positions (agents x 2) drawn uniformly in the initial region, pairwise separated."""
    if mission.sweep is None:
        raise MissionError(
            "a sweep needs 'sweep: {initial_region: NAME}' in the mission", where="sweep"
        )
    rows_t, rhs_t = region_halfspaces(mission.regions[mission.sweep.initial_region])
    rows, rhs = np.array(rows_t, dtype=float), np.array(rhs_t, dtype=float)
    box = _bounding_box(rows, rhs, mission)
    rng = np.random.default_rng([seed, run])
    separation = mission.separation or 0.0
    placed: list[np.ndarray] = []
    tries = 0
    while len(placed) < len(mission.agents):
        tries += 1
        if tries > MAX_TRIES:
            raise MissionError(
                f"cannot place {counted(len(mission.agents), 'agent')} {separation} apart in region "
                f"'{mission.sweep.initial_region}'",
                where="sweep.initial_region",
            )
        z = box[:, 0] + rng.random(2) * (box[:, 1] - box[:, 0])
        if not _inside(rows, rhs, z):
            continue
        if all(np.max(np.abs(z - q)) >= separation for q in placed):
            placed.append(z)
    return np.array(placed)


def with_initial_positions(mission: Mission, positions: np.ndarray) -> Mission:
    """A copy of ``mission`` whose agents start at ``positions``, at rest."""
    agents: list[Agent] = []
    for agent, z in zip(mission.agents, positions, strict=False):
        dyn = mission.dynamics[agent.dynamics]
        state = [min(max(0.0, lo), hi) for lo, hi in dyn.state_bounds]
        for axis, component in enumerate(dyn.position):
            state[component] = float(z[axis])
        agents.append(agent.model_copy(update={"initial_state": state}))
    return mission.model_copy(update={"agents": agents})
