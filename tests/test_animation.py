"""Tests of the animation (plan.gif), of figures for 24 agents and of constraints on the timeline."""

from __future__ import annotations

import io
import os
import sys
from pathlib import Path

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.patches import Rectangle
from PIL import Image
from typer.testing import CliRunner

from stlplan.cli import app
from stlplan.mission.loader import load_problem
from stlplan.mission.problem import Problem
from stlplan.monitor.verdicts import check as monitor_check
from stlplan.outputs.plots import (
    PlanAnimation,
    animate_plan,
    ffmpeg,
    plan_figure,
    timeline_figure,
)
from stlplan.outputs.plots.animation import (
    FRAME_MS,
    FRAMES_PER_STEP,
    HOLD_MS,
    MAX_FRAMES,
    frame_times,
    positions_at,
    trail,
)
from stlplan.outputs.plots.common import MANY_AGENTS, limit_windows, spread
from stlplan.result import MonitorReport, Trajectory, Verdict
from tests.helpers.paths import FARM, MISSIONS
from tests.helpers.plans import make_report, make_trajectory


def _keyframes(points: list[tuple[int, float, float]], horizon: int) -> np.ndarray:
    """Positions at steps 0..H through (step, x, y) keyframes, straight between them."""
    steps, xs, ys = zip(*points, strict=True)
    k = np.arange(horizon + 1)
    return np.column_stack([np.interp(k, steps, xs), np.interp(k, steps, ys)])


def scaled_farm_plan(problem: Problem) -> Trajectory:
    """A plan shaped like Case I for the 24 agents of ``farm-x3``: six UV+IR formations cross B,
    uv7 visits A1 then A2, six Vis agents meet in C from step 3, the rest stay near the start."""
    paths: dict[str, np.ndarray] = {}
    for agent in problem.agents:
        z0 = agent.initial_state[:2]
        number = int(agent.name.lstrip("uvisr"))
        y = 4.02 + 0.104 * ((number - 1) % 6) + (0.052 if agent.name.startswith("ir") else 0)
        if number <= 6 and not agent.name.startswith("vis"):
            keys = [(0, *z0), (2, 1.8, y), (8, 6.2, y), (9, 6.3, y)]
        elif agent.name == "uv7":
            keys = [(0, *z0), (3, 1.0, 1.0), (5, 1.1, 0.9), (7, 2.5, 0.8), (9, 2.5, 0.8)]
        elif agent.name.startswith("vis") and number <= 6:
            spot = (4.55 + 0.15 * number, 1.0 + 0.4 * (number % 2))
            lane = 3.75 - 0.12 * number  # one lane each, above the obstacle
            keys = [(0, *z0), (1, 1.5, lane), (2, spot[0], lane), (3, *spot), (9, *spot)]
        else:
            keys = [(0, *z0), (9, *z0)]
        paths[agent.name] = _keyframes(keys, problem.horizon)
    states, inputs = {}, {}
    for name, z in paths.items():
        v = np.vstack([np.diff(z, axis=0), np.zeros((1, 2))])
        states[name] = np.hstack([z, v])
        inputs[name] = np.diff(v, axis=0)
    return Trajectory(problem.horizon, states, inputs)


@pytest.fixture(scope="module")
def farm() -> Problem:
    return load_problem(FARM)


@pytest.fixture(scope="module")
def team24() -> tuple[Problem, Trajectory, MonitorReport]:
    problem = load_problem(MISSIONS / "scale" / "farm-x3.yaml")
    trajectory = scaled_farm_plan(problem)
    return problem, trajectory, monitor_check(problem, trajectory)


def test_the_gif_has_one_frame_per_drawn_time(farm: Problem, tmp_path: Path) -> None:
    target = tmp_path / "plan.gif"
    count = animate_plan(farm, make_trajectory(farm), make_report(), target)
    assert count == farm.horizon * FRAMES_PER_STEP + 1
    with Image.open(target) as gif:
        assert gif.format == "GIF"
        assert gif.n_frames == count
        assert gif.info["loop"] == 0
        first = np.asarray(gif.convert("RGB"))
        gif.seek(count - 1)
        last = np.asarray(gif.convert("RGB"))
    assert first.shape == last.shape and first.shape[1] >= 500
    assert np.any(first != last)  # the team moved
    assert [p.name for p in tmp_path.iterdir()] == ["plan.gif"]  # no temporary file left


def test_frames_follow_the_segments_between_steps() -> None:
    assert list(frame_times(2)) == pytest.approx([0, 1 / 3, 2 / 3, 1, 4 / 3, 5 / 3, 2])
    long = frame_times(600)  # a long horizon: MAX_FRAMES evenly over the steps
    assert len(long) == MAX_FRAMES and long[0] == 0 and long[-1] == 600
    assert np.diff(long) == pytest.approx(600 / (MAX_FRAMES - 1))
    path = np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 6.0]])
    assert positions_at(path, 0.5) == pytest.approx([1.5, 0.0])
    assert positions_at(path, 1.5) == pytest.approx([3.0, 3.0])
    assert positions_at(path, 2.0) == pytest.approx([3.0, 6.0])
    # the trail turns at the waypoint (3, 0) and ends where the marker is
    assert trail(path, 1.5).tolist() == [[0.0, 0.0], [3.0, 0.0], [3.0, 3.0]]
    assert trail(path, 0.0).tolist() == [[0.0, 0.0], [0.0, 0.0]]


