"""Tests of the figures: plan.png and timeline.png for a hand-built farm plan (paper Case I), and
convergence.png for a hand-built record of incumbents and bounds."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest
import yaml
from matplotlib.patches import Polygon
from PIL import Image

from stlplan.mission.loader import load_problem
from stlplan.mission.problem import Problem, build_problem
from stlplan.mission.schema import Mission
from stlplan.monitor.verdicts import check as monitor_check
from stlplan.outputs.plots import (
    convergence_figure,
    obstacle_regions,
    plan_figure,
    plot_convergence,
    plot_plan,
    plot_timeline,
    polygon_area,
    region_vertices,
    sync_caption,
    task_presence,
    timeline_figure,
    workspace,
)
from stlplan.result import (
    ConvergencePoint,
    MonitorReport,
    PlanResult,
    PlanStatus,
    Trajectory,
    Verdict,
)
from tests.helpers.paths import FARM
from tests.helpers.plans import make_report, make_trajectory


@pytest.fixture(scope="module")
def farm() -> Problem:
    return load_problem(FARM)


@pytest.fixture(autouse=True)
def no_open_figures():
    yield
    assert plt.get_fignums() == []


def assert_png(path: Path, min_width: int = 800, min_height: int = 400) -> None:
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with Image.open(path) as image:
        image.verify()
    with Image.open(path) as image:
        width, height = image.size
        colors = image.convert("RGB").getcolors(maxcolors=1 << 20)
    assert width >= min_width and height >= min_height
    assert width < 4000 and height < 4000
    assert colors is not None and len(colors) > 50  # drawn, not blank
    assert path.stat().st_size > 20_000


def test_plot_plan_writes_a_png(farm: Problem, tmp_path: Path) -> None:
    target = tmp_path / "plan.png"
    plot_plan(farm, make_trajectory(farm), make_report(), target, title="farm: optimal")
    assert_png(target)
    assert [p.name for p in tmp_path.iterdir()] == ["plan.png"]  # no temporary file left


def test_plot_timeline_writes_a_png(farm: Problem, tmp_path: Path) -> None:
    target = tmp_path / "timeline.png"
    plot_timeline(farm, make_trajectory(farm), make_report(), target)
    assert_png(target, min_height=300)
    assert [p.name for p in tmp_path.iterdir()] == ["timeline.png"]


def test_saving_replaces_an_existing_file(farm: Problem, tmp_path: Path) -> None:
    target = tmp_path / "plan.png"
    target.write_bytes(b"old")
    plot_plan(farm, make_trajectory(farm), make_report(), target)
    assert_png(target)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plan.png"]


def test_failed_save_leaves_nothing(farm: Problem, tmp_path: Path) -> None:
    with pytest.raises(OSError):
        plot_plan(farm, make_trajectory(farm), make_report(), tmp_path / "missing" / "plan.png")
    assert list(tmp_path.iterdir()) == []


def test_region_vertices_of_a_triangle_clipped_by_the_workspace() -> None:
    # x >= 1, y >= 1, x + y <= 4 within [0, 7] x [0, 5]: the triangle (1,1), (3,1), (1,3)
    triangle = (((-1.0, 0.0), (0.0, -1.0), (1.0, 1.0)), (-1.0, -1.0, 4.0))
    vertices = region_vertices(triangle, ((0, 7), (0, 5)))
    assert {tuple(np.round(v, 9)) for v in vertices} == {(1.0, 1.0), (3.0, 1.0), (1.0, 3.0)}
    assert polygon_area(vertices) == pytest.approx(2.0)
    # the same half-planes within [0, 2] x [0, 5]: the corner (3, 1) is cut off at x = 2
    clipped = region_vertices(triangle, ((0, 2), (0, 5)))
    assert len(clipped) == 4
    assert polygon_area(clipped) == pytest.approx(2.0 - 0.5)
    # a region outside the workspace has no vertices
    assert region_vertices(triangle, ((5, 7), (4, 5))).shape == (0, 2)


def test_region_vertices_are_in_counter_clockwise_order() -> None:
    box = (((1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)), (2.0, -1.0, 3.0, -1.0))
    v = region_vertices(box, ((0, 7), (0, 5)))
    signed = np.dot(v[:, 0], np.roll(v[:, 1], -1)) - np.dot(np.roll(v[:, 0], -1), v[:, 1])
    assert len(v) == 4 and signed > 0


def polytope_problem() -> Problem:
    data = yaml.safe_load(FARM.read_text())
    # a diamond |x - 6| + |y - 2.5| <= 0.7 and a half-plane x + y >= 11 that the workspace clips
    data["regions"]["Diamond"] = {
        "G": [[1, 1], [1, -1], [-1, 1], [-1, -1]],
        "h": [9.2, 4.2, -2.8, -7.8],
    }
    data["regions"]["Corner"] = {"G": [[-1, -1]], "h": [-11]}
    data["tasks"]["inspect"] = {"formula": "F[0,9] in(p, Diamond)", "roles": {"p": "Vis"}}
    return build_problem(Mission.model_validate(data))


def test_plan_draws_polytope_regions(tmp_path: Path) -> None:
    problem = polytope_problem()
    report = MonitorReport(make_report().verdicts + (Verdict("inspect", "task", False, -1.0),))
    fig = plan_figure(problem, make_trajectory(problem), report)
    polygons = {
        round(polygon_area(p.get_xy()[:4]), 6)
        for p in fig.axes[0].patches
        if isinstance(p, Polygon)
    }
    assert round(0.7 * 0.7 * 2, 6) in polygons  # the diamond: diagonals 1.4, area 0.98
    assert round(0.5 * 1 * 1, 6) in polygons  # the corner triangle (6,5), (7,4), (7,5)
    plot_plan(problem, make_trajectory(problem), report, tmp_path / "plan.png")
    assert_png(tmp_path / "plan.png")


def test_every_region_is_drawn_and_named(farm: Problem) -> None:
    fig = plan_figure(farm, make_trajectory(farm), make_report())
    ax = fig.axes[0]
    assert sum(isinstance(p, Polygon) for p in ax.patches) == len(farm.regions)
    assert set(farm.regions) <= {t.get_text() for t in ax.texts}


def test_obstacles_are_the_regions_under_negation(farm: Problem) -> None:
    assert obstacle_regions(farm) == ("Obs",)
    fig = plan_figure(farm, make_trajectory(farm), make_report())
    hatched = [p for p in fig.axes[0].patches if isinstance(p, Polygon) and p.get_hatch()]
    assert len(hatched) == 1
    assert polygon_area(hatched[0].get_xy()[:4]) == pytest.approx(2.0 * 1.5)


def test_plan_shows_the_synchronized_run(farm: Problem) -> None:
    report = make_report()
    fig = plan_figure(farm, make_trajectory(farm), report, title="farm: optimal")
    texts = {t.get_text() for t in fig.axes[0].texts}
    assert "crop_C synchronized: steps 3-9 (run 7, rho_s = 5)" in texts
    assert fig.axes[0].get_title() == "farm: optimal"
    # one large marker per run step for each of the group's two agents
    big = [line for line in fig.axes[0].lines if line.get_markersize() >= 10]
    assert sorted(len(line.get_xdata()) for line in big) == [7, 7]


def test_sync_caption_without_a_run() -> None:
    verdict = Verdict(
        "crop_C",
        "synchronous",
        False,
        -1.0,
        group=(("vis1",),),
        rho_s=-2.0,
        run_start=None,
        run_length=0,
    )
    assert sync_caption(verdict) == "crop_C: no synchronized run (rho_s = -2)"


def test_workspace_comes_from_position_bounds(farm: Problem) -> None:
    assert workspace(farm) == ((0.0, 7.0), (0.0, 5.0))


def test_task_presence_follows_the_roles_regions(farm: Problem) -> None:
    trajectory, report = make_trajectory(farm), make_report()
    tasks = {t.name: t for t in farm.tasks}
    a1 = task_presence(farm, trajectory, tasks["crop_A1"], report.verdict("crop_A1"))
    assert sorted(a1["uv3"]) == [3, 4, 5]
    a2 = task_presence(farm, trajectory, tasks["crop_A2"], report.verdict("crop_A2"))
    assert sorted(a2["uv3"]) == [7, 8, 9]
    b = task_presence(farm, trajectory, tasks["crop_B"], report.verdict("crop_B"))
    assert set(b) == {"uv1", "ir1", "uv2", "ir2"}
    assert sorted(b["ir2"]) == list(range(2, 10))
    assert set(b["uv1"][2]) == {"B_start", "B"}
    assert set(b["uv1"][8]) == {"B_end"}  # inside B too, but G[2,7] in(p, B) ends at step 7
    c = task_presence(farm, trajectory, tasks["crop_C"], report.verdict("crop_C"))
    assert sorted(c["vis1"]) == sorted(c["vis2"]) == list(range(3, 10))


def _homecoming() -> tuple[Problem, Trajectory, MonitorReport]:
    """A robot that starts at Home and must be back there between steps 13 and 16, and a
    trajectory that never leaves Home."""
    mission = Mission.model_validate(
        {
            "name": "homecoming",
            "horizon": 18,
            "dynamics": {
                "si": {
                    "A": [[1, 0], [0, 1]],
                    "B": [[1, 0], [0, 1]],
                    "state_bounds": [[0, 10], [0, 10]],
                    "input_bounds": [[-1, 1], [-1, 1]],
                }
            },
            "agents": [{"name": "r", "dynamics": "si", "initial_state": [1, 1]}],
            "regions": {"Home": {"box": [[0, 2], [0, 2]]}},
            "tasks": {"home": {"formula": "F[13,16] in(p, Home)", "roles": {"p": {"agent": "r"}}}},
        }
    )
    problem = build_problem(mission)
    states = {"r": np.tile([1.0, 1.0], (19, 1))}
    trajectory = Trajectory(18, states, {"r": np.zeros((18, 2))})
    return problem, trajectory, monitor_check(problem, trajectory)


def test_a_bar_lies_within_its_formulas_window() -> None:
    problem, trajectory, report = _homecoming()
    assert report.satisfied
    steps = task_presence(problem, trajectory, problem.tasks[0], report.verdict("home"))
    assert sorted(steps["r"]) == [13, 14, 15, 16]  # at Home from step 0, read from 13 to 16
    ax = timeline_figure(problem, trajectory, report).axes[0]
    bars = [p for p in ax.patches if p.get_facecolor()[3] == 1 and p.get_width() < 18]
    assert len(bars) == 1
    assert bars[0].get_x() == pytest.approx(13 - 0.45) and bars[0].get_width() == pytest.approx(3.9)


def test_a_negated_region_serves_no_task() -> None:
    from stlplan.formula.parser import parse

    problem, trajectory, report = _homecoming()
    task = dataclasses.replace(problem.tasks[0], formula=parse("G[0,18] !in(p, Home)"))
    assert task_presence(problem, trajectory, task, report.verdict("home")) == {"r": {}}


def test_timeline_rows_and_shading(farm: Problem) -> None:
    fig = timeline_figure(farm, make_trajectory(farm), make_report())
    ax = fig.axes[0]
    rows = sorted(zip(ax.get_yticks(), ax.get_yticklabels(), strict=True), key=lambda r: -r[0])
    names = [a.name for a in farm.agents] + ["avoid_obstacle", "separation"]  # then the limits
    assert [label.get_text().split()[0] for _, label in rows] == names
    shaded = [p for p in ax.patches if p.get_hatch() == ".."]
    assert len(shaded) == 2 and all(p.get_width() == 7 for p in shaded)
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert [t.name for t in farm.tasks] == legend[: len(farm.tasks)]
    assert "crop_C synchronized: steps 3-9 (run 7, rho_s = 5)" in legend


def test_figures_without_verdicts_or_runs(farm: Problem, tmp_path: Path) -> None:
    failing = MonitorReport(
        (
            Verdict(
                "crop_C",
                "synchronous",
                False,
                -0.4,
                group=(("vis1",), ("vis3",)),
                rho_s=-2.0,
                run_start=None,
                run_length=0,
            ),
        )
    )
    fig = plan_figure(farm, make_trajectory(farm), failing)
    texts = {t.get_text() for t in fig.axes[0].texts}
    assert "crop_C: no synchronized run (rho_s = -2)" in texts
    assert "monitor: violated crop_C;  rho_s(Phi) = -2" in texts
    assert not [line for line in fig.axes[0].lines if line.get_markersize() >= 10]
    empty = MonitorReport(())
    timeline = timeline_figure(farm, make_trajectory(farm), empty)
    idle = [t for t in timeline.axes[0].texts if t.get_text() == "no task"]
    assert len(idle) == len(farm.agents)
    plot_plan(farm, make_trajectory(farm), empty, tmp_path / "plan.png")
    plot_timeline(farm, make_trajectory(farm), empty, tmp_path / "timeline.png")
    assert_png(tmp_path / "plan.png")
    assert_png(tmp_path / "timeline.png", min_height=300)


# ---------------------------------------------------------------------------- convergence.png
RECORD = (
    ConvergencePoint(3.4, None, 3.1839),
    ConvergencePoint(7.6, None, 3.1702),
    ConvergencePoint(20.0, 2.5, 3.1628),
    ConvergencePoint(24.0, 3.1627, 3.16281),
)
"""A run whose parts give the whole's bound at 3.4 s and whose first plan comes at 20 s."""


