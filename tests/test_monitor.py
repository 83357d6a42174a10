"""The independent monitor: known answers on hand-built trajectories, and a brute-force oracle."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Mapping

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stlplan.errors import TrajectoryError
from stlplan.formula.boundary import HOLDS_AT
from stlplan.formula.parser import to_text
from stlplan.formula.tree import (
    Always,
    And,
    Eventually,
    Formula,
    InRegion,
    Interval,
    Linear,
    Not,
    Or,
    Term,
    Until,
    horizon,
)
from stlplan.mission.loader import load_problem
from stlplan.monitor.verdicts import check
from stlplan.result import Trajectory
from tests.helpers.maps import AVOID, BOXES, Path2, make_problem, walk
from tests.helpers.paths import FARM


def stay(point: tuple[float, float], steps: int) -> list[tuple[float, float]]:
    return [point] * steps


# --- ordinary tasks --------------------------------------------------------------------------


REACH = {"reach": {"formula": "F[0,3] G[0,2] in(p, R)", "roles": {"p": "V"}}}


def test_task_satisfied_with_the_margin_of_its_best_window() -> None:
    # margins in R: (2.5,3) 0.5, (3,3) 1, (3.2,3) 0.8; the window from step 2 keeps 1
    path = [(1, 1), (2.5, 3), (3, 3), (3, 3), (3, 3), (3.2, 3), (5, 5), (5, 5), (5, 5), (5, 5)]
    problem = make_problem({"a": path}, {"a": "V"}, REACH)
    verdict = check(problem, walk({"a": path})).verdict("reach")
    assert verdict.kind == "task"
    assert verdict.satisfied
    assert verdict.robustness == pytest.approx(1.0)
    assert verdict.group == (("a",),)
    assert "holds with margin 1" in verdict.detail


@pytest.mark.parametrize(
    ("step4", "satisfied", "rho"), [((3, 3), True, 1.0), ((4.5, 3), False, -0.5)]
)
def test_leaving_the_region_one_step_early_fails(
    step4: tuple[float, float], satisfied: bool, rho: float
) -> None:
    # F[0,2] G[0,2]: the last window is steps 2..4; leaving at step 4 (margin -0.5) breaks it
    path = [(0, 3), (1, 3), (3, 3), (3, 3), step4] + stay((4.5, 3), 5)
    tasks = {"stay": {"formula": "F[0,2] G[0,2] in(p, R)", "roles": {"p": "V"}}}
    problem = make_problem({"a": path}, {"a": "V"}, tasks)
    verdict = check(problem, walk({"a": path})).verdict("stay")
    assert verdict.satisfied is satisfied
    assert verdict.robustness == pytest.approx(rho)


def test_best_group_is_named() -> None:
    # only b and c reach R: the group of two is (b), (c)
    inside, outside = stay((3, 3), 5), stay((9, 9), 5)
    paths = {"a": outside, "b": inside, "c": [(3.5, 3)] * 5}
    tasks = {"pair": {"formula": "in(p, R)", "count": 2, "roles": {"p": "V"}}}
    problem = make_problem(paths, dict.fromkeys(paths, "V"), tasks)
    verdict = check(problem, walk(paths)).verdict("pair")
    assert verdict.satisfied
    assert verdict.group == (("b",), ("c",))
    assert verdict.robustness == pytest.approx(0.5)
    assert verdict.detail == "group (b), (c) holds with margin 0.5"


def test_failing_task_names_its_best_group() -> None:
    paths = {"a": stay((9, 9), 3), "b": stay((4.3, 3), 3)}
    tasks = {"pair": {"formula": "in(p, R)", "count": 2, "roles": {"p": "V"}}}
    problem = make_problem(paths, dict.fromkeys(paths, "V"), tasks)
    verdict = check(problem, walk(paths)).verdict("pair")
    assert not verdict.satisfied
    assert verdict.robustness == pytest.approx(-5.0)
    assert verdict.detail == "no group satisfies: best (a), (b) reaches -5"


# --- multi-agent predicates and until ---------------------------------------------------------


def test_distance_between_two_roles() -> None:
    # inf-norm distances 0.5, 0.8, 0.3 between p and q: margin 1 - 0.8 = 0.2
    paths = {"u": [(1, 1), (1, 1), (2, 2)], "w": [(1.5, 1.2), (1.8, 1), (2, 2.3)]}
    tasks = {"near": {"formula": "G[0,2] dist(p, q) <= 1", "roles": {"p": "U", "q": "W"}}}
    problem = make_problem(paths, {"u": "U", "w": "W"}, tasks)
    verdict = check(problem, walk(paths)).verdict("near")
    assert verdict.satisfied
    assert verdict.robustness == pytest.approx(0.2)
    assert verdict.group == (("u", "w"),)
    far = make_problem(
        paths,
        {"u": "U", "w": "W"},
        {"far": {"formula": "dist(p, q) >= 1", "roles": {"p": "U", "q": "W"}}},
    )
    assert check(far, walk(paths)).verdict("far").robustness == pytest.approx(-0.5)


def test_linear_inequality_over_two_roles() -> None:
    # p.x[0] - q.x[1] >= 1 at step 0 with p = (5, 0), q = (0, 3.5): value 1.5 - 1 = 0.5
    paths = {"u": [(5, 0), (5, 0)], "w": [(0, 3.5), (0, 3.5)]}
    tasks = {"lead": {"formula": "p.x[0] - q.x[1] >= 1", "roles": {"p": "U", "q": "W"}}}
    problem = make_problem(paths, {"u": "U", "w": "W"}, tasks)
    assert check(problem, walk(paths)).verdict("lead").robustness == pytest.approx(0.5)
    swapped = {"lead": {"formula": "p.x[0] - q.x[1] >= 1", "roles": {"p": "W", "q": "U"}}}
    problem = make_problem(paths, {"u": "U", "w": "W"}, swapped)
    assert check(problem, walk(paths)).verdict("lead").robustness == pytest.approx(-1.0)


@pytest.mark.parametrize(("x3", "rho"), [(4.0, 1.0), (5.5, -0.5)])
def test_until_needs_the_left_side_at_both_ends(x3: float, rho: float) -> None:
    # left 5 - x0: 4, 3, 2, 5 - x3; right x1 - 2: -2, -2, -1, 1. At k' = 3 both must hold.
    path = [(1, 0), (2, 0), (3, 1), (x3, 3), (6, 3)]
    tasks = {"wait": {"formula": "p.x[0] <= 5 U[1,3] p.x[1] >= 2", "roles": {"p": "V"}}}
    problem = make_problem({"a": path}, {"a": "V"}, tasks)
    verdict = check(problem, walk({"a": path})).verdict("wait")
    assert verdict.robustness == pytest.approx(rho)
    assert verdict.satisfied is (rho >= 0)


# --- synchronous tasks (DESIGN 2.1) -----------------------------------------------------------

SYNC = {
    "sync": {
        "formula": "in(p, C)",
        "count": 2,
        "roles": {"p": "Vis"},
        "synchronous": {"within": [3, 7], "hold": 1},
    }
}
CENTER, AWAY = (7.0, 7.0), (1.0, 1.0)


def in_c(steps: range, point: tuple[float, float] = CENTER, horizon: int = 9) -> Path2:
    return [point if k in steps else AWAY for k in range(horizon + 1)]


def sync_verdict(paths: Mapping[str, Path2]):  # type: ignore[no-untyped-def]
    problem = make_problem(paths, dict.fromkeys(paths, "Vis"), SYNC)
    return check(problem, walk(paths)).verdict("sync")


def test_paper_case_one_run_of_seven_gives_rho_s_five() -> None:
    verdict = sync_verdict(
        {"v1": in_c(range(3, 10)), "v2": in_c(range(3, 10)), "v3": in_c(range(0))}
    )
    assert verdict.kind == "synchronous"
    assert (verdict.run_start, verdict.run_length, verdict.rho_s) == (3, 7, 5.0)
    assert verdict.satisfied
    assert verdict.group == (("v1",), ("v2",))
    assert verdict.robustness == pytest.approx(1.0)
    assert "7 steps from step 3" in verdict.detail


@pytest.mark.parametrize(
    ("steps1", "steps2", "start", "length", "rho_s"),
    [
        (range(4, 6), range(4, 6), 4, 2, 0.0),  # exactly d + 1 = 2 steps together: G[0,1] holds
        (range(4, 6), range(5, 7), 5, 1, -1.0),  # together at step 5 only
        (range(1, 5), range(0, 5), 3, 2, 0.0),  # the run began before a = 3: counted from 3
        (range(6, 10), range(6, 10), 6, 4, 2.0),  # runs may go past b = 7 up to H
        (range(0), range(0), 3, 0, -2.0),  # never together
    ],
)
def test_synchronous_run_counting(
    steps1: range, steps2: range, start: int, length: int, rho_s: float
) -> None:
    verdict = sync_verdict({"v1": in_c(steps1), "v2": in_c(steps2)})
    assert (verdict.run_start, verdict.run_length, verdict.rho_s) == (start, length, rho_s)
    assert verdict.satisfied is (rho_s >= 0)


def test_synchronous_ties_prefer_the_earliest_start() -> None:
    # (v1, v2) together at 5..6 and (v1, v3) at 3..4: equal runs, the earlier one is reported
    paths = {"v1": in_c(range(3, 7)), "v2": in_c(range(5, 7)), "v3": in_c(range(3, 5))}
    verdict = sync_verdict(paths)
    assert verdict.group == (("v1",), ("v3",))
    assert (verdict.run_start, verdict.run_length) == (3, 2)


def test_synchronous_ties_then_prefer_spatial_robustness() -> None:
    # all three in C at 3..4; v1 only 0.2 inside, so (v2, v3) has the better margin
    edge = (6.2, 7.0)
    paths = {"v1": in_c(range(3, 5), edge), "v2": in_c(range(3, 5)), "v3": in_c(range(3, 5))}
    verdict = sync_verdict(paths)
    assert verdict.group == (("v2",), ("v3",))
    assert verdict.robustness == pytest.approx(1.0)


def test_synchronous_failure_names_the_best_group() -> None:
    verdict = sync_verdict({"v1": in_c(range(4, 6)), "v2": in_c(range(5, 7))})
    assert not verdict.satisfied
    assert "best (v1), (v2) for 1 from step 5, rho_s = -1" in verdict.detail


# --- constraints, separation, dynamics -------------------------------------------------------


def test_constraint_fails_for_the_agent_that_enters() -> None:
    paths = {"a": stay((1, 1), 4), "b": [(1, 3), (2.5, 3), (1, 3), (1, 3)]}
    problem = make_problem(paths, dict.fromkeys(paths, "V"), constraints=AVOID)
    verdict = check(problem, walk(paths)).verdict("avoid")
    assert verdict.kind == "constraint"
    assert not verdict.satisfied
    assert verdict.robustness == pytest.approx(-0.5)
    assert "worst p=b" in verdict.detail


def test_separation_names_the_closest_pair_and_step() -> None:
    paths = {"a": stay((1, 1), 6), "b": stay((5, 5), 6), "c": [(5, 1)] * 4 + [(1.03, 1.01), (5, 1)]}
    problem = make_problem(paths, dict.fromkeys(paths, "V"), separation=0.05)
    verdict = check(problem, walk(paths)).verdict("separation")
    assert not verdict.satisfied
    assert verdict.robustness == pytest.approx(-0.02)
    assert "a and c at step 4" in verdict.detail
    ok = make_problem(paths, dict.fromkeys(paths, "V"), separation=0.01)
    assert check(ok, walk(paths)).verdict("separation").satisfied


def test_report_without_separation_has_no_separation_verdict() -> None:
    paths = {"a": stay((1, 1), 3)}
    report = check(make_problem(paths, {"a": "V"}), walk(paths))
    assert [v.kind for v in report.verdicts] == ["dynamics"]
    assert report.satisfied


def test_dynamics_violation_is_located() -> None:
    paths = {"a": [(1.0, 1.0), (2.0, 1.0), (3.0, 1.0), (4.0, 1.0)]}
    traj = walk(paths)
    traj.states["a"][2, 0] += 0.5  # x(2) no longer equals x(1) + u(1), nor x(3) = x(2) + u(2)
    problem = make_problem(paths, {"a": "V"})
    verdict = check(problem, traj).verdict("dynamics a")
    assert verdict.kind == "dynamics"
    assert not verdict.satisfied
    assert verdict.robustness == pytest.approx(-0.5)
    assert verdict.detail.startswith("a step 2: x[0] = 3.5, expected A x(k) + B u(k) = 3")


def test_dynamics_initial_state_and_bounds() -> None:
    paths = {"a": [(1.0, 1.0), (7.0, 1.0), (7.0, 1.0)]}  # u(0) = 6 > 5
    problem = make_problem(paths, {"a": "V"})
    verdict = check(problem, walk(paths)).verdict("dynamics a")
    assert not verdict.satisfied
    assert verdict.robustness == pytest.approx(-1.0)
    assert "u[0] = 6, expected within [-5, 5]" in verdict.detail
    moved = walk({"a": [(1.2, 1.0), (1.2, 1.0), (1.2, 1.0)]})
    verdict = check(make_problem({"a": [(1, 1)] * 3}, {"a": "V"}), moved).verdict("dynamics a")
    assert "step 0: x[0] = 1.2, expected the initial state 1" in verdict.detail


def test_dynamics_tolerance_accepts_solver_noise() -> None:
    paths = {"a": [(1.0, 1.0), (5.0, 1.0), (10.0, 1.0)]}  # u(1) = 5 and x(2) = 10 on their bounds
    problem = make_problem(paths, {"a": "V"})
    traj = walk(paths)
    traj.states["a"][0, 0] += 1e-8
    traj.inputs["a"][1, 0] += 1e-7
    traj.states["a"][2, 0] += 2e-7
    assert check(problem, traj).verdict("dynamics a").satisfied
    traj.states["a"][2, 0] += 1e-3
    verdict = check(problem, traj).verdict("dynamics a")
    assert not verdict.satisfied
    assert verdict.robustness == pytest.approx(-1e-3, rel=1e-3)


def test_trajectory_that_does_not_fit_is_rejected() -> None:
    paths = {"a": stay((1, 1), 4)}
    problem = make_problem(paths, {"a": "V"})
    with pytest.raises(TrajectoryError, match="horizon"):
        check(problem, walk({"a": stay((1, 1), 3)}))
    with pytest.raises(TrajectoryError, match="agent 'a'"):
        check(problem, walk({"b": stay((1, 1), 4)}))


# --- the farm mission ------------------------------------------------------------------------


def test_farm_agents_that_stay_home_fail_every_task() -> None:
    problem = load_problem(FARM)
    H = problem.horizon
    traj = Trajectory(
        H,
        {a.name: np.tile(a.initial_state, (H + 1, 1)) for a in problem.agents},
        {a.name: np.zeros((H, a.m)) for a in problem.agents},
    )
    report = check(problem, traj)
    tasks = [v for v in report.verdicts if v.kind in ("task", "synchronous")]
    assert [v.name for v in tasks] == [t.name for t in problem.tasks]
    assert not any(v.satisfied for v in tasks)
    assert all(v.robustness < 0 for v in tasks)
    assert report.verdict("crop_C").rho_s == -2.0
    assert report.verdict("avoid_obstacle").satisfied
    assert report.verdict("separation").satisfied
    assert all(v.satisfied for v in report.verdicts if v.kind == "dynamics")
    assert not report.satisfied


def test_monitor_does_not_import_the_solver() -> None:
    code = (
        "import sys, stlplan.monitor.verdicts\n"
        "bad = [m for m in sys.modules if m.split('.')[0] in ('pyomo', 'highspy')"
        " or m.startswith('stlplan.planner.encoding') or m == 'stlplan.planner.solve']\n"
        "print(','.join(bad))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


# --- property: the monitor against a brute-force evaluator -----------------------------------


def atom_value(atom: Formula, x: np.ndarray, k: int) -> float:
    """Robustness of a surface atom of role p straight from its definition."""
    if isinstance(atom, InRegion):
        (xl, xh), (yl, yh) = BOXES[atom.region]
        return min(x[k][0] - xl, xh - x[k][0], x[k][1] - yl, yh - x[k][1])
    assert isinstance(atom, Linear)
    total = sum(t.coef * x[k][t.component] for t in atom.terms)
    return total - atom.bound if atom.op == ">=" else atom.bound - total


def brute(f: Formula, x: np.ndarray, k: int) -> float:
    """Recursive robustness of ``f`` at step ``k`` with plain loops."""
    if isinstance(f, Not):
        return -atom_value(f.atom, x, k)
    if isinstance(f, (InRegion, Linear)):
        return atom_value(f, x, k)
    if isinstance(f, And):
        return min(brute(c, x, k) for c in f.children)
    if isinstance(f, Or):
        return max(brute(c, x, k) for c in f.children)
    if isinstance(f, (Always, Eventually)):
        values = [brute(f.child, x, j) for j in range(k + f.interval.lo, k + f.interval.hi + 1)]
        return min(values) if isinstance(f, Always) else max(values)
    assert isinstance(f, Until)
    best = -float("inf")
    for j in range(k + f.interval.lo, k + f.interval.hi + 1):
        # the paper's U: left on [k, j]; the strict U* (stlpy, RTAMT): left on [k, j)
        last = j - 1 if f.strict else j
        left = min((brute(f.left, x, i) for i in range(k, last + 1)), default=float("inf"))
        best = max(best, min(brute(f.right, x, j), left))
    return best


def surface_formulas() -> st.SearchStrategy[Formula]:
    coef = st.sampled_from([-2.0, -1.0, 0.5, 1.0, 3.0])
    linear = st.builds(
        Linear,
        st.tuples(st.builds(Term, coef, st.just("p"), st.integers(0, 1))),
        st.sampled_from(["<=", ">="]),
        st.sampled_from([-1.0, 0.0, 2.5, 4.0, 7.0]),
    )
    atom = st.one_of(st.builds(InRegion, st.just("p"), st.sampled_from(["R", "C"])), linear)
    leaf = st.one_of(atom, st.builds(Not, atom))
    interval = st.tuples(st.integers(0, 2), st.integers(0, 2)).map(
        lambda t: Interval(min(t), max(t))
    )

    def extend(inner: st.SearchStrategy[Formula]) -> st.SearchStrategy[Formula]:
        pair = st.tuples(inner, inner)
        return st.one_of(
            pair.map(lambda c: And(c)),
            pair.map(lambda c: Or(c)),
            st.builds(Always, interval, inner),
            st.builds(Eventually, interval, inner),
            st.builds(Until, interval, inner, inner, st.booleans()),
        )

    return st.recursive(leaf, extend, max_leaves=5)


@settings(max_examples=60, deadline=None)
@given(formula=surface_formulas(), data=st.data())
def test_monitor_matches_brute_force(formula: Formula, data: st.DataObject) -> None:
    H = horizon(formula) + data.draw(st.integers(0, 2))
    points = st.tuples(st.floats(0, 10, allow_nan=False), st.floats(0, 10, allow_nan=False))
    path = data.draw(st.lists(points, min_size=H + 1, max_size=H + 1))
    if H == 0:
        path = path + path  # the schema needs H >= 1
    tasks = {"phi": {"formula": to_text(formula), "roles": {"p": "V"}}}
    problem = make_problem({"a": path}, {"a": "V"}, tasks)
    verdict = check(problem, walk({"a": path})).verdict("phi")
    expected = brute(formula, np.array(path), 0)
    assert verdict.robustness == pytest.approx(expected, abs=1e-9)
    assert verdict.satisfied is bool(expected >= HOLDS_AT)


def test_a_run_past_gamma_is_counted_up_to_gamma_and_says_so() -> None:
    paths = {"v1": in_c(range(3, 10)), "v2": in_c(range(3, 10))}
    capped = {"sync": {**SYNC["sync"], "synchronous": {"within": [3, 7], "hold": 1, "gamma": 2}}}
    verdict = check(make_problem(paths, dict.fromkeys(paths, "Vis"), capped), walk(paths)).verdict(
        "sync"
    )
    assert (verdict.rho_s, verdict.counted) == (5.0, 2.0)
    assert "rho_s = 5, counted up to gamma = 2" in verdict.detail
    uncapped = sync_verdict(paths)  # the mission's gamma, 8 by default
    assert (uncapped.rho_s, uncapped.counted) == (5.0, 5.0)
    assert "counted up to" not in uncapped.detail
