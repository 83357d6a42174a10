"""Which pairs of agents can come closer than the separation, from reachable boxes alone."""

from __future__ import annotations

import pytest

from stlplan.analysis.reach import meeting_steps, reachable_boxes
from stlplan.mission.loader import load_problem
from stlplan.mission.problem import Problem
from tests.helpers.missions import mission
from tests.helpers.paths import MISSIONS


def _three(separation: float | None) -> Problem:
    """Single integrators, ``|u| <= 1`` per axis, on ``[-5, 5]^2``, two steps: ``a`` and ``b``
    2 apart on the x axis, ``c`` far off in the north-west corner."""
    return mission(
        horizon=2,
        agents=[
            {"name": "a", "dynamics": "si", "initial_state": [0, 0]},
            {"name": "b", "dynamics": "si", "initial_state": [2, 0]},
            {"name": "c", "dynamics": "si", "initial_state": [-4.5, 4.5]},
        ],
        separation=separation,
    )


def test_pairs_meet_where_their_boxes_come_within_the_separation() -> None:
    # a and b touch from step 1; at step 2 a's box [-2, 2]^2 is 0.5 from c's along both axes
    assert meeting_steps(_three(0.5)) == {("a", "b"): (1, 2)}
    assert meeting_steps(_three(0.6)) == {("a", "b"): (1, 2), ("a", "c"): (2,)}


def test_without_a_separation_no_pair_needs_one() -> None:
    assert meeting_steps(_three(None)) == {}


def test_given_boxes_are_used() -> None:
    problem = _three(0.5)
    boxes = reachable_boxes(problem)
    lo, hi = boxes["b"]
    boxes["b"] = (lo + 10, hi + 10)  # b moved out of everyone's way
    assert meeting_steps(problem, boxes) == {}


@pytest.mark.parametrize("name", ["crowd/crowd-16", "farm"])
def test_in_a_crowd_and_on_the_farm_every_pair_can_meet(name: str) -> None:
    problem = load_problem(MISSIONS / f"{name}.yaml")
    n = len(problem.agents)
    found = meeting_steps(problem)
    assert len(found) == n * (n - 1) // 2
    assert all(0 not in steps for steps in found.values())  # the starts keep the separation
