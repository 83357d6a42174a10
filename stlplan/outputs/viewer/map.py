"""The viewer's map: regions as ``plan.png`` draws them, the agents' paths with a hover text per
step, the agents' markers at one step, and the segments that cross an obstacle or an agent."""

from __future__ import annotations

import html
from typing import Any

import numpy as np
import plotly.graph_objects as go
from matplotlib.colors import to_rgba

from stlplan.mission.problem import Problem
from stlplan.monitor.crossings import crossing_segments
from stlplan.outputs.plots.common import (
    MANY_AGENTS,
    _capability_key,
    _run_steps,
    _sync_verdicts,
    spread,
    task_service,
    workspace,
)
from stlplan.outputs.plots.past import step_note
from stlplan.outputs.plots.plan import region_patches
from stlplan.outputs.plots.team import notes_at, team_marks
from stlplan.result import MonitorReport, Trajectory

GOLD = "goldenrod"
"""The ring of a step in a synchronized run, and the run's shading on the timeline."""
HOVER = "%{hovertext}<extra></extra>"
"""A point's hover label: its text alone, without the trace's name beside it."""
_RED = "rgb(214,39,40)"
_SYMBOLS = {"o": "circle", "s": "square", "^": "triangle-up", "D": "diamond"}
_SYMBOLS |= {"v": "triangle-down", "P": "cross", "X": "x", "h": "hexagon"}
"""plotly's name of each matplotlib marker of :func:`~stlplan.outputs.plots.common.agent_styles`."""
_MARKER_PX, _NAME_PX = 18, 12
"""The size of an agent's marker at the slider's step, and of its name, pixels."""
_HATCH_LINES = 60
"""An obstacle's hatching has a line every ``1 / _HATCH_LINES`` of the workspace's longer side."""
_LABEL_SCALE = 72 * 9.0
"""Points across the map's width when placing region names, as on ``plan.png``."""

Style = tuple[str, tuple[float, ...]]
"""An agent's matplotlib marker and colour."""
Entry = tuple[str, str, bool]
"""An agent's legend group, its legend label, and whether its path carries the legend entry."""


def rgba(color: Any, alpha: float | None = None) -> str:
    """A matplotlib colour as CSS ``rgba(r,g,b,a)``; ``alpha`` replaces its own when given."""
    r, g, b, a = to_rgba(color)
    a = a if alpha is None else alpha
    return f"rgba({round(255 * r)},{round(255 * g)},{round(255 * b)},{a:g})"


def _number(value: float) -> str:
    return f"{float(value) + 0.0:.3g}"  # + 0.0 turns -0 into 0


# ------------------------------------------------------------------------------------- hover text
def hover_texts(
    problem: Problem, trajectory: Trajectory, report: MonitorReport
) -> dict[str, list[str]]:
    """Agent name -> one hover text per step ``k = 0..H``.

    Each names the agent and its capability, the step ``k`` (for a replan, whether it is
    executed, of the new plan or after the agent was lost), the state ``x(k)`` (every
    component), and the tasks the agent serves at ``k``: those of
    :func:`~stlplan.outputs.plots.common.task_service`, with the regions of its role it is inside
    and whether ``k`` lies in the task's synchronized run; then each count that finds it inside
    its region at ``k`` and each visit it makes at ``k``
    (:func:`~stlplan.outputs.plots.team.notes_at`).
    """
    service = task_service(problem, trajectory, report)
    runs = {v.name: _run_steps(v) for v in _sync_verdicts(report)}
    marks = team_marks(problem, trajectory)
    texts = {}
    for agent in problem.agents:
        head = f"<b>{html.escape(agent.name)}</b> ({html.escape(_capability_key(agent))})"
        rows = []
        for k, state in enumerate(trajectory.states[agent.name]):
            values = ", ".join(_number(v) for v in state)
            counted = [html.escape(note) for note in notes_at(marks, agent.name, k)]
            served = _served_at(service[agent.name], runs, k)
            served = "<br>".join(filter(None, [served, *counted])) or "serves no task"
            when = step_note(problem, agent.name, k)
            rows.append(f"{head}<br>step k = {k}{when}<br>state x = ({values})<br>{served}")
        texts[agent.name] = rows
    return texts


