"""How the viewer draws the team's counts, as the figures do (:mod:`stlplan.outputs.plots.team`):
on the map a star at the place of each visit; on the timeline, after each agent's task lanes, a
lane per count or visits that finds it, with a thin bar where the count finds the agent inside
its region or a numbered star at each of its visits. The hover texts
(:func:`~stlplan.outputs.viewer.map.hover_texts`) and the page's subtitle say the same in words."""

from __future__ import annotations

import html
from collections.abc import Sequence

import numpy as np
import plotly.graph_objects as go

from stlplan.mission.problem import Problem
from stlplan.outputs.plots.common import Service
from stlplan.outputs.plots.team import (
    TeamMark,
    caption,
    lane_box,
    marks_of,
    step_runs,
    visit_names,
)
from stlplan.outputs.viewer.map import HOVER, rgba
from stlplan.outputs.viewer.timeline import _filled, _lane_background, rows
from stlplan.result import Trajectory

_STAR = dict(symbol="star", line=dict(color="white", width=1))
"""A visit's marker (its size and colour aside)."""


def _visit_hover(mark: TeamMark) -> dict[tuple[str, int], str]:
    names = visit_names(mark)
    return {
        (a, k): f"<b>{html.escape(name)}</b><br>{html.escape(a)} enters at step {k}"
        for (a, k), name in names.items()
    }


def entry_traces(
    problem: Problem, trajectory: Trajectory, marks: Sequence[TeamMark], colors
) -> list[go.Scatter]:
    """A trace per visits on the map, in the map's legend: a star at the place of each entry,
    its hover text the visit's number, the agent and the step."""
    traces = []
    for mark in (m for m in marks if m.visits and m.steps):
        entries, hover = mark.entries(), _visit_hover(mark)
        at = np.array([trajectory.position(a, problem.agent(a).position)[k] for a, k in entries])
        traces.append(
            go.Scatter(
                x=at[:, 0],
                y=at[:, 1],
                mode="markers",
                marker=dict(size=16, color=rgba(colors[mark.region][1]), **_STAR),
                name=html.escape(mark.label),
                hovertext=[hover[e] for e in entries],
                hovertemplate=HOVER,
            )
        )
    return traces


def _lane(problem: Problem, service: Service, marks, mark: TeamMark, agent: str):
    """``(bottom, height)`` of ``mark``'s lane in ``agent``'s row: after its tasks' lanes."""
    counted, tasks = marks_of(marks, agent), len(service[agent])
    return lane_box(rows(problem)[agent], tasks + counted.index(mark), tasks + len(counted))


def lane_traces(
    problem: Problem, service: Service, marks: Sequence[TeamMark], colors
) -> tuple[list[go.Scatter], list[dict]]:
    """A trace per count or visits on the timeline, in the task legend (a count's thin bars, a
    visits' numbered stars), and each of its lanes' faint background over its window."""
    traces, backgrounds = [], []
    for mark in (m for m in marks if m.steps):
        (face, dark), (first, last) = colors[mark.region], mark.window
        lanes = {a: _lane(problem, service, marks, mark, a) for a in mark.steps}
        backgrounds += [_lane_background(last, lane, face, first) for lane in lanes.values()]
        if mark.visits:
            traces.append(_stars(mark, lanes, rgba(dark)))
            continue
        boxes = [
            (k0 - 0.45, k1 + 0.45, y0 + 0.28 * height, y0 + 0.72 * height)
            for a, (y0, height) in lanes.items()
            for k0, k1 in step_runs(mark.steps[a])
        ]
        style = dict(fillcolor=rgba(face), line=dict(color=rgba(dark), width=0.8))
        traces.append(_filled(boxes, html.escape(mark.label), style))
    return traces, backgrounds


def _stars(mark: TeamMark, lanes, color: str) -> go.Scatter:
    """A visits' stars on the timeline, each numbered: the visit's place among them all."""
    order = {entry: i for i, entry in enumerate(mark.entries(), start=1)}
    hover = _visit_hover(mark)
    stars = [(a, k, y0 + height / 2) for a, (y0, height) in lanes.items() for k in mark.steps[a]]
    return go.Scatter(
        x=[k for _, k, _ in stars],
        y=[y for _, _, y in stars],
        mode="markers+text",
        text=[str(order[a, k]) for a, k, _ in stars],
        textposition="middle right",
        textfont=dict(size=10, color=color),
        marker=dict(size=13, color=color, **_STAR),
        name=html.escape(mark.label),
        legend="legend2",
        hovertext=[hover[a, k] for a, k, _ in stars],
        hovertemplate=HOVER,
    )


def captions(marks: Sequence[TeamMark]) -> list[str]:
    """A line per count and visits (:func:`~stlplan.outputs.plots.team.caption`), escaped."""
    return [html.escape(caption(m)) for m in marks]
