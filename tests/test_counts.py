"""Counts inside formulas (``count``) and totals over time (``visits``).

The monitor is checked against a hand-written evaluator on random walks over a grid, and the
planner's optimum against an enumeration of who does what on missions small enough to count by
hand: the cheapest agents to bring into a region, the cheapest agents to send out of it, and the
cheapest way to share entries among agents (a first entry costs the way in, each further one the
way out and back).
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stlplan.errors import FormulaError
from stlplan.formula.boundary import HOLDS_AT
from stlplan.formula.parser import parse, to_text
from stlplan.formula.tree import Count, Visits, Who
from stlplan.mission.problem import Problem
from stlplan.monitor.robustness import robustness
from stlplan.monitor.verdicts import check
from tests.helpers.dynamics import single_integrator
from tests.helpers.examples import examples
from tests.helpers.missions import mission
from tests.helpers.solving import ENCODINGS, solve

BOX = ((1.0, 3.0), (1.0, 3.0))
"""Region R of the monitor tests; grid cells have centres at 0.5, 1.5, ..., 4.5."""
TEAM = {"a": ["cam"], "b": ["cam"], "c": ["ground"]}
H = 6


def _problem(formula: str) -> Problem:
    agents = [
        {"name": n, "dynamics": "si", "capabilities": caps, "initial_state": [0.5, 0.5]}
        for n, caps in TEAM.items()
    ]
    (xl, xh), (yl, yh) = BOX
    return mission(
        horizon=H,
        agents=agents,
        regions={"R": {"box": [[xl, xh], [yl, yh]]}},
        tasks={"t": {"formula": formula}},
        dynamics={"si": single_integrator(5, ((0, 5), (0, 5)))},
    )


def _monitor(problem: Problem, states: dict[str, np.ndarray]) -> np.ndarray:
    task = problem.tasks[0]
    binding = task.binding(task.elements[0])
    signals = {role: states[agent] for role, agent in binding.items()}
    return robustness(problem.lowered(task.formula, binding), signals, H)


def _inside(point: np.ndarray) -> float:
    """The hand-written robustness of ``in(., R)``: the depth inside R (negative outside)."""
    (xl, xh), (yl, yh) = BOX
    return float(min(point[0] - xl, xh - point[0], point[1] - yl, yh - point[1]))


def _counted(who: Who) -> list[str]:
    return [n for n, caps in TEAM.items() if who.admits(frozenset(caps))]


def _count_by_hand(atom: Count, states: dict[str, np.ndarray], k: int) -> float:
    values = sorted((_inside(states[a][k]) for a in _counted(atom.who)), reverse=True)
    if atom.op == ">=":
        return values[atom.n - 1]
    # at most n inside: the (n+1)-th deepest must be outside
    return -values[atom.n]


def _entry(track: np.ndarray, t: int, first: int) -> float:
    inside = _inside(track[t])
    return inside if t == first else min(inside, -_inside(track[t - 1]))


def _visits_by_hand(atom: Visits, states: dict[str, np.ndarray], k: int) -> float:
    lo, hi = k + atom.interval.lo, k + atom.interval.hi
    entries = [_entry(states[a], t, lo) for a in _counted(atom.who) for t in range(lo, hi + 1)]
    values = sorted(entries, reverse=True)
    return values[atom.n - 1] if atom.op == ">=" else -values[atom.n]


cells = st.integers(0, 4).map(lambda i: i + 0.5)
walks = st.lists(st.tuples(cells, cells), min_size=H + 1, max_size=H + 1)


@settings(max_examples=examples(40, 400), deadline=None)
@given(
    walks=st.tuples(walks, walks, walks),
    n=st.integers(0, 1),
    op=st.sampled_from([">=", "<="]),
    who=st.sampled_from(["cam", "cam | ground", ""]),
)
def test_the_monitor_counts_as_a_hand_evaluator_does(
    walks: tuple[Any, ...], n: int, op: str, who: str
) -> None:
    """``count``: the n-th deepest agent's depth; ``<=``: minus the next one's."""
    states = {name: np.array(w) for name, w in zip(TEAM, walks, strict=True)}
    bound = n + 1 if op == ">=" else n
    text = f"count(R{', ' + who if who else ''}) {op} {bound}"
    atom = parse(text)
    assert isinstance(atom, Count)
    found = _monitor(_problem(f"G[0,{H}] ({text} | !({text}))"), states)
    rho = _monitor(_problem(text), states)
    assert len(found) == 1 and found[0] >= HOLDS_AT  # the formula and its negation are total
    for k in range(H + 1):
        by_hand = _count_by_hand(atom, states, k)
        inside = sum(_inside(states[a][k]) > 0 for a in _counted(atom.who))
        holds = inside >= atom.n if op == ">=" else inside <= atom.n
        assert (by_hand > 0) == holds
        assert rho[k] == pytest.approx(by_hand)


@settings(max_examples=examples(40, 400), deadline=None)
@given(
    walks=st.tuples(walks, walks, walks),
    window=st.tuples(st.integers(0, 3), st.integers(0, 3)),
    n=st.integers(1, 4),
    op=st.sampled_from([">=", "<="]),
)
def test_the_monitor_counts_visits_as_a_hand_evaluator_does(
    walks: tuple[Any, ...], window: tuple[int, int], n: int, op: str
) -> None:
    """``visits``: entries (outside at t-1, inside at t; inside at the window's first step)."""
    states = {name: np.array(w) for name, w in zip(TEAM, walks, strict=True)}
    lo, hi = min(window), max(window)
    most = len(TEAM) * ((hi - lo + 2) // 2)  # entries at most every other step
    n = min(n, most - 1 if op == "<=" else most)
    text = f"visits[{lo},{hi}](R, cam | ground) {op} {n}"
    atom = parse(text)
    assert isinstance(atom, Visits)
    rho = _monitor(_problem(text), states)
    assert len(rho) == H + 1 - hi
    for k in range(len(rho)):
        entered = 0
        for a in _counted(atom.who):
            inside = [_inside(p) > 0 for p in states[a]]
            entered += inside[k + lo]
            entered += sum(inside[t] and not inside[t - 1] for t in range(k + lo + 1, k + hi + 1))
        holds = entered >= n if op == ">=" else entered <= n
        by_hand = _visits_by_hand(atom, states, k)
        assert rho[k] == pytest.approx(by_hand)
        assert (by_hand > 0) == holds


def test_count_and_visits_read_and_print_back() -> None:
    for text in (
        "count(A, camera) >= 1",
        "count(B) <= 1",
        "count(A, UV & IR) >= 2",
        "visits[0,40](C, ground | aerial) >= 10",
        "G[0,30] F[0,10] count(A, camera) >= 1",
        "!(count(A, UV & IR) >= 2)",
    ):
        assert to_text(parse(text)) == text
    assert parse("count(A, UV and IR) >= 2") == parse("count(A, UV & IR) >= 2")
    with pytest.raises(FormulaError, match="whole number"):
        parse("count(A, cam) >= 1.5")
    with pytest.raises(FormulaError, match="reserved word"):
        parse("in(count, A)")


def test_a_task_that_only_counts_is_met_once() -> None:
    from stlplan.errors import MissionError

    with pytest.raises(MissionError, match=r"names no role.*found count 2, expected 1") as caught:
        _problem_with({"formula": "F[0,6] count(R, cam) >= 2", "count": 2})
    assert caught.value.where == "tasks.t.count"


def _problem_with(task: dict[str, Any]) -> Problem:
    agents = [
        {"name": n, "dynamics": "si", "capabilities": caps, "initial_state": [0.5, 0.5]}
        for n, caps in TEAM.items()
    ]
    return mission(
        horizon=H, agents=agents, regions={"R": {"box": [[1, 3], [1, 3]]}}, tasks={"t": task}
    )


def test_a_total_no_agent_can_reach_is_found_before_solving() -> None:
    """A visit to R within steps 0..1 while every agent starts 1.5 away at one unit a step."""
    from stlplan.analysis.diagnose import cheap_reasons

    far = _line_mission([0.0, 0.5], "visits[0,1](A, cam) >= 1")
    (reason,) = cheap_reasons(far)
    assert reason.item == "t"
    assert "no plan the dynamics and bounds allow" in reason.text
    assert "'visits[0,1](A, cam) >= 1'" in reason.text
    assert cheap_reasons(_line_mission([0.0, 1.5], "visits[0,1](A, cam) >= 1")) == ()


# -- the planner's optimum against an enumeration --------------------------------------------


def _line_mission(
    starts: list[float],
    task: str,
    constraints: dict[str, Any] | None = None,
    synchronous: dict[str, Any] | None = None,
    **fields: Any,
) -> Problem:
    """Agents on the line y = 0 (single integrators, |u| <= 1), region A = [2, 3] x [-1, 1];
    a task ``t`` whose formula names the role ``p`` (any agent) when it has one."""
    agents = [
        {"name": f"a{i}", "dynamics": "si", "capabilities": ["cam"], "initial_state": [x, 0.0]}
        for i, x in enumerate(starts)
    ]
    spec: dict[str, Any] = {"formula": task}
    if "(p," in task:
        spec |= {"roles": {"p": "cam"}, "count": len(starts)}
    if synchronous is not None:
        spec["synchronous"] = synchronous
    return mission(
        horizon=8,
        agents=agents,
        regions={"A": {"box": [[2, 3], [-1, 1]]}},
        tasks={"t": spec},
        constraints=constraints or {},
        objective={"beta": 1.0, "effort": "l1", "two_step": False, **fields},
        dynamics={"si": single_integrator(1, ((-1, 6), (-2, 2)))},
    )


def _effort(problem: Problem, encoding: str) -> float:
    result, _ = solve(problem, {"model.encoding": encoding})
    assert result.status == "optimal" and result.trajectory is not None
    assert check(problem, result.trajectory).satisfied
    inputs = result.trajectory.inputs
    return float(sum(np.abs(u).sum() for u in inputs.values()))


starts = st.lists(st.floats(-1.0, 1.5).map(lambda x: round(x, 2)), min_size=3, max_size=3)


@pytest.mark.parametrize("encoding", ENCODINGS)
@settings(max_examples=examples(4, 20), deadline=None)
@given(xs=starts)
def test_the_cheapest_agents_are_brought_in(encoding: str, xs: list[float]) -> None:
    """``F[3,3] count(A, cam) >= 2``: the two agents nearest A go in (cost: their distance)."""
    problem = _line_mission(xs, "F[3,3] count(A, cam) >= 2")
    ways = sorted(2 - x for x in xs)
    assert _effort(problem, encoding) == pytest.approx(ways[0] + ways[1], abs=1e-4)


@pytest.mark.parametrize("encoding", ENCODINGS)
@settings(max_examples=examples(4, 20), deadline=None)
@given(xs=st.lists(st.floats(2.1, 2.9).map(lambda x: round(x, 2)), min_size=3, max_size=3))
def test_the_cheapest_agents_are_sent_out(encoding: str, xs: list[float]) -> None:
    """``G[1,8] count(A) <= 1`` with every agent inside A: all but the one dearest to move
    leave by their nearer side."""
    problem = _line_mission(xs, "G[1,8] count(A, cam) <= 1")
    ways = sorted(min(x - 2, 3 - x) for x in xs)
    assert _effort(problem, encoding) == pytest.approx(ways[0] + ways[1], abs=1e-4)


def _entries_cost(ways: list[float], total: int, margin: float) -> float:
    """The cheapest share of ``total`` entries: an agent's first costs its way in plus the
    margin, each further one leaving and coming back (twice the margin each way)."""
    best = float("inf")
    for share in itertools.product(range(total + 1), repeat=len(ways)):
        if sum(share) != total:
            continue
        cost = sum(
            w + margin + 4 * margin * (n - 1) for w, n in zip(ways, share, strict=True) if n > 0
        )
        best = min(best, cost)
    return best


@pytest.mark.heavy
@pytest.mark.parametrize("encoding", ENCODINGS)
@settings(max_examples=examples(4, 20), deadline=None)
@given(xs=st.lists(st.floats(0.0, 1.5).map(lambda x: round(x, 2)), min_size=2, max_size=2))
def test_entries_are_shared_as_cheaply_as_an_enumeration_says(
    encoding: str, xs: list[float]
) -> None:
    """``visits[0,8](A, cam) >= 3`` kept with a margin of 0.2: each entry is a real one."""
    margin = 0.2
    problem = _line_mission(xs, "visits[0,8](A, cam) >= 3", margin={"minimum": margin})
    expected = _entries_cost([2 - x for x in xs], 3, margin)
    assert _effort(problem, encoding) == pytest.approx(expected, abs=1e-4)


def test_a_replan_counts_the_visits_already_made() -> None:
    """Two of three visits made by step 4: the replan from step 5 needs one more, and the
    cheapest is a0 stepping out and back in (4 margins), not three new entries."""
    from stlplan.replanning import replan
    from stlplan.result import Trajectory

    margin = 0.2
    problem = _line_mission([1.0, 0.0], "visits[0,8](A, cam) >= 3", margin={"minimum": margin})
    a0 = [1.0, 1.5, 2.2, 1.8, 2.2, 2.2, 2.2, 2.2, 2.2]  # enters at 2 and at 4
    states = {
        "a0": np.array([[x, 0.0] for x in a0]),
        "a1": np.zeros((9, 2)),
    }
    inputs = {name: np.diff(x, axis=0) for name, x in states.items()}
    again, result = replan(problem, Trajectory(8, states, inputs), 5)
    assert result.status == "optimal" and result.trajectory is not None
    assert check(again, result.trajectory).satisfied
    future = sum(float(np.abs(u[5:]).sum()) for u in result.trajectory.inputs.values())
    assert future == pytest.approx(4 * margin, abs=1e-4)


@pytest.mark.heavy
def test_a_closed_loop_run_replans_on_its_visits_and_is_judged_on_them() -> None:
    """Executed under a disturbance of 0.02 with a replan every step, plans robust to it (the
    margin kept where a step's disturbance cannot use it up), the run keeps its three visits
    (each replan counts those already made) and the monitor judges the executed run."""
    from stlplan.monitor.counts import entry_steps, inside_steps
    from stlplan.pipeline import plan
    from stlplan.planner.overrides import Overrides
    from stlplan.simulation.run import disturbances, execute, judge
    from stlplan.simulation.settings import Simulated

    problem = _line_mission([1.0, 0.5], "visits[0,8](A, cam) >= 3", margin={"minimum": 0.2})
    settings = Overrides(threads=1, time_limit=60, robust_to=0.02)
    first = plan(problem, settings)[1]
    simulated = Simulated(0.02, "every")
    run = execute(problem, first, settings, simulated, disturbances(problem, 0.02, 0, 0))
    assert len(run.replan_seconds) == problem.horizon - 1
    assert judge(problem, run.executed, simulated).satisfied
    visits = [
        t
        for agent in ("a0", "a1")
        for t in entry_steps(inside_steps(problem, run.executed, agent, "A"), 0, 8)
    ]
    assert len(visits) >= 3


@pytest.mark.parametrize("encoding", ENCODINGS)
def test_a_constraint_counts_and_a_synchronous_task_counts(encoding: str) -> None:
    """``G[0,8] count(A, cam) <= 1`` as a constraint (one agent in A at a time) while each of
    two agents must visit A: they take turns. A synchronous task whose phi is a count: two
    agents in A together for two steps, starting within [3, 6]."""
    turns = _line_mission(
        [1.0, 1.2],
        "F[0,8] in(p, A)",
        constraints={"one_at_a_time": {"formula": "G[0,8] count(A, cam) <= 1"}},
    )
    result, _ = solve(turns, {"model.encoding": encoding})
    assert result.trajectory is not None and check(turns, result.trajectory).satisfied
    inside = [(x[:, 0] > 2) & (x[:, 0] < 3) for x in result.trajectory.states.values()]
    assert all(row.any() for row in inside) and not (inside[0] & inside[1]).any()

    together = _line_mission(
        [1.0, 0.5], "count(A, cam) >= 2", synchronous={"within": [3, 6], "hold": 1}
    )
    result, _ = solve(together, {"model.encoding": encoding})
    assert result.trajectory is not None
    report = check(together, result.trajectory)
    assert report.satisfied and report.verdict("t").rho_s is not None
    assert report.verdict("t").rho_s >= 0
