"""The viewer's page: the map and the timeline side by side, one frame per step, the slider and
the play button, written as one HTML file with plotly.js inline (packed small)."""

from __future__ import annotations

import html
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import plotly.graph_objects as go
from plotly.subplots import make_subplots

import stlplan.outputs.viewer.map as plan_map
import stlplan.outputs.viewer.packed as packed
import stlplan.outputs.viewer.team as team
import stlplan.outputs.viewer.timeline as timeline
from stlplan.mission.problem import Problem
from stlplan.outputs.plots.common import (
    MANY_AGENTS,
    _group_agents,
    _run_steps,
    _status_line,
    _sync_verdicts,
    agent_styles,
    sync_caption,
    task_service,
    workspace,
    write_atomically,
)
from stlplan.outputs.plots.past import events_note
from stlplan.outputs.plots.team import region_colors, team_marks
from stlplan.outputs.viewer.past import path_parts, replan_traces, timeline_marks
from stlplan.result import MonitorReport, Trajectory

HEIGHT_PX = 700
"""Height of the figure (taller by :data:`LINE_PX` per line of counts under the subtitle); its
width follows the browser window."""
LINE_PX = 18
"""The height of a line of the subtitle, pixels."""
MAP_PX = (520, 480)
"""About the map's largest width and height in a window 1400 pixels wide, pixels: the scale at
which agents' names are kept apart."""
STEP_MS = 700
"""How long the play button stays on each step, milliseconds; the markers move for most of it."""
MOVE_MS = 500
"""How long the markers take to slide from one step's positions to the next when playing,
milliseconds (half as long when the slider moves).

plotly.js moves the markers for the shorter of a frame's duration and its transition's; when that
is 0 it draws only the frame's traces (the markers, the timeline's line) on their subplots and the
paths, regions and bars vanish, so every move here takes some time."""
_FONT = dict(family="DejaVu Sans, Verdana, Arial, sans-serif", size=13, color="#222")
_CONFIG = dict(displaylogo=False, responsive=True, toImageButtonOptions=dict(filename="plan"))


def viewer_figure(
    problem: Problem, trajectory: Trajectory, report: MonitorReport, title: str | None = None
) -> go.Figure:
    """The viewer as a plotly figure (see :mod:`stlplan.outputs.viewer`).

    Parameters
    ----------
    problem, trajectory, report
        The mission, the team trajectory, and the monitor's verdicts on it (groups, runs).
    title
        Figure title, e.g. ``"farm: optimal"``; default the mission name.
    """
    fig = _subplots()
    hover = plan_map.hover_texts(problem, trajectory, report)
    marks, colors = team_marks(problem, trajectory), region_colors(problem)
    regions, labels = plan_map.region_traces(problem, trajectory)
    fig.add_traces(regions, rows=1, cols=1)
    fig.add_traces(_paths(problem, trajectory, report, hover), rows=1, cols=1)
    crossing = plan_map.crossing_trace(problem, trajectory)
    unsafe = [] if crossing is None else [crossing]
    fig.add_traces(unsafe + replan_traces(problem, trajectory), rows=1, cols=1)
    fig.add_traces(team.entry_traces(problem, trajectory, marks, colors), rows=1, cols=1)
    service = task_service(problem, trajectory, report)
    lanes = _timeline_traces(fig, problem, report, service, (marks, colors))
    steps = [_step(problem, trajectory, hover, k) for k in range(problem.horizon + 1)]
    first = len(fig.data)
    fig.add_traces(_markers(problem, steps[0][:-1]), rows=1, cols=1)
    fig.add_traces([timeline.cursor_trace(problem).update(steps[0][-1])], rows=1, cols=2)
    moving = list(range(first, len(fig.data)))
    fig.frames = [
        go.Frame(name=str(k), data=[go.Scatter(change) for change in step], traces=moving)
        for k, step in enumerate(steps)
    ]
    _layout(fig, problem, report, title or problem.mission.name, team.captions(marks))
    replan_marks, notes = timeline_marks(problem, timeline.rows(problem))
    notes = labels + timeline.idle_notes(problem, service, marks) + notes
    fig.update_layout(
        annotations=list(fig.layout.annotations) + notes,
        shapes=lanes + list(fig.layout.shapes) + replan_marks,
    )
    return fig


