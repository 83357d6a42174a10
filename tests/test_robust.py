"""Plans robust to a bounded disturbance: margins one step of it cannot break."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from stlplan.monitor.verdicts import check
from stlplan.online import OnlinePlanner
from stlplan.pipeline import plan
from stlplan.planner.config import Overrides
from stlplan.result import Trajectory
from tests.helpers.missions import mission

W = 0.05


def _crossing() -> object:
    """a reaches a small goal past an obstacle, b crosses its path; separation 0.3."""
    team = [
        {"name": "a", "dynamics": "si", "initial_state": [0, 0]},
        {"name": "b", "dynamics": "si", "initial_state": [2, -1.5]},
    ]
    regions = {
        "Goal": {"box": [[3.8, 4.2], [-0.2, 0.2]]},
        "Rock": {"box": [[1.5, 2.5], [-0.5, 0.5]]},
        "Dock": {"box": [[1.8, 2.2], [1.3, 1.7]]},
    }
    tasks = {
        "goal": {"formula": "F[4,6] G[0,1] in(p, Goal)", "roles": {"p": {"agent": "a"}}},
        "dock": {"formula": "F[3,7] in(p, Dock)", "roles": {"p": {"agent": "b"}}},
    }
    constraints = {"avoid": {"formula": "G[0,7] !in(p, Rock)", "for_each": "p"}}
    return mission(
        horizon=7, agents=team, regions=regions, tasks=tasks, constraints=constraints,
        separation=0.3, objective={"beta": 1.0, "effort": "l1"},
    )  # fmt: skip


def _verdicts_hold(problem, trajectory: Trajectory) -> bool:  # type: ignore[no-untyped-def]
    report = check(problem, trajectory)  # the dynamics are off by the disturbance: not judged
    return all(v.satisfied for v in report.verdicts if v.kind != "dynamics")


def test_a_robust_plan_keeps_the_margin_it_was_asked_for() -> None:
    problem = _crossing()
    _, nominal = plan(problem, Overrides(time_limit=60))
    _, robust = plan(problem, Overrides(time_limit=60, robust_to=W))
    assert nominal.margin is not None and nominal.margin < 1e-3  # on its boundaries
    assert robust.margin is not None and robust.margin >= W - 1e-6
    assert robust.objective is not None and nominal.objective is not None
    assert robust.objective < nominal.objective  # the price of robustness


@pytest.mark.parametrize("corner", list(itertools.product((-1.0, 1.0), repeat=2)) + ["alternate"])
def test_replanned_every_step_a_robust_plan_survives_the_worst_corners(corner) -> None:  # type: ignore[no-untyped-def]
    problem = _crossing()
    loop = OnlinePlanner(problem, overrides=Overrides(time_limit=60, robust_to=W), policy="every")
    x = {a.name: a.initial_state.copy() for a in problem.agents}
    for k in range(problem.horizon + 1):
        step = loop.step(k, x)
        if k == problem.horizon:
            break
        sign = np.array(corner) if corner != "alternate" else np.array([1.0, -1.0]) * (-1) ** k
        for a in problem.agents:
            x[a.name] = a.A @ x[a.name] + a.B @ step.inputs[a.name] + W * sign
    assert _verdicts_hold(problem, loop.history())
    assert loop.replans == problem.horizon - 1  # every step but the first
