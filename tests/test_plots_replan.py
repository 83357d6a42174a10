"""Tests of a replan's figures and viewer: the executed past solid, the new plan dashed, the replan
step marked, a lost agent crossed and a closed region hatched (a hand-built farm plan replanned
from step 4 with vis3 lost and Init closed, no solve)."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.lines import Line2D
from matplotlib.patches import Polygon, Rectangle
from PIL import Image

from stlplan import api
from stlplan.mission.loader import load_problem
from stlplan.mission.problem import Problem
from stlplan.monitor.verdicts import check
from stlplan.outputs.plots import PlanAnimation, plan_figure, polygon_area, timeline_figure
from stlplan.outputs.plots.animation import ANIMATION_DPI, MAP_INCHES, MARGINS, frame_times
from stlplan.outputs.plots.common import task_service
from stlplan.outputs.viewer import hover_texts, viewer_figure
from stlplan.outputs.viewer.packed import unpacked
from stlplan.result import MonitorReport, PlanResult, PlanStatus, Replan, Trajectory
from tests.helpers.paths import FARM
from tests.helpers.plans import make_replan, make_report, make_trajectory

K = 4
LOST = "vis3"  # at (0.7, 3.5) from step 2 on, away from the others
CLOSED = "Init"  # the box [0, 1] x [4, 5], which every agent has left by step 2


@pytest.fixture(scope="module")
def farm() -> Problem:
    return load_problem(FARM)


@pytest.fixture(scope="module")
def replan(farm: Problem) -> tuple[Problem, Trajectory, MonitorReport]:
    problem, trajectory = make_replan(farm, K, (LOST,), (CLOSED,))
    return problem, trajectory, check(problem, trajectory)


@pytest.fixture(autouse=True)
def no_open_figures():
    yield
    assert plt.get_fignums() == []


def _path(problem: Problem, trajectory: Trajectory, name: str) -> np.ndarray:
    return trajectory.position(name, problem.agent(name).position)


def _dashed(ax) -> list[Line2D]:
    return [line for line in ax.lines if line.get_linestyle() == "--"]


# ------------------------------------------------------------------------------------- plan.png
def test_the_past_is_solid_and_the_new_plan_dashed(replan) -> None:
    problem, trajectory, report = replan
    ax = plan_figure(problem, trajectory, report).axes[0]
    dashed = {tuple(map(tuple, line.get_xydata())) for line in _dashed(ax)}
    solid = {
        tuple(map(tuple, line.get_xydata())) for line in ax.lines if line.get_linestyle() == "-"
    }
    moving = [a.name for a in problem.agents if a.name != LOST]
    assert len(dashed) == len(_dashed(ax)) == len(moving)  # none for the lost agent
    for name in moving:
        z = _path(problem, trajectory, name)
        assert tuple(map(tuple, z[K:])) in dashed
        assert tuple(map(tuple, z[: K + 1])) in solid
    assert tuple(map(tuple, _path(problem, trajectory, LOST)[: K + 1])) in solid


def test_the_replan_step_is_ringed_and_the_lost_agent_crossed(replan) -> None:
    problem, trajectory, report = replan
    ax = plan_figure(problem, trajectory, report).axes[0]
    crosses = [line for line in ax.lines if line.get_marker() == "x"]
    assert len(crosses) == 1
    assert crosses[0].get_xydata().tolist() == [_path(problem, trajectory, LOST)[K].tolist()]
    rings = [line for line in ax.lines if line.get_marker() == "o" and line.get_mfc() == "none"]
    assert len(rings) == 1
    at_k = [_path(problem, trajectory, a.name)[K] for a in problem.agents if a.name != LOST]
    assert rings[0].get_xydata() == pytest.approx(np.array(at_k))


def test_the_closed_region_is_hatched_and_no_obstacle(replan) -> None:
    problem, trajectory, report = replan
    ax = plan_figure(problem, trajectory, report).axes[0]
    hatches = {p.get_hatch(): p for p in ax.patches if isinstance(p, Polygon) and p.get_hatch()}
    assert set(hatches) == {"///", "////"}  # the obstacle Obs, the closed Init
    assert polygon_area(hatches["////"].get_xy()[:4]) == pytest.approx(1.0)  # Init: 1 x 1
    assert polygon_area(hatches["///"].get_xy()[:4]) == pytest.approx(3.0)  # Obs: 2 x 1.5


def test_the_legend_and_subtitle_name_the_replan(replan) -> None:
    problem, trajectory, report = replan
    ax = plan_figure(problem, trajectory, report).axes[0]
    entries = [t.get_text() for t in ax.get_legend().get_texts()]
    assert entries[-5:] == [
        "executed (steps 0-4)",
        "new plan (from step 4)",
        "replan at step 4",
        "lost at step 4: vis3",
        "closed from step 4: Init",
    ]
    texts = [t.get_text() for t in ax.texts]
    assert any(t.startswith("replanned from step 4: vis3 lost, Init closed   |   ") for t in texts)


def test_a_plan_without_a_past_has_no_replan_marks(farm: Problem) -> None:
    ax = plan_figure(farm, make_trajectory(farm), make_report()).axes[0]
    assert _dashed(ax) == []
    assert not [line for line in ax.lines if line.get_marker() == "x"]
    assert not any("replan" in t.get_text() for t in ax.get_legend().get_texts())


# --------------------------------------------------------------------------------- timeline.png
def _rows(fig) -> dict[str, float]:
    ax = fig.axes[0]
    labels = [t.get_text() for t in ax.get_yticklabels()]
    return {label.split()[0]: y for label, y in zip(labels, ax.get_yticks(), strict=True)}


def test_the_timeline_marks_the_replan_and_greys_the_lost_row(replan) -> None:
    problem, trajectory, report = replan
    fig = timeline_figure(problem, trajectory, report)
    ax, rows = fig.axes[0], _rows(fig)
    lines = [line for line in ax.lines if list(line.get_xdata()) == [K, K]]
    assert len(lines) == 1 and lines[0].get_linestyle() == "--"
    spans = [p for p in ax.patches if p.get_x() == pytest.approx(-0.6)]
    assert [p.get_width() for p in spans if isinstance(p, Rectangle)] == [pytest.approx(K + 0.6)]
    greyed = [p for p in ax.patches if p.get_x() == K and p.get_height() == 1.0]
    assert len(greyed) == 1 and greyed[0].get_y() == pytest.approx(rows[LOST] - 0.5)
    lost = [t for t in ax.texts if t.get_text() == "lost at step 4"]
    assert len(lost) == 1 and lost[0].get_position()[1] == rows[LOST]
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert {"replan at step 4", "executed (steps 0-4)"} <= set(legend)
    assert rows["closed"] < rows["avoid_obstacle"]  # the closure's row with the constraints
    assert "closed Init (from step 4)" in [t.get_text() for t in ax.get_yticklabels()]


def test_a_timeline_without_a_past_has_no_replan_line(farm: Problem) -> None:
    fig = timeline_figure(farm, make_trajectory(farm), make_report())
    ax = fig.axes[0]
    assert not [line for line in ax.lines if line.get_linestyle() == "--"]
    assert not any("replan" in t.get_text() for t in fig.legends[0].get_texts())


# ------------------------------------------------------------------------------------- plan.gif
def _pixels(problem: Problem, frame: Image.Image, box: tuple[float, float, float, float]):
    """The frame's pixels over the map's rectangle ``box`` = ``(x0, x1, y0, y1)``."""
    (xl, xh), (yl, yh) = ((0.0, 7.0), (0.0, 5.0))  # the farm's workspace
    per_unit = MAP_INCHES / max(xh - xl, yh - yl) * ANIMATION_DPI
    left, bottom = MARGINS[0] * ANIMATION_DPI, MARGINS[1] * ANIMATION_DPI
    image = np.asarray(frame.convert("RGB")).astype(int)
    x0, x1, y0, y1 = box
    rows = slice(
        round(image.shape[0] - bottom - y1 * per_unit),
        round(image.shape[0] - bottom - y0 * per_unit),
    )
    return image[rows, round(left + x0 * per_unit) : round(left + x1 * per_unit)]


def _dark(pixels: np.ndarray) -> int:
    return int(np.sum(np.all(pixels < 80, axis=2)))


def test_the_animation_crosses_the_lost_agent_and_hatches_from_the_replan(replan) -> None:
    problem, trajectory, report = replan
    frames = PlanAnimation(problem, trajectory, report).frames()
    times = frame_times(problem.horizon)
    x, y = _path(problem, trajectory, LOST)[K]
    near = (x - 0.12, x + 0.12, y - 0.12, y + 0.12)
    cross = [_dark(_pixels(problem, f, near)) for f in frames]
    hatch = [_dark(_pixels(problem, f, (0.05, 0.4, 4.05, 4.95))) for f in frames]  # Init's left
    before = [i for i, t in enumerate(times) if 2 <= t < K]  # vis3 stands still from step 2
    after = [i for i, t in enumerate(times) if t >= K]
    assert max(cross[i] for i in before) * 2 < min(cross[i] for i in after)
    assert max(hatch[i] for i in before) * 4 < min(hatch[i] for i in after)


# ------------------------------------------------------------------------------------ plan.html
def test_the_viewer_marks_the_past_the_lost_agent_and_the_closed_region(replan) -> None:
    problem, trajectory, report = replan
    fig = viewer_figure(problem, trajectory, report)
    names = [t.name for t in fig.data]
    assert {"replan at step 4", "lost at step 4: vis3", "closed from step 4: Init"} <= set(names)
    cross = next(t for t in fig.data if t.name == "lost at step 4: vis3")
    assert cross.marker.symbol == "x-thin"
    assert (cross.x[0], cross.y[0]) == pytest.approx(tuple(_path(problem, trajectory, LOST)[K]))
    for agent in problem.agents:
        label = f"{agent.name} ({'+'.join(sorted(agent.capabilities))})"
        parts = [t for t in fig.data if t.name == label]
        z = _path(problem, trajectory, agent.name)
        assert list(parts[0].x) == pytest.approx(z[: K + 1, 0].tolist())
        if agent.name == LOST:
            assert [t.line.dash for t in parts] == [None]  # it stays: no new plan
        else:
            assert [t.line.dash for t in parts] == [None, "dash"]
            assert list(parts[1].x) == pytest.approx(z[K:, 0].tolist())
            assert [parts[0].showlegend, parts[1].showlegend] == [True, False]
    assert "replanned from step 4: vis3 lost, Init closed" in fig.layout.title.subtitle.text


def test_the_viewer_timeline_shades_the_past_and_greys_the_lost_row(replan) -> None:
    problem, trajectory, report = replan
    fig = viewer_figure(problem, trajectory, report)
    shapes = [s for s in fig.layout.shapes if s.xref == "x2" and s.yref == "y2"]
    assert [(s.x0, s.x1) for s in shapes if s.type == "line"] == [(K, K)]
    rects = [(s.x0, s.x1, s.y0) for s in shapes if s.type == "rect" and s.x0 in (-0.6, K)]
    row = len(problem.agents) - 1 - [a.name for a in problem.agents].index(LOST)
    assert (-0.6, K, -0.6) in rects and (K, problem.horizon + 0.6, row - 0.5) in rects
    notes = {a.text: a for a in fig.layout.annotations}
    assert notes["<i>lost at step 4</i>"].y == row
    assert "<b>replan at step 4</b>" in notes
    markers = [fig.data[i].name for i in fig.frames[0].traces]
    assert markers == [a.name for a in problem.agents] + ["step"]  # the frames move the same


def test_hover_says_executed_new_plan_or_lost(replan) -> None:
    problem, trajectory, report = replan
    texts = hover_texts(problem, trajectory, report)
    assert "<br>step k = 4 (executed)<br>" in texts["uv1"][4]
    assert "<br>step k = 5 (new plan)<br>" in texts["uv1"][5]
    assert "<br>step k = 5 (lost at step 4)<br>" in texts[LOST][5]


def test_a_viewer_without_a_past_has_no_replan_marks(farm: Problem) -> None:
    fig = viewer_figure(farm, make_trajectory(farm), make_report())
    marks = ("executed", "new plan", "replan at", "lost at", "closed from")
    assert not [t for t in fig.data if t.name and t.name.startswith(marks)]
    assert all(t.line.dash is None for t in fig.data if t.mode == "lines+markers")
    assert "replan" not in fig.layout.title.subtitle.text


# ------------------------------------------------------------------------------ the plan folder
@pytest.mark.heavy
def test_write_plan_draws_every_file_of_a_replan(replan, tmp_path: Path) -> None:
    problem, trajectory, report = replan
    record = Replan(K, (f"{LOST} lost", f"{CLOSED} closed"), 0.0, 1.0)
    result = PlanResult(PlanStatus.OPTIMAL, "", trajectory, report=report, replan=record)
    written = api.write_plan(problem, result, tmp_path, animation=True, viewer=True)
    names = {p.name for p in written}
    assert {"plan.png", "timeline.png", "plan.gif", "plan.html"} <= names
    with Image.open(tmp_path / "plan.png") as image:
        assert image.size[0] > 800
    page = (tmp_path / "plan.html").read_text(encoding="utf-8")
    assert "replan at step 4" in unpacked(page, "figure").decode("utf-8")


@pytest.fixture(scope="module")
def lost_in_service(farm: Problem) -> tuple[Problem, Trajectory, MonitorReport]:
    """vis1 lost at step 4 inside C, where crop_C's synchronized run still counts it."""
    problem, trajectory = make_replan(farm, K, ("vis1",))
    return problem, trajectory, check(problem, trajectory)


