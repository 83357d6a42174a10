"""The viewer's timeline: one row per agent over steps ``0..H``, a bar where the agent serves a
task (one lane per task it serves, as on ``timeline.png``), the synchronized runs shaded, and a
dashed line at the slider's step."""

from __future__ import annotations

import html
from collections.abc import Sequence

import plotly.graph_objects as go

from stlplan.mission.problem import Problem
from stlplan.outputs.plots.common import (
    Service,
    _capability_key,
    _group_agents,
    _run_steps,
    _sync_verdicts,
    task_colors,
    workspace,
)
from stlplan.outputs.plots.team import TeamMark, lane_box, marks_of
from stlplan.outputs.plots.timeline import _segments, _smallest
from stlplan.outputs.viewer.map import GOLD, HOVER, rgba
from stlplan.result import MonitorReport

TIMELINE_PX = 420
"""About the timeline's width in a window 1400 pixels wide, pixels: whether a bar's label fits."""
_LABEL_PX = 11
"""The size of a bar's label, pixels."""

Box = tuple[float, float, float, float]
"""A rectangle ``(x0, x1, y0, y1)`` on the timeline, in steps and rows."""


def rows(problem: Problem) -> dict[str, int]:
    """The timeline's row of each agent: the mission's first agent on top."""
    return {a.name: len(problem.agents) - 1 - i for i, a in enumerate(problem.agents)}


def task_bars(
    problem: Problem, service: Service, marks: Sequence[TeamMark] = ()
) -> tuple[list[go.Scatter], list[dict]]:
    """A trace of bars per task (a task that only counts has none), one of their labels, and a
    faint background shape per lane.

    An agent serving ``n`` tasks has ``n`` lanes in its row, one per task in the mission's
    order, then one per count or visits of ``marks`` that finds it
    (:mod:`~stlplan.outputs.viewer.team` draws those); a bar covers the steps ``first..last`` of
    each run of consecutive steps in which the agent is inside the same regions of its role,
    labelled with the smallest of them where the label fits. The bars are filled polygons rather
    than plotly bars, which plotly.js 4 stops drawing while the markers of another subplot move.
    """
    colors, where, bounds = task_colors(problem), rows(problem), workspace(problem)
    boxes: dict[str, list[Box]] = {t.name: [] for t in problem.tasks if t.roles}
    labels: list[tuple[float, float, str, str]] = []  # centre, label, hover text
    lanes = []
    for name, tasks in service.items():
        count = len(tasks) + len(marks_of(list(marks), name))
        for lane, (task, steps) in enumerate(tasks.items()):
            y0, height = lane_box(where[name], lane, count)
            lanes.append(_lane_background(problem.horizon, (y0, height), colors[task]))
            for first, last, regions in _segments(steps):
                boxes[task].append(
                    (first - 0.45, last + 0.45, y0 + 0.05 * height, y0 + 0.95 * height)
                )
                label = _smallest(problem, regions, bounds)
                fits = _LABEL_PX * 0.62 * len(label) <= _step_px(problem) * (last - first + 0.9)
                hover = _bar_hover(task, name, regions, first, last)
                labels.append(((first + last) / 2, y0 + height / 2, label if fits else "", hover))
    fill = {t: dict(fillcolor=rgba(colors[t]), line=dict(color="white", width=0.8)) for t in boxes}
    traces = [_filled(boxes[task], task, fill[task]) for task in boxes]
    return [*traces, _label_trace(labels)], lanes


def _step_px(problem: Problem) -> float:
    return TIMELINE_PX / (problem.horizon + 1.2)


def _filled(boxes: list[Box], name: str, style: dict) -> go.Scatter:
    """Rectangles as one trace, each closed and filled on its own (separated by gaps)."""
    xs: list[float | None] = []
    ys: list[float | None] = []
    for x0, x1, y0, y1 in boxes:
        xs += [x0, x1, x1, x0, x0, None]
        ys += [y0, y0, y1, y1, y0, None]
    return go.Scatter(
        x=xs,
        y=ys,
        mode="lines",
        fill="toself",
        name=name,
        hoveron="fills",
        hoverinfo="name",
        legend="legend2",
        **style,
    )