def test_the_synchronized_run_is_ringed_only_while_it_lasts(farm: Problem) -> None:
    report = make_report()  # crop_C: vis1 and vis2 synchronized at steps 3-9
    movie = PlanAnimation(farm, make_trajectory(farm), report)
    frames = [np.asarray(f.convert("RGB")).astype(int) for f in movie.frames()]
    # the ring's colour, gold (255, 215, 0), as the shared palette gives it
    gold = [np.sum(np.all(np.abs(f - [255, 215, 0]) <= 40, axis=2)) for f in frames]
    legend = min(gold)  # the legend's ring is in every frame
    ringed = [t for t, n in zip(frame_times(farm.horizon), gold, strict=True) if n > legend + 20]
    assert ringed[0] == pytest.approx(3.0) and ringed[-1] == pytest.approx(9.0)
    assert len(ringed) == 6 * FRAMES_PER_STEP + 1


def test_the_gif_is_written_atomically(farm: Problem, tmp_path: Path) -> None:
    target = tmp_path / "plan.gif"
    target.write_bytes(b"old")
    with pytest.raises(OSError):
        animate_plan(farm, make_trajectory(farm), make_report(), tmp_path / "no" / "plan.gif")
    animate_plan(farm, make_trajectory(farm), make_report(), target)
    with Image.open(io.BytesIO(target.read_bytes())) as gif:
        assert gif.n_frames > 1
    assert [p.name for p in tmp_path.iterdir()] == ["plan.gif"]


def test_spread_keeps_labels_that_cover_nothing() -> None:
    points = np.array([[0.0, 0.0], [1.0, 0.0], [5.0, 0.0], [0.0, 0.5]])
    half = np.full((4, 2), 0.6)
    # box 1 overlaps box 0, box 2 is alone, box 3 overlaps box 0
    assert spread(points, half).tolist() == [True, False, True, False]
    # boxes 0 and 1 fixed (markers): kept although they overlap, and label 3 covers them
    assert spread(points, half, fixed=2).tolist() == [True, True, True, False]
    assert spread(points[2:], half[2:]).tolist() == [True, True]


def test_24_agents_get_one_legend_entry_per_capability(team24) -> None:
    problem, trajectory, report = team24
    assert len(problem.agents) == 24 > MANY_AGENTS
    fig = plan_figure(problem, trajectory, report)
    ax = fig.axes[0]
    entries = [t.get_text() for t in ax.get_legend().get_texts()]
    assert entries[:3] == ["UV (9 agents)", "IR (6 agents)", "Vis (9 agents)"]
    # no step numbers; names at the end points only, never two on top of each other
    names = [t for t in ax.texts if t.get_text() in {a.name for a in problem.agents}]
    assert 0 < len(names) <= 24
    assert not [t for t in ax.texts if t.get_text().isdigit()]
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    boxes = [t.get_window_extent(renderer=canvas.get_renderer()) for t in names]
    for i, a in enumerate(boxes):
        assert not any(a.overlaps(b) for b in boxes[i + 1 :])


def test_24_agents_keep_distinct_shades_within_a_capability(team24) -> None:
    from stlplan.outputs.plots.common import agent_styles

    problem = team24[0]
    styles = agent_styles(problem)
    uv = [styles[a.name][1] for a in problem.agents if "UV" in a.capabilities]
    assert len(set(uv)) == 9
    gaps = np.abs(np.diff(np.array(uv)[:, :3], axis=0)).sum(axis=1)
    assert np.all(gaps > 0.02)


def test_a_few_agents_keep_one_legend_entry_each(farm: Problem) -> None:
    fig = plan_figure(farm, make_trajectory(farm), make_report())
    entries = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert entries[: len(farm.agents)] == [
        f"{a.name} ({'+'.join(sorted(a.capabilities))})" for a in farm.agents
    ]


def test_the_24_agent_animation_names_few_agents_at_the_start(team24, tmp_path: Path) -> None:
    problem, trajectory, report = team24
    count = animate_plan(problem, trajectory, report, tmp_path / "plan.gif")
    assert count == problem.horizon * FRAMES_PER_STEP + 1
    with Image.open(tmp_path / "plan.gif") as gif:
        assert gif.n_frames == count