def _timeline_traces(fig: go.Figure, problem, report, service, counts) -> list[dict]:
    """The timeline's synchronized runs, task bars and counts' lanes
    (:mod:`~stlplan.outputs.viewer.team`); returns the lanes' background shapes."""
    marks, colors = counts
    bars, lanes = timeline.task_bars(problem, service, marks)
    counted, counted_lanes = team.lane_traces(problem, service, marks, colors)
    fig.add_traces(timeline.sync_bars(problem, report) + bars + counted, rows=1, cols=2)
    return lanes + counted_lanes


def _subplots() -> go.Figure:
    """The map on the left, the timeline on the right, each titled over its left edge."""
    fig = make_subplots(
        rows=1,
        cols=2,
        column_widths=[0.55, 0.45],
        horizontal_spacing=0.12,
        subplot_titles=("paths over the map", "who serves which task when"),
    )
    for note, axis in zip(fig.layout.annotations, ("xaxis", "xaxis2"), strict=True):
        note.update(x=fig.layout[axis].domain[0], xanchor="left", yshift=14)  # above the names
    return fig


def _paths(problem, trajectory, report, hover) -> list[go.Scatter]:
    """Each agent's path, in the parts of :func:`~stlplan.outputs.viewer.past.path_parts`."""
    styles, entries = agent_styles(problem), plan_map.legend_entries(problem)
    runs = {name: set(_run_steps(v)) for v in _sync_verdicts(report) for name in _group_agents(v)}
    return [
        plan_map.path_trace(
            z, styles[a.name], entries[a.name], texts, runs.get(a.name, set()), first, dash
        )
        for a in problem.agents
        for first, z, texts, dash in path_parts(
            problem, a.name, trajectory.position(a.name, a.position), hover[a.name]
        )
    ]


def _markers(problem: Problem, start: list[dict]) -> list[go.Scatter]:
    styles, entries = agent_styles(problem), plan_map.legend_entries(problem)
    return [
        plan_map.marker_trace(a.name, styles[a.name], entries[a.name]).update(here)
        for a, here in zip(problem.agents, start, strict=True)
    ]


def _step(problem, trajectory, hover, k: int) -> list[dict]:
    """What changes at step ``k``: each agent's marker moves to ``z(k)`` with its hover text and
    its name (where the name covers no marker or other name), and the timeline's line to ``k``."""
    names = [a.name for a in problem.agents]
    here = np.array([trajectory.position(a.name, a.position)[k] for a in problem.agents])
    (xl, xh), (yl, yh) = workspace(problem)
    scale = min(MAP_PX[0] / (xh - xl), MAP_PX[1] / (yh - yl))
    shown = plan_map.names_shown(names, here, scale)
    moved = [
        dict(x=[z[0]], y=[z[1]], text=[text], hovertext=[hover[name][k]])
        for name, z, text in zip(names, here.tolist(), shown, strict=True)
    ]
    return [*moved, dict(x=[k, k])]


