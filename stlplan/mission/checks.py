"""Semantic checks of a mission the schema accepted: one clear message per mistake.

Each check raises :class:`MissionError` (or :class:`FormulaError`) naming the field path and what
was expected. They run in the order a reader meets the file: dynamics, agents, regions, tasks,
constraints, objective. This module holds the whole-mission checks (horizon, dynamics, agents,
regions, sweep); the checks of tasks, constraints and their formulas live in
:mod:`stlplan.mission.formula_checks` and are re-exported here, so callers import every check from here.
"""

from __future__ import annotations

import numpy as np

from stlplan.errors import fail, undefined
from stlplan.mission.formula_checks import (
    MAX_ELEMENTS,
    MAX_GROUPS,
    ROLE_NAME,
    check_constraint,
    check_group_count,
    check_groups,
    check_task,
    check_window,
)
from stlplan.mission.schema import Dynamics, Mission

__all__ = [
    "MAX_ELEMENTS",
    "MAX_GROUPS",
    "MAX_HORIZON",
    "ROLE_NAME",
    "check_agents",
    "check_constraint",
    "check_dynamics",
    "check_group_count",
    "check_groups",
    "check_mission",
    "check_regions",
    "check_task",
    "check_window",
]

MAX_HORIZON = 100_000
"""Largest horizon H (states are stored for every step)."""


def check_dynamics(mission: Mission, source: str | None) -> None:
    """Matrix shapes, position components and bound intervals of every dynamics model."""
    for name, dyn in mission.dynamics.items():
        where = f"dynamics.{name}"
        n, m = _check_matrices(dyn, where, source)
        for field, bounds, size, kind in (
            ("state_bounds", dyn.state_bounds, n, "state"),
            ("input_bounds", dyn.input_bounds, m, "input"),
        ):
            if len(bounds) != size:
                fail(
                    f"expected {size} {kind} bounds (one per {kind} component), found "
                    f"{len(bounds)}",
                    f"{where}.{field}",
                    source,
                )
            for i, (lo, hi) in enumerate(bounds):
                if lo > hi:
                    fail(
                        f"empty interval [{lo}, {hi}]: low must be <= high",
                        f"{where}.{field}[{i}]",
                        source,
                    )
        i, j = dyn.position
        if i == j or not (0 <= i < n and 0 <= j < n):
            fail(
                f"position must name two distinct state components in 0..{n - 1}, found [{i}, {j}]",
                f"{where}.position",
                source,
            )


def _check_matrices(dyn: Dynamics, where: str, source: str | None) -> tuple[int, int]:
    """``A`` is n x n and ``B`` is n x m with m >= 1; returns ``(n, m)``."""
    n = len(dyn.A)
    if n == 0 or any(len(row) != n for row in dyn.A):
        fail(
            f"A must be a non-empty square matrix (n x n), found rows of lengths "
            f"{[len(r) for r in dyn.A]}",
            f"{where}.A",
            source,
        )
    if len(dyn.B) != n:
        fail(f"B must have n = {n} rows (as A), found {len(dyn.B)}", f"{where}.B", source)
    m = len(dyn.B[0])
    if m == 0:
        fail("B needs at least one column (one per input component)", f"{where}.B", source)
    for k, row in enumerate(dyn.B):
        if len(row) != m:
            fail(
                f"every row of B must have m = {m} entries (as B[0]), found {len(row)}",
                f"{where}.B[{k}]",
                source,
            )
    return n, m


def check_agents(mission: Mission, source: str | None) -> None:
    """Unique names, defined dynamics, initial state length and bounds."""
    seen: set[str] = set()
    for k, agent in enumerate(mission.agents):
        where = f"agents[{k}]"
        if agent.name in seen:
            fail(f"duplicate agent name '{agent.name}'", f"{where}.name", source)
        seen.add(agent.name)
        if agent.dynamics not in mission.dynamics:
            fail(
                undefined("dynamics", agent.dynamics, list(mission.dynamics)),
                f"{where}.dynamics",
                source,
            )
        dyn = mission.dynamics[agent.dynamics]
        if len(agent.initial_state) != len(dyn.A):
            fail(
                f"initial_state has {len(agent.initial_state)} values, dynamics "
                f"'{agent.dynamics}' has {len(dyn.A)} state components",
                f"{where}.initial_state",
                source,
            )
        for i, (x, (lo, hi)) in enumerate(zip(agent.initial_state, dyn.state_bounds, strict=True)):
            if not lo <= x <= hi:
                fail(
                    f"initial state {x} is outside its bounds [{lo}, {hi}]",
                    f"{where}.initial_state[{i}]",
                    source,
                )


def check_regions(mission: Mission, source: str | None) -> None:
    """Non-empty boxes and consistent polytope shapes."""
    for name, region in mission.regions.items():
        where = f"regions.{name}"
        if region.box is not None:
            for axis, (lo, hi) in zip("xy", region.box, strict=True):
                if lo >= hi:
                    fail(
                        f"empty box: {axis} interval [{lo}, {hi}] needs low < high",
                        f"{where}.box",
                        source,
                    )
        elif region.G is not None and region.h is not None:
            if len(region.G) != len(region.h):
                fail(
                    f"G has {len(region.G)} rows but h has {len(region.h)} entries",
                    f"{where}.h",
                    source,
                )
            if not region.G:
                fail("a polytope needs at least one row [g_x, g_y] in G", f"{where}.G", source)
            if any(np.hypot(*g) == 0 for g in region.G):
                fail("a row of G is zero", f"{where}.G", source)


def check_mission(mission: Mission, source: str | None) -> None:
    """Every whole-mission check that needs no parsed formula."""
    if mission.horizon > MAX_HORIZON:
        fail(
            f"expected a horizon of at most {MAX_HORIZON} steps, found {mission.horizon}",
            "horizon",
            source,
        )
    check_dynamics(mission, source)
    check_agents(mission, source)
    check_regions(mission, source)
    if mission.sweep is not None and mission.sweep.initial_region not in mission.regions:
        fail(
            undefined("region", mission.sweep.initial_region, list(mission.regions)),
            "sweep.initial_region",
            source,
        )