def test_a_constraints_only_mission_draws_its_constraint(tmp_path: Path) -> None:
    problem = load_problem(MISSIONS / "reach-avoid.yaml")
    assert not problem.tasks and len(problem.constraints) == 1
    z = _keyframes([(0, 1.0, 1.0), (6, 2.0, 7.5), (12, 8.0, 8.0)], problem.horizon)
    v = np.vstack([np.diff(z, axis=0), np.zeros((1, 2))])
    trajectory = Trajectory(problem.horizon, {"robot": np.hstack([z, v])}, {})
    report = MonitorReport((Verdict("reach_avoid", "constraint", True, 0.5),))
    fig = timeline_figure(problem, trajectory, report)
    ax = fig.axes[0]
    hatched = [p for p in ax.patches if isinstance(p, Rectangle) and p.get_hatch() == "xx"]
    assert len(hatched) == 1
    assert hatched[0].get_x() == pytest.approx(-0.45)  # steps 0..12
    assert hatched[0].get_width() == pytest.approx(12.9)
    assert "robot" in {t.get_text() for t in ax.texts}
    ticks = [t.get_text() for t in ax.get_yticklabels()]
    assert "reach_avoid (constraint)" in ticks
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert "constraint: the steps it reads" in legend


def test_a_violated_constraint_is_edged_in_red(farm: Problem) -> None:
    report = MonitorReport(
        make_report().verdicts[:-2] + (Verdict("avoid_obstacle", "constraint", False, -0.2),)
    )
    fig = timeline_figure(farm, make_trajectory(farm), report)
    bars = {round(p.get_y() + 0.3): p for p in fig.axes[0].patches if p.get_hatch() == "xx"}
    assert len(bars) == 2  # avoid_obstacle, then the separation
    edges = sorted(tuple(np.round(p.get_edgecolor()[:3], 2)) for p in bars.values())
    assert (0.84, 0.15, 0.16) in edges and (0.5, 0.5, 0.5) in edges


def test_limit_windows_read_the_formula_intervals(farm: Problem) -> None:
    limits = limit_windows(farm)
    assert [(x.name, x.window) for x in limits] == [
        ("avoid_obstacle", (0, 9)),
        ("separation", (0, 9)),
    ]
    assert limits[0].binds == tuple(a.name for a in farm.agents)


def _fake_ffmpeg(folder: Path, body: str) -> Path:
    """An ``ffmpeg`` executable in ``folder`` that runs ``body`` (Python) on its arguments."""
    folder.mkdir(exist_ok=True)
    fake = folder / "ffmpeg"
    fake.write_text(f"#!{sys.executable}\nimport sys\nargs = sys.argv[1:]\n{body}\n")
    fake.chmod(0o755)
    return fake


COUNTING_FFMPEG = """
width, height = map(int, args[args.index("-s") + 1].split("x"))
frames = len(sys.stdin.buffer.read()) // (width * height * 3)
with open(args[-1], "w") as out:
    out.write(f"{frames} frames, {args[-4:-1]}")
"""


def test_the_mp4_goes_through_ffmpeg(
    farm: Problem, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    fake = _fake_ffmpeg(tmp_path / "bin", COUNTING_FFMPEG)
    monkeypatch.setenv("PATH", f"{fake.parent}{os.pathsep}{os.environ['PATH']}")
    assert ffmpeg() == str(fake)
    movie = PlanAnimation(farm, make_trajectory(farm), make_report())
    movie.write_mp4(tmp_path / "plan.mp4")
    held = len(movie.frames()) + HOLD_MS // FRAME_MS
    assert (tmp_path / "plan.mp4").read_text() == f"{held} frames, ['-f', 'mp4', '-y']"


def test_a_failing_ffmpeg_is_an_os_error_and_leaves_nothing(
    farm: Problem, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    fake = _fake_ffmpeg(tmp_path / "bin", "sys.stderr.write('no encoder'); sys.exit(1)")
    monkeypatch.setenv("PATH", f"{fake.parent}{os.pathsep}{os.environ['PATH']}")
    movie = PlanAnimation(farm, make_trajectory(farm), make_report())
    with pytest.raises(OSError, match="ffmpeg could not write the MP4: no encoder"):
        movie.write_mp4(tmp_path / "plan.mp4")
    assert [p.name for p in tmp_path.iterdir()] == ["bin"]
    monkeypatch.setenv("PATH", str(tmp_path / "nowhere"))
    assert ffmpeg() is None
    with pytest.raises(OSError, match="ffmpeg is not installed"):
        movie.write_mp4(tmp_path / "plan.mp4")


@pytest.mark.heavy
def test_a_solve_writes_the_mp4_only_with_ffmpeg(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    fake = _fake_ffmpeg(tmp_path / "bin", COUNTING_FFMPEG)
    path = os.environ["PATH"]
    monkeypatch.setenv("PATH", f"{fake.parent}{os.pathsep}{path}")
    out = tmp_path / "out"
    mission = str(MISSIONS / "reach-avoid.yaml")
    found = CliRunner().invoke(app, ["solve", mission, "--out", str(out), "-q", "--threads", "1"])
    assert found.exit_code == 0, found.output
    assert {"plan.gif", "plan.mp4"} <= {p.name for p in out.iterdir()}
    monkeypatch.setenv("PATH", path)  # ffmpeg gone: the next solve's folder holds no mp4
    real_ffmpeg = ffmpeg()
    found = CliRunner().invoke(app, ["solve", mission, "--out", str(out), "-q", "--threads", "1"])
    assert found.exit_code == 0, found.output
    assert ("plan.mp4" in {p.name for p in out.iterdir()}) == (real_ffmpeg is not None)
