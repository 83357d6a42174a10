"""Tiny missions shared by the planner's tests: a builder and the named problems."""

from __future__ import annotations

from typing import Any

from stlplan.mission.problem import Problem, build_problem
from stlplan.mission.schema import Mission
from tests.helpers.dynamics import SINGLE_INTEGRATOR_U1


def mission(**fields: Any) -> Problem:
    """A checked problem from mission fields: name 'tiny', and dynamics ``si`` (single
    integrators, ``|u| <= 1`` per axis) unless ``dynamics`` is given."""
    return build_problem(
        Mission.model_validate({"name": "tiny", "dynamics": {"si": SINGLE_INTEGRATOR_U1}, **fields})
    )


def swap_problem(
    separation: float | None,
    horizon: int = 2,
    inter_sample: bool = False,
    east_from: int | None = None,
) -> Problem:
    """a and b trade places on the x axis, arriving at step H (a may reach East from step
    ``east_from`` on, when given); with H = 2 both are within 0.2 of x = 1 at step 1, so a
    separation of 0.5 costs a detour in y: up/down 0.25, back 0.15 each (sampled separation, the
    paper's; between samples the two would pass through each other)."""
    first = horizon if east_from is None else east_from
    return mission(
        safety={"inter_sample": inter_sample},
        horizon=horizon,
        agents=[
            {"name": "a", "dynamics": "si", "initial_state": [0, 0]},
            {"name": "b", "dynamics": "si", "initial_state": [2, 0]},
        ],
        regions={
            "East": {"box": [[1.9, 2.1], [-0.1, 0.1]]},
            "West": {"box": [[-0.1, 0.1], [-0.1, 0.1]]},
        },
        tasks={
            "east": {
                "formula": f"F[{first},{horizon}] in(p, East)",
                "roles": {"p": {"agent": "a"}},
            },
            "west": {
                "formula": f"F[{horizon},{horizon}] in(p, West)",
                "roles": {"p": {"agent": "b"}},
            },
        },
        separation=separation,
        objective={"beta": 1.0, "effort": "l1"},
    )


def detour_for_free() -> Problem:
    """a (or b) must reach R; a's straight diagonal passes through the idle e at (1, 1), but
    every monotone path from (0, 0) to R costs the same L1 effort: the collision costs nothing."""
    agents = [
        {"name": "a", "dynamics": "si", "capabilities": ["X"], "initial_state": [0, 0]},
        {"name": "b", "dynamics": "si", "capabilities": ["X"], "initial_state": [4, -4]},
        {"name": "e", "dynamics": "si", "capabilities": ["Z"], "initial_state": [1, 1]},
    ]
    return mission(
        safety={"inter_sample": True},
        horizon=4,
        agents=agents,
        regions={"R": {"box": [[2, 3], [2, 3]]}},
        tasks={"reach": {"formula": "F[3,4] in(p, R)", "roles": {"p": "X"}}},
        separation=0.2,
        objective={"beta": 1.0, "effort": "l1"},
    )


def crossing_problem(inter_sample: bool = True, paired: bool = False) -> Problem:
    """Four agents trade places across the middle of a square: their straight plans all meet
    near (1, 1) at step 2; each must reach its goal at step 4 (each agent its own part; with
    ``paired``, a and b in one task and c and d in another: two parts of two agents)."""
    corners = {
        "a": ((0, 0), (2, 2)),
        "b": ((2, 2), (0, 0)),
        "c": ((0, 2), (2, 0)),
        "d": ((2, 0), (0, 2)),
    }
    agents = [
        {"name": n, "dynamics": "si", "initial_state": list(s)} for n, (s, _) in corners.items()
    ]
    regions = {
        f"G{n}": {"box": [[x - 0.1, x + 0.1], [y - 0.1, y + 0.1]]}
        for n, (_, (x, y)) in corners.items()
    }
    tasks = {
        f"to_{n}": {"formula": f"F[4,4] in(p, G{n})", "roles": {"p": {"agent": n}}} for n in corners
    }
    if paired:
        tasks = {
            f"{p}{q}": {
                "formula": f"F[4,4] in(p, G{p}) & F[4,4] in(q, G{q})",
                "roles": {"p": {"agent": p}, "q": {"agent": q}},
            }
            for p, q in ("ab", "cd")
        }
    return mission(
        safety={"inter_sample": inter_sample},
        horizon=4,
        agents=agents,
        regions=regions,
        tasks=tasks,
        separation=0.3,
        objective={"beta": 1.0, "effort": "l1"},
    )


def sync_and_errand() -> Problem:
    """Two parts: a and b meet in Goal (a synchronous task, ``rho_s`` up to 4), c runs an errand
    to S. The whole optimum is about ``rho_s - 0.1 * effort`` > 0, c's part alone only
    ``-0.1 * effort_c`` < 0: a part's bound recorded as the whole's would fall below the optimum."""
    agents = [
        {"name": "a", "dynamics": "si", "capabilities": ["X"], "initial_state": [0, 0]},
        {"name": "b", "dynamics": "si", "capabilities": ["X"], "initial_state": [0, 1]},
        {"name": "c", "dynamics": "si", "capabilities": ["Y"], "initial_state": [4, 0]},
    ]
    return mission(
        horizon=7,
        agents=agents,
        regions={"Goal": {"box": [[1, 2], [0, 1]]}, "S": {"box": [[4, 5], [3, 4]]}},
        tasks={
            "meet": {
                "formula": "in(p, Goal)",
                "count": 2,
                "roles": {"p": "X"},
                "synchronous": {"within": [1, 3], "hold": 1},
            },
            "errand": {"formula": "F[3,5] in(p, S)", "roles": {"p": "Y"}},
        },
        separation=0.05,
        objective={"beta": 0.1, "gamma": 4, "effort": "l1"},
    )