def test_a_lost_agents_service_is_drawn_as_the_monitor_counts_it(lost_in_service) -> None:
    problem, trajectory, report = lost_in_service
    crop_c = next(v for v in report.verdicts if v.name == "crop_C")
    assert crop_c.satisfied and ("vis1",) in crop_c.group
    served = task_service(problem, trajectory, report)["vis1"]["crop_C"]
    assert set(range(K, problem.horizon + 1)) <= set(served)  # counted where it stays
    fig = timeline_figure(problem, trajectory, report)
    ax, row = fig.axes[0], _rows(fig)["vis1"]
    lost = [p for p in ax.patches if p.get_x() == K and p.get_hatch() == "//"]
    bars = [p for p in ax.patches if isinstance(p, Rectangle) and p.get_zorder() > lost[0].get_zorder()
            and row - 0.5 <= p.get_y() <= row + 0.5 and p.get_x() + p.get_width() > K]  # fmt: skip
    assert len(lost) == 1 and bars  # the bars past K drawn over the loss's mark
    plt.close(fig)
    viewer = viewer_figure(problem, trajectory, report)
    greyed = [s for s in viewer.layout.shapes if s.type == "rect" and s.x0 == K and s.xref == "x2"]
    assert len(greyed) == 1 and greyed[0].layer == "below"