def _served_at(tasks: dict[str, dict[int, tuple[str, ...]]], runs: dict[str, range], k: int) -> str:
    lines = []
    for task, steps in tasks.items():
        if k in steps:
            where = ", ".join(html.escape(r) for r in steps[k])
            sync = " (synchronized run)" if k in runs.get(task, ()) else ""
            lines.append(f"serves {html.escape(task)} in {where}{sync}")
    return "<br>".join(lines)


# ---------------------------------------------------------------------------------------- regions
def region_traces(problem: Problem, trajectory: Trajectory) -> tuple[list[go.Scatter], list[dict]]:
    """A filled polygon per region, largest first, coloured as on ``plan.png`` (obstacles grey
    and hatched), and its name as an annotation placed away from the paths."""
    bounds = workspace(problem)
    (xl, xh), (yl, yh) = bounds
    points = np.vstack([trajectory.position(a.name, a.position) for a in problem.agents])
    spacing = max(xh - xl, yh - yl) / _HATCH_LINES
    traces, labels = [], []
    for patch in region_patches(problem, bounds, points, _LABEL_SCALE / (xh - xl)):
        style, (x, y) = patch.style, np.vstack([patch.vertices, patch.vertices[:1]]).T
        edge = rgba(style["edgecolor"], min(1.0, 2 * style["alpha"]))
        traces.append(
            go.Scatter(
                x=x,
                y=y,
                mode="lines",
                fill="toself",
                fillcolor=rgba(style["facecolor"], style["alpha"]),
                line=dict(color=edge, width=1.2),
                name=patch.name,
                hoveron="fills",
                hoverinfo="name",
                showlegend=False,
            )
        )
        if style.get("hatch"):
            traces.append(_hatch_trace(patch.vertices, spacing, rgba(style["edgecolor"], 0.7)))
        labels.append(_region_label(patch.name, patch.label_at))
    return traces, labels


def hatch_segments(vertices: np.ndarray, spacing: float) -> list[np.ndarray]:
    """The parts inside a convex polygon of the lines ``x - y = c``, ``c`` a multiple of
    ``spacing``: the hatching of an obstacle, each part as its two ends (shape ``(2, 2)``).

    The line crosses the edge from ``a`` to ``b`` where ``s(z) = x - y - c`` changes sign, at
    ``a + s(a) / (s(a) - s(b)) (b - a)``; inside a convex polygon it runs between the crossings
    farthest apart.
    """
    levels = vertices[:, 0] - vertices[:, 1]
    ends = np.roll(vertices, -1, axis=0)
    segments = []
    for c in spacing * np.arange(np.ceil(levels.min() / spacing), levels.max() / spacing):
        sa, sb = levels - c, np.roll(levels, -1) - c
        crossing = (sa * sb <= 0) & (sa != sb)
        t = sa[crossing] / (sa[crossing] - sb[crossing])
        found = vertices[crossing] + t[:, None] * (ends[crossing] - vertices[crossing])
        if len(found) >= 2:
            along = found.sum(axis=1)  # x + y orders the points along the line
            segments.append(found[[np.argmin(along), np.argmax(along)]])
    return segments


def _hatch_trace(vertices: np.ndarray, spacing: float, color: str) -> go.Scatter:
    # plotly's own fill patterns fail while the markers move (plotly.js 4), so lines draw them
    xs: list[float | None] = []
    ys: list[float | None] = []
    for segment in hatch_segments(vertices, spacing):
        xs += [*segment[:, 0].tolist(), None]
        ys += [*segment[:, 1].tolist(), None]
    line = dict(color=color, width=1)
    return go.Scatter(x=xs, y=ys, mode="lines", line=line, hoverinfo="skip", showlegend=False)


def _region_label(name: str, at: np.ndarray) -> dict:
    return dict(
        text=f"<b>{html.escape(name)}</b>",
        x=float(at[0]),
        y=float(at[1]),
        xref="x",
        yref="y",
        showarrow=False,
        font=dict(size=12, color="#262626"),
        bgcolor="rgba(255,255,255,0.6)",
    )


