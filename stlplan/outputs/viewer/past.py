"""How the viewer draws a replan (``problem.past``), as the figures do
(:mod:`stlplan.outputs.plots.past`): each path's executed part solid and its new plan dashed, a
ring at each agent's place at the replan's step ``K``, a cross where a lost agent stays, each
closed region hatched, and on the timeline the executed steps shaded, a line at ``K`` and each
lost agent's row greyed from ``K`` on, beneath its bars."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import plotly.graph_objects as go

from stlplan.mission.problem import Problem
from stlplan.outputs.plots.common import workspace
from stlplan.outputs.plots.past import closed_patches, executed_and_planned, places_at_replan
from stlplan.outputs.viewer.map import hatch_segments, rgba
from stlplan.result import Trajectory

INK = "rgb(26,26,26)"
"""The colour of the replan's marks, as on ``plan.png``."""
_HATCH_LINES = 40
"""A closed region's hatching has a line every ``1 / _HATCH_LINES`` of the workspace's longer
side (darker and coarser than an obstacle's)."""

Part = tuple[int, np.ndarray, list[str], str | None]
"""A part of an agent's path: its first step, its points, their hover texts, its line's dash
(None: solid)."""


def path_parts(problem: Problem, name: str, z: np.ndarray, hover: list[str]) -> list[Part]:
    """Agent ``name``'s path ``z`` in the parts the map draws: the whole path solid without a
    past; for a replan the executed steps ``0..K`` solid and the new plan ``K..H`` dashed (none
    for a lost agent, which stays where it was at ``K``)."""
    past = problem.past
    if past is None:
        return [(0, z, hover, None)]
    K = past.step
    executed, planned = executed_and_planned(z, K)
    parts: list[Part] = [(0, executed, hover[: K + 1], None)]
    if name not in past.lost:
        parts.append((K, planned, hover[K:], "dash"))
    return parts


def replan_traces(problem: Problem, trajectory: Trajectory) -> list[go.Scatter]:
    """The map's marks of a replan, each with its legend entry: the executed and planned lines'
    dashes, a ring at each agent's place at ``K``, a cross where each lost agent stays, each
    closed region's outline and hatching (none without a past)."""
    past = problem.past
    if past is None:
        return []
    K = past.step
    ringed, crossed = places_at_replan(problem, trajectory)
    traces = [
        _legend_line(f"executed (steps 0-{K})", "solid"),
        _legend_line(f"new plan (from step {K})", "dash"),
        _points(ringed, f"replan at step {K}", dict(symbol="circle-open", size=24)),
    ]
    if len(crossed):
        lost = ", ".join(sorted(past.lost))
        cross = dict(symbol="x-thin", size=20, line=dict(color=INK, width=4))
        traces.append(_points(crossed, f"lost at step {K}: {lost}", cross))
    (xl, xh), (yl, yh) = workspace(problem)
    spacing = max(xh - xl, yh - yl) / _HATCH_LINES
    for patch in closed_patches(problem):
        traces.append(_closed_trace(patch.get_xy()[:-1], str(patch.get_label()), spacing))
    return traces


def _legend_line(name: str, dash: str) -> go.Scatter:
    line = dict(color="rgb(115,115,115)", width=2, dash=dash)
    return go.Scatter(x=[None], y=[None], mode="lines", line=line, name=name, hoverinfo="skip")


def _points(points: np.ndarray, name: str, marker: dict) -> go.Scatter:
    return go.Scatter(
        x=points[:, 0],
        y=points[:, 1],
        mode="markers",
        marker={"color": INK, "line": dict(color=INK, width=2), **marker},
        name=name,
        hoverinfo="name",
        cliponaxis=False,  # an agent at the workspace's edge
    )


def _closed_trace(vertices: np.ndarray, name: str, spacing: float) -> go.Scatter:
    """A closed region: its outline, then the parts of its hatching, as one trace of lines."""
    outline = np.vstack([vertices, vertices[:1]])
    xs: list[float | None] = [*outline[:, 0].tolist(), None]
    ys: list[float | None] = [*outline[:, 1].tolist(), None]
    for segment in hatch_segments(vertices, spacing):
        xs += [*segment[:, 0].tolist(), None]
        ys += [*segment[:, 1].tolist(), None]
    line = dict(color=rgba("0.1", 0.8), width=1.5)
    return go.Scatter(x=xs, y=ys, mode="lines", line=line, name=name, hoverinfo="name")


def timeline_marks(problem: Problem, rows: Mapping[str, int]) -> tuple[list[dict], list[dict]]:
    """The timeline's shapes and annotations of a replan (none without a past): the executed
    steps shaded, a line at ``K`` and each lost agent's row greyed from ``K`` on, beneath its
    bars (``rows``: agent -> row)."""
    past = problem.past
    if past is None:
        return [], []
    K, H, top = past.step, problem.horizon, len(rows) - 0.4
    executed = dict(fillcolor="rgba(140,140,140,0.14)", line=dict(width=0), layer="below")
    shapes = [
        _on_timeline("rect", (-0.6, K, -0.6, top), **executed),
        _on_timeline("line", (K, K, -0.6, top), line=dict(color=INK, width=2)),
    ]
    replan = dict(text=f"<b>replan at step {K}</b>", x=K, y=top, yanchor="bottom")
    notes = [_note(**replan, font=dict(size=11, color=INK))]
    # beneath the bars: the service a lost agent still gives where it stays is drawn as counted
    greyed = dict(
        fillcolor="rgba(200,200,200,0.35)",
        line=dict(color="#999", width=1, dash="dot"),
        layer="below",
    )
    for name in sorted(past.lost):
        y = rows[name]
        shapes.append(_on_timeline("rect", (K, H + 0.6, y - 0.5, y + 0.5), **greyed))
        lost = dict(text=f"<i>lost at step {K}</i>", x=(K + H + 0.6) / 2, y=y)
        notes.append(_note(**lost, font=dict(size=11, color="#444")))
    return shapes, notes


def _on_timeline(kind: str, box: tuple[float, float, float, float], **style) -> dict:
    x0, x1, y0, y1 = box
    return dict(type=kind, xref="x2", yref="y2", x0=x0, x1=x1, y0=y0, y1=y1, **style)


def _note(**text) -> dict:
    return dict(xref="x2", yref="y2", showarrow=False, **text)