def test_plot_convergence_writes_a_png(farm: Problem, tmp_path: Path) -> None:
    target = tmp_path / "convergence.png"
    result = PlanResult(PlanStatus.OPTIMAL, "", convergence=RECORD, first_plan_seconds=20.0)
    plot_convergence(farm, result, target)
    assert_png(target, min_height=300)
    assert [p.name for p in tmp_path.iterdir()] == ["convergence.png"]
    with pytest.raises(ValueError, match="no convergence point"):
        plot_convergence(farm, PlanResult(PlanStatus.OPTIMAL, ""), tmp_path / "none.png")


def test_convergence_draws_the_incumbent_solid_the_bound_dashed_and_the_first_plan(
    farm: Problem,
) -> None:
    ax = convergence_figure(farm, RECORD, 20.0).axes[0]
    styles = {line.get_label(): line.get_linestyle() for line in ax.lines}
    assert styles["incumbent (a plan meeting every requirement)"] == "-"
    assert styles["bound (proven, upper)"] == "--"
    assert styles["first plan (20.0 s)"] == "None"  # a star alone
    star = next(line for line in ax.lines if line.get_label().startswith("first plan"))
    assert list(star.get_xdata()) == [20.0] and list(star.get_ydata()) == [2.5]
    incumbent = next(line for line in ax.lines if line.get_label().startswith("incumbent"))
    assert np.isnan(incumbent.get_ydata()[:2]).all()  # nothing drawn before the first plan
    subtitle = {t.get_text() for t in ax.texts}
    assert "final gap 0.00% (incumbent 3.1627, bound 3.16281) at 24.0 s" in subtitle
    assert ax.get_xlim()[0] == 0.0


def test_convergence_without_a_plan_draws_the_bound_and_says_why_it_starts_late(
    farm: Problem,
) -> None:
    record = (ConvergencePoint(38.4, None, 2.6196), ConvergencePoint(56.1, None, 2.6196))
    ax = convergence_figure(farm, record, None).axes[0]
    assert [line.get_label() for line in ax.lines if not line.get_label().startswith("_")] == [
        "bound (proven, upper)"
    ]
    texts = {t.get_text() for t in ax.texts}
    assert "no plan, bound 2.6196 at 56.1 s" in texts
    assert "no plan or bound\nof the whole team\nbefore 38.4 s" in texts
    low, high = ax.get_ylim()
    assert low < 2.6196 < high and high - low > 1e-3  # a flat record keeps a readable span