# ----------------------------------------------------------------------------------------- agents
def legend_entries(problem: Problem) -> dict[str, Entry]:
    """Agent name -> its legend group, label and whether it carries the entry: one entry per
    agent up to :data:`MANY_AGENTS` agents (as on ``plan.png``), one per capability beyond (its
    middle agent's path, labelled with the head count); clicking an entry hides its group."""
    if len(problem.agents) <= MANY_AGENTS:
        return {a.name: (a.name, f"{a.name} ({_capability_key(a)})", True) for a in problem.agents}
    by_key: dict[str, list[str]] = {}
    for agent in problem.agents:
        by_key.setdefault(_capability_key(agent), []).append(agent.name)
    return {
        name: (key, f"{key} ({len(names)} agents)", name == names[len(names) // 2])
        for key, names in by_key.items()
        for name in names
    }


def path_trace(
    z: np.ndarray,
    style: Style,
    entry: Entry,
    hover: list[str],
    sync,
    first: int = 0,
    dash: str | None = None,
) -> go.Scatter:
    """An agent's path ``z`` (shape ``(H + 1, 2)``, or the part of it from step ``first`` on):
    an open point per step, the start filled with a black edge, the steps ``sync`` of a
    synchronized run filled and ringed in gold; its line solid, or in plotly's ``dash`` style. A part from
    a later step than 0 carries no legend entry (the part from step 0 does)."""
    symbol, color = _SYMBOLS[style[0]], rgba(style[1])
    steps = range(first, first + len(z))
    edges = ["black" if k == 0 else GOLD if k in sync else color for k in steps]
    marker = dict(
        symbol=symbol,
        size=[9 if k == 0 or k in sync else 6 for k in steps],
        color=[color if k == 0 or k in sync else "white" for k in steps],
        line=dict(color=edges, width=[2.5 if k in sync else 1.5 for k in steps]),
    )
    group, label, shown = entry
    return go.Scatter(
        x=z[:, 0],
        y=z[:, 1],
        mode="lines+markers",
        line=dict(color=color, width=2) | ({} if dash is None else dict(dash=dash)),
        marker=marker,
        name=label,
        legendgroup=group,
        showlegend=shown and first == 0,
        hovertext=hover,
        hovertemplate=HOVER,
    )


def marker_trace(name: str, style: Style, entry: Entry) -> go.Scatter:
    """Where the agent is at the slider's step (the frames give its place, its hover text and
    whether its name shows): a large filled marker, its name above and to the right."""
    color = rgba(style[1])
    return go.Scatter(
        mode="markers+text",
        textposition="top right",
        cliponaxis=False,
        textfont=dict(size=12, color=color),
        marker=dict(
            symbol=_SYMBOLS[style[0]], size=16, color=color, line=dict(color="black", width=1.5)
        ),
        name=name,
        legendgroup=entry[0],
        showlegend=False,
        hovertemplate=HOVER,
    )


def names_shown(names: list[str], points: np.ndarray, px_per_unit: float) -> list[str]:
    """Each agent's name, or ``""`` where it would cover a marker or a name shown before it.

    ``points`` (shape ``(n, 2)``) are the agents' positions, ``px_per_unit`` the map's pixels per
    unit; a name's box sits above and to the right of its marker, as ``textposition="top right"``
    draws it, and :func:`~stlplan.outputs.plots.common.spread` keeps the boxes that miss the others.
    """
    at = points * px_per_unit
    size = np.array([[0.33 * _NAME_PX * len(n) + 2, 0.5 * _NAME_PX + 2] for n in names])
    centers = at + size + _MARKER_PX / 2
    dots = np.full_like(at, _MARKER_PX / 2)
    keep = spread(np.vstack([at, centers]), np.vstack([dots, size]), fixed=len(names))
    return [n if shown else "" for n, shown in zip(names, keep[len(names) :], strict=True)]


def crossing_trace(problem: Problem, trajectory: Trajectory) -> go.Scatter | None:
    """The segments a robot would follow through an obstacle or another agent, in red; None
    when there are none."""
    xs: list[float | None] = []
    ys: list[float | None] = []
    for name, k in crossing_segments(problem, trajectory):
        z = trajectory.position(name, problem.agent(name).position)[k : k + 2]
        xs += [*z[:, 0].tolist(), None]
        ys += [*z[:, 1].tolist(), None]
    if not xs:
        return None
    return go.Scatter(
        x=xs,
        y=ys,
        mode="lines",
        line=dict(color=_RED, width=5),
        opacity=0.8,
        name="unsafe between steps",
        hoverinfo="skip",
    )
