"""Safety between steps: the exact segment robustness, the monitor's verdicts and the planner."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from stlplan.mission.problem import Problem
from stlplan.monitor.crossings import crossing_segments, segment_floor, separation_segments
from stlplan.monitor.verdicts import check
from stlplan.outputs.plots import plan_figure
from stlplan.planner.config import PlannerConfig
from stlplan.planner.solve import plan
from stlplan.result import PlanStatus
from tests.helpers.maps import AVOID, make_problem, walk
from tests.helpers.missions import mission, swap_problem

finite = st.floats(-10, 10, allow_nan=False)


@settings(max_examples=200, derandomize=True, deadline=None)
@given(arrays(float, (2, 4), elements=finite))
def test_segment_floor_is_the_minimum_over_the_segment(ends: np.ndarray) -> None:
    a, b = ends
    s = np.linspace(0.0, 1.0, 20001)[:, None]
    dense = float(np.min(np.max((1 - s) * a + s * b, axis=1)))
    exact = float(segment_floor(a, b))
    # exact is attained on the segment, and no sampled point lies below it
    assert exact <= dense + 1e-9
    assert exact >= dense - 20 * 1e-4 * float(np.max(np.abs(b - a)))


def test_segment_floor_of_a_corner_cut() -> None:
    # outside the box [-1, 1]^2 (x - 1, -x - 1, y - 1, -y - 1 >= 0 for one), from (-2, 0) to
    # (0, 1.5): both ends outside, the segment reaches (-6/7, 6/7), 1/7 deep, at s = 4/7
    a = np.array([-3.0, 1.0, -1.0, -1.0])
    b = np.array([-1.0, -1.0, 0.5, -2.5])
    assert float(segment_floor(a, b)) == pytest.approx(-1 / 7)
    assert max(a) > 0 and max(b) > 0


def test_a_path_that_cuts_a_corner_fails_between_its_safe_steps() -> None:
    # R is [2, 4]^2; (1, 3) -> (3, 4.5) keeps both ends outside but cuts the corner (2, 4),
    # reaching 1/7 inside at s = 4/7
    paths = {"a": [(1, 3), (3, 4.5), (5, 5), (5, 5)]}
    problem = make_problem(paths, {"a": "V"}, constraints=AVOID)
    verdict = check(problem, walk(paths)).verdict("avoid")
    assert not verdict.satisfied
    assert verdict.robustness == pytest.approx(-1 / 7)
    assert "on the segment 0 -> 1" in verdict.detail
    sampled = problem.with_inter_sample(False)
    assert check(sampled, walk(paths)).verdict("avoid").satisfied


def test_a_corner_passed_outside_is_accepted() -> None:
    # (1, 4.5) -> (2.5, 5) stays above the box: the exact check accepts it
    paths = {"a": [(1, 4.5), (2.5, 5), (5, 5), (5, 5)]}
    problem = make_problem(paths, {"a": "V"}, constraints=AVOID)
    assert check(problem, walk(paths)).verdict("avoid").satisfied


def test_two_agents_passing_through_each_other_between_steps() -> None:
    # a and b trade places; at every step they are 1 apart, between steps 1 and 2 they meet
    paths = {"a": [(1, 1), (2, 1), (3, 2), (3, 3)], "b": [(3, 2), (3, 1), (2, 1), (1, 1)]}
    problem = make_problem(paths, dict.fromkeys(paths, "V"), separation=0.5)
    verdict = check(problem, walk(paths)).verdict("separation")
    assert not verdict.satisfied
    assert "a and b on the segment 1 -> 2" in verdict.detail
    assert check(problem.with_inter_sample(False), walk(paths)).verdict("separation").satisfied


def test_separation_segments_match_the_dense_minimum() -> None:
    rng = np.random.default_rng(3)
    positions = rng.uniform(0, 3, size=(4, 6, 2))
    exact = separation_segments(positions, 0.5)
    s = np.linspace(0, 1, 5001)[:, None, None]
    for p in range(4):
        for q in range(p + 1, 4):
            rel = positions[p] - positions[q]
            path = (1 - s) * rel[None, :-1] + s * rel[None, 1:]  # (S, H, 2)
            dense = np.min(np.max(np.abs(path), axis=2), axis=0) - 0.5
            assert np.allclose(exact[p, q], dense, atol=2e-3)
            assert np.all(exact[p, q] <= dense + 1e-9)


def corner_problem(horizon: int, inter_sample: bool) -> Problem:
    # from (0, 0) to x = 2 at step H past Obs = [0.55, 1.45] x [-2, 0.5], |u| <= 1 per axis
    return mission(
        horizon=horizon,
        safety={"inter_sample": inter_sample},
        agents=[{"name": "a", "dynamics": "si", "initial_state": [0, 0]}],
        regions={
            "Goal": {"box": [[1.9, 2.1], [-0.1, 0.1]]},
            "Obs": {"box": [[0.55, 1.45], [-2, 0.5]]},
        },
        tasks={
            "reach": {
                "formula": f"F[{horizon},{horizon}] in(p, Goal)",
                "roles": {"p": {"agent": "a"}},
            }
        },
        constraints={"avoid": {"formula": f"G[0,{horizon}] !in(p, Obs)", "for_each": "p"}},
        objective={"beta": 1.0, "effort": "l1"},
    )


def test_a_sampled_plan_cuts_the_corner_a_safe_one_goes_around() -> None:
    options = PlannerConfig().with_overrides({"solver.time_limit": 60.0})
    # in two steps the middle one must sit above Obs with x near 1: the way there cuts the corner
    sampled = plan(corner_problem(2, inter_sample=False), options)
    assert sampled.status is PlanStatus.OPTIMAL and sampled.trajectory is not None
    verdict = check(corner_problem(2, inter_sample=True), sampled.trajectory).verdict("avoid")
    assert not verdict.satisfied and "on the segment 0 -> 1" in verdict.detail
    assert plan(corner_problem(2, inter_sample=True), options).status is PlanStatus.INFEASIBLE
    for lazy in (True, False):
        safe = plan(
            corner_problem(3, inter_sample=True),
            PlannerConfig().with_overrides({"solver.time_limit": 60.0, "lazy.enabled": lazy}),
        )
        assert safe.status is PlanStatus.OPTIMAL and safe.trajectory is not None
        assert check(corner_problem(3, inter_sample=True), safe.trajectory).satisfied


@pytest.mark.parametrize("lazy", [True, False])
def test_the_planner_keeps_agents_apart_between_steps(lazy: bool) -> None:
    problem = swap_problem(separation=0.5, horizon=4, inter_sample=True)
    result = plan(
        problem,
        PlannerConfig().with_overrides(
            {"solver.time_limit": 60.0, "lazy.enabled": lazy, "model.floors": False}
        ),
    )
    assert result.status is PlanStatus.OPTIMAL
    assert result.trajectory is not None
    assert check(problem, result.trajectory).satisfied
    sampled = plan(
        problem.with_inter_sample(False),
        PlannerConfig().with_overrides({"solver.time_limit": 60.0, "lazy.enabled": lazy}),
    )
    assert sampled.objective is not None and result.objective is not None
    assert sampled.objective >= result.objective - 1e-6


def test_crossing_segments_name_the_agents_and_steps() -> None:
    paths = {"a": [(1, 1), (2, 1), (3, 2), (3, 3)], "b": [(3, 2), (3, 1), (2, 1), (1, 1)]}
    problem = make_problem(paths, dict.fromkeys(paths, "V"), separation=0.5)
    assert crossing_segments(problem, walk(paths)) == [("a", 1), ("b", 1)]
    assert crossing_segments(problem.with_inter_sample(False), walk(paths)) == []
    corner = {"a": [(1, 3), (3, 4.5), (5, 5), (5, 5)]}
    cut = make_problem(corner, {"a": "V"}, constraints=AVOID)
    assert crossing_segments(cut, walk(corner)) == [("a", 0)]


def test_the_map_marks_crossings_in_red() -> None:
    corner = {"a": [(1, 3), (3, 4.5), (5, 5), (5, 5)]}
    problem = make_problem(corner, {"a": "V"}, constraints=AVOID)
    trajectory = walk(corner)
    figure = plan_figure(problem, trajectory, check(problem, trajectory))
    legend = figure.axes[0].get_legend()
    assert "unsafe between steps" in [t.get_text() for t in legend.get_texts()]
    red = [ln for ln in figure.axes[0].lines if ln.get_color() == "#d62728"]
    assert len(red) == 1 and np.allclose(red[0].get_xydata(), [(1, 3), (3, 4.5)])
    safe = problem.with_inter_sample(False)
    figure = plan_figure(safe, trajectory, check(safe, trajectory))
    assert not [ln for ln in figure.axes[0].lines if ln.get_color() == "#d62728"]


def test_check_draws_the_trajectory_it_judges(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from stlplan.cli import app

    out = tmp_path / "map.png"
    csv = tmp_path / "crossing.csv"
    csv.write_text(
        "agent,k,x0,x1,u0,u1\n"
        + "".join(
            f"a,{k},{x},{y},{dx},{dy}\n"
            for k, (x, y, dx, dy) in enumerate([(0, 0, 1, 0.6), (1, 0.6, 1, -0.6), (2, 0, "", "")])
        ),
        encoding="utf-8",
    )
    mission_file = tmp_path / "corner.yaml"
    mission_file.write_text(CORNER_YAML, encoding="utf-8")
    found = CliRunner().invoke(app, ["check", str(mission_file), str(csv), "--plot", str(out)])
    assert found.exit_code == 1, found.output
    assert "on the segment" in found.output.replace("\n", " ")
    assert out.stat().st_size > 10_000
    sampled = CliRunner().invoke(app, ["check", str(mission_file), str(csv), "--no-inter-sample"])
    assert sampled.exit_code == 0, sampled.output


CORNER_YAML = """
name: corner
horizon: 2
dynamics:
  si: {A: [[1, 0], [0, 1]], B: [[1, 0], [0, 1]], state_bounds: [[-5, 5], [-5, 5]],
       input_bounds: [[-1, 1], [-1, 1]]}
agents:
  - {name: a, dynamics: si, initial_state: [0, 0]}
regions:
  Goal: {box: [[1.9, 2.1], [-0.1, 0.1]]}
  Obs: {box: [[0.5, 1.5], [-2, 0.5]]}
tasks:
  reach: {formula: "F[2,2] in(p, Goal)", roles: {p: {agent: a}}}
constraints:
  avoid: {formula: "G[0,2] !in(p, Obs)", for_each: p}
"""
