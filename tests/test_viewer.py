"""Tests of the interactive viewer (plan.html): the page's content, its figure, and the page in
headless Chromium (its traces, the slider, the play button, the hover text)."""

from __future__ import annotations

import json
import re
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from stlplan import api
from stlplan.cli import app
from stlplan.mission.loader import load_problem
from stlplan.mission.problem import Problem
from stlplan.monitor.verdicts import check
from stlplan.outputs.plots import task_presence
from stlplan.outputs.viewer import hover_texts, viewer_figure, write_viewer
from stlplan.outputs.viewer.packed import unpacked
from stlplan.result import PlanResult, Trajectory
from tests.helpers.browser import Page
from tests.helpers.paths import FARM, MISSIONS
from tests.helpers.plans import make_report, make_trajectory

MOST_BYTES = 2_000_000
"""What a page may weigh (docs/viewer.md)."""


@pytest.fixture(scope="module")
def sync_pair(tmp_path_factory: pytest.TempPathFactory) -> tuple[Problem, PlanResult, Path]:
    """sync-pair solved once, its folder written without the animation."""
    out = tmp_path_factory.mktemp("sync-pair")
    overrides = api.Overrides(threads=1)
    result = api.solve(MISSIONS / "sync-pair.yaml", out=out, overrides=overrides, animation=False)
    assert result.trajectory is not None and result.report is not None
    return load_problem(MISSIONS / "sync-pair.yaml"), result, out


@pytest.fixture(scope="module")
def farm() -> Problem:
    return load_problem(FARM)


# ---------------------------------------------------------------------------------- the file
def test_solve_writes_one_self_contained_page(sync_pair) -> None:
    problem, _, out = sync_pair
    assert sorted(p.name for p in out.iterdir()) == [
        "convergence.png",
        "plan.html",
        "plan.png",
        "summary.json",
        "timeline.png",
        "trajectory.csv",
    ]
    page = (out / "plan.html").read_text(encoding="utf-8")
    assert re.findall(r"<script[^>]*\bsrc\s*=", page) == []  # every script inline
    assert re.findall(r"<link\b", page) == []  # no style sheet or font to fetch
    library = unpacked(page, "plotly-js").decode("utf-8")
    assert re.search(r"plotly\.js v\d", library)  # the library itself, not a link to it
    assert len(library) > 3_000_000  # plotly.js is some 4.8 MB ...
    assert len(page.encode("utf-8")) < MOST_BYTES  # ... packed
    assert "<title>sync-pair: optimal</title>" in page
    figure = json.loads(unpacked(page, "figure"))
    for agent in problem.agents:
        assert any(trace.get("name") == agent.name for trace in figure["data"])


@pytest.mark.parametrize("mission", ["farm.yaml", "crowd/crowd-64.yaml"])
def test_the_page_of_a_shipped_mission_weighs_at_most_2_mb(mission: str, tmp_path: Path) -> None:
    # the agents standing at their starts: the page's size is plotly.js and the figure's
    problem = load_problem(MISSIONS / mission)
    steps = problem.horizon + 1
    states = {a.name: np.tile(a.initial_state, (steps, 1)) for a in problem.agents}
    inputs = {a.name: np.zeros((problem.horizon, a.m)) for a in problem.agents}
    trajectory = Trajectory(problem.horizon, states, inputs)
    target = tmp_path / "plan.html"
    write_viewer(problem, trajectory, check(problem, trajectory), target)
    assert target.stat().st_size < MOST_BYTES


def test_write_viewer_leaves_only_the_page(farm: Problem, tmp_path: Path) -> None:
    target = tmp_path / "plan.html"
    write_viewer(farm, make_trajectory(farm), make_report(), target, title="farm: optimal")
    assert [p.name for p in tmp_path.iterdir()] == ["plan.html"]  # no temporary file left
    assert "<title>farm: optimal</title>" in target.read_text(encoding="utf-8")


def test_no_html_writes_none_and_removes_an_earlier_one(sync_pair, tmp_path: Path) -> None:
    out = tmp_path / "plan"
    shutil.copytree(sync_pair[2], out)
    mission = str(MISSIONS / "sync-pair.yaml")
    args = ["solve", mission, "--out", str(out), "-q", "--no-animation", "--no-html"]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    names = sorted(p.name for p in out.iterdir())
    assert names == [
        "convergence.png",
        "plan.png",
        "summary.json",
        "timeline.png",
        "trajectory.csv",
    ]


