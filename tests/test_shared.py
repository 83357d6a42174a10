"""Tasks that need the same agents at once: a conflict of two tasks found without solving."""

from __future__ import annotations

import numpy as np

from stlplan.analysis.diagnose import cheap_reasons
from stlplan.analysis.shared import Pin, pins
from stlplan.formula.parser import parse
from stlplan.mission.past import replanned
from stlplan.mission.problem import Problem
from stlplan.planner.overrides import Overrides
from stlplan.replanning import replan
from stlplan.result import PlanStatus, Trajectory
from tests.helpers.missions import mission
from tests.helpers.paths import DATA, MISSIONS

HOLD = "G[1,4] in(p, Hold)"


def _team(agents: int, hold: str = HOLD, visit: str = "F[0,4] G[0,1] in(p, Far)") -> Problem:
    """``agents`` workers start at x = 0; ``hold`` keeps two of them in Hold (x around 1) at
    steps 1..4, ``visit`` sends one to Far (x around -1) for two steps by step 5."""
    team = [
        {"name": f"w{i}", "dynamics": "si", "capabilities": ["W"], "initial_state": [0, i]}
        for i in range(agents)
    ]
    return mission(
        horizon=6,
        agents=team,
        regions={
            "Hold": {"box": [[0.5, 1.5], [-1, 4]]},
            "Far": {"box": [[-1.5, -0.5], [-1, 4]]},
        },
        tasks={
            "hold": {"formula": hold, "count": 2, "roles": {"p": "W"}},
            "visit": {"formula": visit, "roles": {"p": "W"}},
        },
        objective={"beta": 1.0, "effort": "l1"},
    )


def _still(problem: Problem) -> Trajectory:
    H = problem.horizon
    states = {a.name: np.tile(a.initial_state, (H + 1, 1)) for a in problem.agents}
    return Trajectory(H, states, {a.name: np.zeros((H, 2)) for a in problem.agents})


def test_a_tasks_pins_are_the_regions_its_always_conjuncts_keep_a_role_in() -> None:
    formula = parse("F[0,2] in(p, A) & G[2,7] (in(p, B) & in(q, B) & dist(p, q) <= 1)")
    assert list(pins(formula)) == [Pin("p", "B", 2, 7), Pin("q", "B", 2, 7)]
    assert list(pins(parse("F[0,3] G[0,2] in(p, B)"))) == []  # not at fixed steps
    assert list(pins(parse("G[0,3] (in(p, A) | in(p, B))"))) == []


def test_two_agents_held_leave_none_for_the_visit() -> None:
    reasons = cheap_reasons(_team(2))
    assert [(r.item, r.others) for r in reasons] == [("visit", ("hold",))]
    assert reasons[0].text == (
        "tasks 'hold' and 'visit' cannot be met together: 'hold' keeps 2 agent(s) of role 'p' "
        "in 'Hold' at steps 1..4; kept there, w0 and w1 cannot serve 'visit', so 0 agent(s) "
        "are left for it, 1 needed"
    )


def test_no_conflict_when_an_agent_is_left_or_the_visit_fits_after_the_hold() -> None:
    assert not cheap_reasons(_team(3))  # a third worker visits
    assert not cheap_reasons(_team(2, visit="F[0,5] G[0,1] in(p, Far)"))  # steps 5-6, after
    assert not cheap_reasons(_team(2, hold="F[0,1] G[0,3] in(p, Hold)"))  # no fixed steps


def test_an_agent_lost_makes_the_conflict_and_the_replan_drops_a_task_without_a_probe() -> None:
    problem = _team(3)
    executed = _still(problem)
    again = replanned(problem, executed, 0, lost=["w2"])
    assert [(r.item, r.others) for r in cheap_reasons(again)] == [("visit", ("hold",))]
    _, result = replan(problem, executed, 0, ["w2"], overrides=Overrides(time_limit=60))
    assert result.status is PlanStatus.DEGRADED
    assert len(result.dropped) == 1 and result.dropped[0].task in ("hold", "visit")
    assert "cannot be met together" in result.dropped[0].reason
    assert not any("diagnosis probe" in c.where for c in result.confirmations)
    assert result.report is not None
    failed = {v.name for v in result.report.verdicts if not v.satisfied}
    assert failed <= {d.task for d in result.dropped}


def test_a_pin_that_takes_none_of_the_second_tasks_agents_is_no_conflict_of_the_two() -> None:
    # Case I replanned at step 6 with uv2 lost and Obs closed: crop_B's two elements left both
    # need uv3 (crop_B is short of agents on its own), and crop_A1 only uv1 can serve; the pair
    # analysis blamed crop_A1, had no agent to name, and raised IndexError (a replan by a
    # deadline crashed)
    from stlplan.api import load_problem, read_trajectory_csv

    problem = load_problem(MISSIONS / "farm.yaml")
    past = read_trajectory_csv(problem, DATA / "farm-executed-0-6.csv", through=6)
    reasons = cheap_reasons(replanned(problem, past, 6, ["uv2"], ["Obs"]))
    assert not [r for r in reasons if r.others == ("crop_B",)]