def _label_trace(labels: list[tuple[float, float, str, str]]) -> go.Scatter:
    """The bars' labels, and a hover text at each bar's centre: the task, agent, regions, steps."""
    x, y, text, hover = zip(*labels, strict=True) if labels else ((), (), (), ())
    return go.Scatter(
        x=x,
        y=y,
        mode="text",
        text=text,
        textfont=dict(size=_LABEL_PX, color="white"),
        hovertext=hover,
        hovertemplate=HOVER,
        showlegend=False,
    )


def _bar_hover(task: str, agent: str, regions: tuple[str, ...], first: int, last: int) -> str:
    steps = f"step {first}" if first == last else f"steps {first}-{last}"
    where = ", ".join(html.escape(r) for r in regions)
    return f"<b>{html.escape(task)}</b>: {html.escape(agent)} in {where}<br>{steps}"


def _lane_background(horizon: int, lane: tuple[float, float], color, first: int = 0) -> dict:
    """A lane's faint background over steps ``first..horizon``."""
    y0, height = lane
    return dict(
        type="rect",
        xref="x2",
        yref="y2",
        x0=first - 0.5,
        x1=horizon + 0.5,
        y0=y0,
        y1=y0 + height,
        fillcolor=rgba(color, 0.12),
        line=dict(width=0),
        layer="below",
    )


def sync_bars(problem: Problem, report: MonitorReport) -> list[go.Scatter]:
    """Each synchronous task's synchronized run, shaded in gold across its group's rows (the page's
    subtitle gives each run's steps and ``rho_s``)."""
    where, traces = rows(problem), []
    for verdict in _sync_verdicts(report):
        steps = _run_steps(verdict)
        if not steps:
            continue
        boxes = [
            (steps[0] - 0.5, steps[-1] + 0.5, where[n] - 0.5, where[n] + 0.5)
            for n in _group_agents(verdict)
        ]
        style = dict(fillcolor=rgba(GOLD, 0.3), line=dict(color="darkgoldenrod", width=1.2))
        traces.append(_filled(boxes, html.escape(f"{verdict.name} synchronized run"), style))
    return traces


def cursor_trace(problem: Problem) -> go.Scatter:
    """The slider's step on the timeline (the frames give its place): a dashed line across the
    agents' rows."""
    return go.Scatter(
        y=[-0.6, len(problem.agents) - 0.4],
        mode="lines",
        line=dict(color="rgba(40,40,40,0.85)", width=2, dash="dash"),
        name="step",
        hoverinfo="skip",
        showlegend=False,
    )


def idle_notes(problem: Problem, service: Service, marks: Sequence[TeamMark] = ()) -> list[dict]:
    """``no task`` across the row of each agent that serves none and no count finds."""
    where, counted = rows(problem), {a for m in marks for a in m.steps}
    return [
        dict(
            text="<i>no task</i>",
            x=problem.horizon / 2,
            y=where[name],
            xref="x2",
            yref="y2",
            showarrow=False,
            font=dict(size=11, color="#999"),
        )
        for name, tasks in service.items()
        if not tasks and name not in counted
    ]


def timeline_axes(problem: Problem) -> tuple[dict, dict, list[dict]]:
    """The x axis (steps), the y axis (agents, named with their capability) and the lines
    between rows."""
    horizon, count = problem.horizon, len(problem.agents)
    xaxis = dict(
        range=[-0.6, horizon + 0.6],
        dtick=1 if horizon <= 30 else (horizon + 29) // 30,
        title=dict(text="step k"),
        showgrid=True,
        gridcolor="#eee",
        zeroline=False,
    )
    where = rows(problem)
    yaxis = dict(
        range=[-0.6, count - 0.4],
        tickvals=[where[a.name] for a in problem.agents],
        ticktext=[f"{a.name} ({_capability_key(a)})" for a in problem.agents],
        showgrid=False,
        zeroline=False,
    )
    lines = [
        dict(
            type="line",
            xref="x2 domain",
            yref="y2",
            x0=0,
            x1=1,
            y0=y - 0.5,
            y1=y - 0.5,
            line=dict(color="#ccc", width=0.8),
            layer="below",
        )
        for y in range(count + 1)
    ]
    return xaxis, yaxis, lines