# -------------------------------------------------------------------------------- the figure
def test_hover_names_the_agent_step_state_and_tasks_served(farm: Problem) -> None:
    texts = hover_texts(farm, make_trajectory(farm), make_report())
    assert set(texts) == {a.name for a in farm.agents}
    assert all(len(rows) == farm.horizon + 1 for rows in texts.values())
    uv3 = texts["uv3"][4]  # at (1.0, 1.0), inside A1
    assert uv3.startswith("<b>uv3</b> (UV)<br>step k = 4<br>")
    assert "state x = (1, 1, 0.1, -0.1)" in uv3
    assert uv3.endswith("serves crop_A1 in A1")
    assert texts["vis1"][5].endswith("serves crop_C in C (synchronized run)")
    assert texts["vis1"][0].endswith("serves no task")
    assert all(text.endswith("serves no task") for text in texts["vis3"])  # in no group


def _boxes(trace: Any) -> list[tuple[float, float, float, float]]:
    """The rectangles ``(x0, x1, y0, y1)`` of a trace of filled bars, gaps between them."""
    x, y = list(trace.x), list(trace.y)
    return [
        (min(x[i : i + 5]), max(x[i : i + 5]), min(y[i : i + 5]), max(y[i : i + 5]))
        for i in range(0, len(x), 6)
    ]


def test_timeline_bars_cover_the_steps_each_agent_serves(farm: Problem) -> None:
    trajectory, report = make_trajectory(farm), make_report()
    fig = viewer_figure(farm, trajectory, report)
    rows = {a.name: len(farm.agents) - 1 - i for i, a in enumerate(farm.agents)}
    for task in farm.tasks:
        bars = _boxes(next(t for t in fig.data if t.name == task.name))
        presence = task_presence(farm, trajectory, task, report.verdict(task.name))
        assert bars  # some agent of the hand-built plan serves each task
        for name, steps in presence.items():
            drawn = set()
            for x0, x1, y0, y1 in bars:
                if rows[name] - 0.5 < y0 < y1 < rows[name] + 0.5:
                    drawn |= set(range(round(x0 + 0.45), round(x1 - 0.45) + 1))
            assert drawn == set(steps), (task.name, name)
    run = _boxes(next(t for t in fig.data if t.name == "crop_C synchronized run"))
    assert [(x0, x1) for x0, x1, _, _ in run] == [(2.5, 9.5)] * 2  # steps 3-9, vis1 and vis2
    assert "crop_C synchronized: steps 3-9 (run 7, rho_s = 5)" in fig.layout.title.subtitle.text


def test_frames_put_each_marker_at_its_step(farm: Problem) -> None:
    trajectory = make_trajectory(farm)
    fig = viewer_figure(farm, trajectory, make_report(), title="farm: optimal")
    assert [f.name for f in fig.frames] == [str(k) for k in range(farm.horizon + 1)]
    assert [s.label for s in fig.layout.sliders[0].steps] == [f.name for f in fig.frames]
    markers = [fig.data[i] for i in fig.frames[0].traces]
    assert [m.name for m in markers] == [a.name for a in farm.agents] + ["step"]
    for k, frame in enumerate(fig.frames):
        for agent, moved in zip(farm.agents, frame.data, strict=False):
            z = trajectory.position(agent.name, agent.position)[k]
            assert (moved.x[0], moved.y[0]) == pytest.approx(tuple(z))
        assert tuple(frame.data[-1].x) == (k, k)  # the timeline's line at k
    assert fig.layout.title.text == "<b>farm: optimal</b>"
    assert fig.layout.yaxis.scaleanchor == "x" and fig.layout.yaxis.scaleratio == 1


def _positions_last(problem_yaml: dict[str, Any]) -> dict[str, Any]:
    """sync-pair with the state ``[v_x, v_y, z_x, z_y]``: the position is components 2 and 3."""
    dyn = problem_yaml["dynamics"]["double_integrator"]
    order = [2, 3, 0, 1]
    dyn["A"] = np.array(dyn["A"])[np.ix_(order, order)].tolist()
    dyn["B"] = np.array(dyn["B"])[order].tolist()
    dyn["state_bounds"] = [dyn["state_bounds"][i] for i in order]
    dyn["position"] = [2, 3]
    for agent in problem_yaml["agents"]:
        agent["initial_state"] = [agent["initial_state"][i] for i in order]
    return problem_yaml