def _slider(horizon: int) -> dict:
    """A step of the slider per step ``k``, each moving the markers to ``z(k)``."""
    move = dict(
        mode="immediate",
        frame=dict(duration=MOVE_MS // 2, redraw=False),
        transition=dict(duration=MOVE_MS // 2),
    )
    return dict(
        active=0,
        steps=[
            dict(label=str(k), method="animate", args=[[str(k)], move]) for k in range(horizon + 1)
        ],
        currentvalue=dict(prefix="step k = ", font=dict(size=14)),
        x=0.1,
        len=0.9,
        y=0,
        yanchor="top",
        pad=dict(t=45, b=10),
    )


def _play_buttons() -> dict:
    """Play from the slider's step to the last step; pause where it is."""
    play = dict(
        frame=dict(duration=STEP_MS, redraw=False),
        transition=dict(duration=MOVE_MS, easing="linear"),
        fromcurrent=True,
        mode="immediate",
    )
    pause = dict(
        frame=dict(duration=0, redraw=False), transition=dict(duration=0), mode="immediate"
    )
    return dict(
        type="buttons",
        direction="left",
        buttons=[
            dict(label="▶ play", method="animate", args=[None, play]),
            dict(label="❚❚ pause", method="animate", args=[[None], pause]),
        ],
        x=0.1,
        xanchor="right",
        y=0,
        yanchor="top",
        pad=dict(t=55, r=10),
        showactive=False,
    )


def _subtitle(problem: Problem, report: MonitorReport, counts: Sequence[str] = ()) -> str:
    """A replan's step and events, the monitor's verdict, then each synchronized run (as on
    ``plan.png``); under it a line per count and visits (``counts``, escaped already)."""
    captions = [sync_caption(v) for v in _sync_verdicts(report)]
    replan = [] if problem.past is None else [events_note(problem.past)]
    head = html.escape("   |   ".join([*replan, _status_line(report), *captions]))
    return "<br>".join([head, *counts])


def _layout(
    fig: go.Figure, problem: Problem, report: MonitorReport, title: str, counts: Sequence[str]
) -> None:
    many = len(problem.agents) > MANY_AGENTS
    title_text = "capability" if many else "agent (capability)"
    legend = dict(title=dict(text=title_text), x=1.02, y=1, yanchor="top")
    if problem.past is not None:
        legend["tracegroupgap"] = 0  # room for a replan's entries under the agents'
    height = HEIGHT_PX + LINE_PX * len(counts)
    # the title where plotly centres it in the top margin, its subtitle's lines of counts below
    at_top = dict(y=1 - 45 / height, yref="container", yanchor="top") if counts else {}
    fig.update_layout(
        title=dict(
            text=f"<b>{html.escape(title)}</b>",
            subtitle=dict(text=_subtitle(problem, report, counts)),
            x=0.01,
            xanchor="left",
            **at_top,
        ),
        height=height,
        font=_FONT,
        template="plotly_white",
        margin=dict(l=60, r=20, t=130 + LINE_PX * len(counts), b=110),
        hoverlabel=dict(align="left", bgcolor="white", font=dict(size=12)),
        legend=legend,
        legend2=dict(title=dict(text="task"), x=1.02, y=0, yanchor="bottom"),
        sliders=[_slider(problem.horizon)],
        updatemenus=[_play_buttons()],
    )
    _axes(fig, problem)


def _axes(fig: go.Figure, problem: Problem) -> None:
    """The map's axes over the workspace, one unit as long on both; the timeline's axes."""
    (xl, xh), (yl, yh) = workspace(problem)
    fig.update_xaxes(
        range=[xl, xh],
        title=dict(text="x"),
        constrain="domain",
        constraintoward="left",
        row=1,
        col=1,
    )
    fig.update_yaxes(
        range=[yl, yh],
        title=dict(text="y"),
        scaleanchor="x",
        scaleratio=1,
        constrain="domain",
        constraintoward="top",
        row=1,
        col=1,
    )
    xaxis, yaxis, lines = timeline.timeline_axes(problem)
    fig.update_xaxes(xaxis, row=1, col=2)
    fig.update_yaxes(yaxis, row=1, col=2)
    fig.update_layout(shapes=lines)


def write_viewer(
    problem: Problem,
    trajectory: Trajectory,
    report: MonitorReport,
    path: str | os.PathLike[str],
    title: str | None = None,
) -> None:
    """Write ``plan.html`` to ``path`` (atomically): the viewer with plotly.js inline, packed
    (:mod:`stlplan.outputs.viewer.packed`), so the page opens from disk with no network.

    Parameters
    ----------
    problem, trajectory, report
        The mission, the team trajectory, and the monitor's verdicts on it (groups, runs).
    path
        Where to write the HTML file.
    title
        Page and figure title, e.g. ``"farm: optimal"``; default the mission name.
    """
    title = title or problem.mission.name
    fig = viewer_figure(problem, trajectory, report, title)
    page = packed.page(fig.to_json(), _CONFIG, title, int(fig.layout.height))

    def write(tmp: Path) -> None:
        tmp.write_text(page, encoding="utf-8")

    write_atomically(path, write)