def test_a_state_beyond_the_position_is_drawn_by_its_position(tmp_path: Path) -> None:
    text = (MISSIONS / "sync-pair.yaml").read_text(encoding="utf-8")
    mission = tmp_path / "velocity-first.yaml"
    mission.write_text(yaml.safe_dump(_positions_last(yaml.safe_load(text))), encoding="utf-8")
    problem = load_problem(mission)
    starts = {a.name: a.initial_state for a in problem.agents}
    ramp = np.linspace(0, 1, problem.horizon + 1)[:, None]
    states = {n: x0 + ramp * np.array([0, 0, 3.0, 0]) for n, x0 in starts.items()}
    inputs = {n: np.zeros((problem.horizon, 2)) for n in starts}
    trajectory = Trajectory(problem.horizon, states, inputs)
    fig = viewer_figure(problem, trajectory, check(problem, trajectory))
    path = next(t for t in fig.data if t.name == "north (ground)")
    assert np.allclose(path.x, states["north"][:, 2]) and np.allclose(path.y, states["north"][:, 3])
    assert "state x = (0, 0, 0.5, 3.5)" in path.hovertext[0]  # every component, in order


# ------------------------------------------------------------------------------- the browser
@pytest.fixture
def page(browser: Any, sync_pair) -> Iterator[Page]:
    opened = Page(browser, sync_pair[2] / "plan.html")
    yield opened
    opened.close()
    assert opened.errors == []
    assert [url for url in opened.requests if not url.startswith("file:")] == []  # no network


def _at_step(problem: Problem, trajectory: Trajectory, k: int) -> np.ndarray:
    """Each agent's position ``z(k)``, then the timeline line's first point ``(k, -0.6)``."""
    here = [trajectory.position(a.name, a.position)[k] for a in problem.agents]
    return np.array([*here, (k, -0.6)])


def _shown(page: Page, problem: Problem) -> np.ndarray:
    """Where the page has each agent's marker, then the timeline line's first point."""
    markers = page.markers()
    return np.array([markers[a.name] for a in problem.agents] + [markers["step"]])


def test_the_page_draws_every_agent_and_the_slider_moves_them(page: Page, sync_pair) -> None:
    problem, result, _ = sync_pair
    traces = page.js("return gd.data.map(t => [t.name, t.type]);")
    for agent in problem.agents:
        assert [agent.name, "scatter"] in traces  # its marker
        assert [f"{agent.name} (ground)", "scatter"] in traces  # its path
    assert ["meet", "scatter"] in traces
    fills = page.fills_drawn()
    assert fills >= 3 + 1 + 1  # the three regions, the bars of meet, the synchronized run
    assert np.allclose(_shown(page, problem), _at_step(problem, result.trajectory, 0))
    page.click_slider(5)
    page.page.wait_for_function(
        "() => document.getElementById('plan')._fullLayout.sliders[0].active === 5"
    )
    page.page.wait_for_timeout(600)  # the markers' transition
    assert np.allclose(_shown(page, problem), _at_step(problem, result.trajectory, 5))
    assert not np.allclose(_shown(page, problem), _at_step(problem, result.trajectory, 0))
    assert page.fills_drawn() == fills  # the rest of the figure is still drawn


@pytest.mark.heavy
def test_play_runs_to_the_last_step(page: Page, sync_pair) -> None:
    problem, result, _ = sync_pair
    page.page.get_by_text("▶ play").click()
    horizon = problem.horizon
    page.page.wait_for_function(
        f"() => document.getElementById('plan')._fullLayout.sliders[0].active === {horizon}",
        timeout=20_000,
    )
    page.page.wait_for_timeout(800)
    assert np.allclose(_shown(page, problem), _at_step(problem, result.trajectory, horizon))


def test_hovering_a_point_shows_its_step_and_state(page: Page, sync_pair) -> None:
    problem, result, _ = sync_pair
    k, agent = 3, problem.agents[0]
    x, y = page.js(
        f"const t = gd._fullData.find(t => t.name === '{agent.name} (ground)');"
        "const xa = gd._fullLayout.xaxis, ya = gd._fullLayout.yaxis;"
        "const box = gd.getBoundingClientRect();"
        f"return [box.left + xa._offset + xa.d2p(t.x[{k}]), box.top + ya._offset + ya.d2p(t.y[{k}])];"
    )
    page.page.mouse.move(x, y)
    label = page.page.locator(".hoverlayer .hovertext")
    label.wait_for(timeout=5_000)
    text = label.first.text_content() or ""
    state = result.trajectory.states[agent.name][k]
    assert f"{agent.name} (ground)" in text and f"step k = {k}" in text
    assert f"state x = ({state[0]:.3g}, {state[1]:.3g}" in text
