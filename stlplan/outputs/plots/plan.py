"""The map figure (``plan.png``): workspace, regions, agents' paths and synchronized runs."""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Polygon

import stlplan.outputs.plots.team as team
from stlplan.mission.problem import Problem
from stlplan.monitor.crossings import crossing_segments
from stlplan.outputs.plots.common import (
    _AXES,
    _LEGEND,
    _PATH,
    _POINTS,
    _REGION_LABEL,
    _START,
    _SYNC,
    DPI,
    MANY_AGENTS,
    _group_agents,
    _run_steps,
    _status_line,
    _sync_verdicts,
    _titles,
    agent_handles,
    agent_styles,
    polygon_area,
    region_styles,
    region_vertices,
    save_figure,
    spread,
    sync_caption,
    workspace,
)
from stlplan.outputs.plots.past import draw_path, draw_replan_marks, events_note, replan_handles
from stlplan.result import MonitorReport, Trajectory

_CROSSING: dict[str, Any] = dict(
    color="#d62728", linewidth=3.2, alpha=0.85, solid_capstyle="round", zorder=4
)
"""A segment of a path that enters an obstacle or another agent's separation box."""
_NAME_SIZE = 7


def _label_spot(vertices: np.ndarray, name: str, avoid: np.ndarray, pt_per_unit: float):
    # among the centre and points pulled 35% inwards from corners and edge midpoints, the one
    # farthest (in label sizes, max-norm) from the trajectory points and the labels placed so far
    center = vertices.mean(axis=0)
    rim = np.vstack([vertices, (vertices + np.roll(vertices, -1, axis=0)) / 2])
    spots = np.vstack([center, rim + 0.35 * (center - rim)])
    half = (np.array([0.33 * 9 * len(name), 6.0]) + 8.0) / pt_per_unit  # + marker size
    if not len(avoid):
        return center
    gaps = np.abs(spots[:, None, :] - avoid[None, :, :]) / half
    score = np.minimum(gaps.max(axis=2).min(axis=1), 1.5)
    return spots[int(np.argmax(score))]


@dataclass(frozen=True)
class RegionPatch:
    """A region as the map draws it."""

    name: str
    vertices: np.ndarray
    """Corners of the region clipped to the workspace, counter-clockwise, shape (n, 2)."""
    area: float
    style: dict[str, Any]
    """Keywords of its :class:`~matplotlib.patches.Polygon`: face and edge colour, alpha, hatch."""
    label_at: np.ndarray
    """Where its name goes: the spot farthest from the points to avoid and the names before it."""


def region_patches(
    problem: Problem, bounds, avoid: np.ndarray, pt_per_unit: float
) -> list[RegionPatch]:
    """The regions with some area inside ``bounds``, largest first (the order they are drawn in).

    Regions are styled by :func:`~stlplan.outputs.plots.common.region_styles`. Names are placed
    smallest region first, each away from ``avoid`` (points, e.g. the paths) and the names placed
    before it, at ``pt_per_unit`` points of the figure per unit of the map.
    """
    shapes = {n: region_vertices(r, bounds) for n, r in problem.regions.items()}
    areas = {n: polygon_area(v) for n, v in shapes.items() if len(v)}
    styles = region_styles(problem, bounds)
    spots = {}
    for name in sorted(areas, key=areas.__getitem__):  # small regions first
        spots[name] = _label_spot(shapes[name], name, avoid, pt_per_unit)
        avoid = np.vstack([avoid, spots[name]])
    return [RegionPatch(n, shapes[n], areas[n], styles[n], spots[n]) for n in styles]


def _draw_regions(ax, problem: Problem, bounds, avoid: np.ndarray, pt_per_unit: float) -> None:
    patches = region_patches(problem, bounds, avoid, pt_per_unit)
    for patch in patches:
        ax.add_patch(Polygon(patch.vertices, closed=True, linewidth=1.2, zorder=1, **patch.style))
    for patch in sorted(patches, key=lambda p: p.area):
        ax.text(*patch.label_at, patch.name, **_REGION_LABEL)


def _step_clusters(points: np.ndarray, eps: float) -> list[tuple[int, int]]:
    # consecutive steps whose positions stay within eps of the first one share one label
    clusters, start = [], 0
    for k in range(1, len(points) + 1):
        if k == len(points) or np.max(np.abs(points[k] - points[start])) > eps:
            clusters.append((start, k - 1))
            start = k
    return clusters


def _draw_agent(ax, problem: Problem, name: str, z: np.ndarray, eps: float | None, styles) -> None:
    """The agent's path (:func:`~stlplan.outputs.plots.past.draw_path`) and start; with
    ``eps``, step labels (one per cluster of steps)."""
    marker, color = styles[name]
    draw_path(ax, problem, name, z, color=color, marker=marker, **_PATH)
    ax.plot(z[0, 0], z[0, 1], marker=marker, markerfacecolor=color, **_START)
    for first, last in _step_clusters(z, eps) if eps is not None else ():
        if first == 0 and last == 0:
            continue  # the start marker already says "step 0"
        label = str(first) if first == last else f"{first}-{last}"
        ax.annotate(label, z[first], color=color, **_POINTS)


def _draw_sync_runs(ax, problem: Problem, trajectory: Trajectory, report, styles) -> list[str]:
    captions = []
    for verdict in _sync_verdicts(report):
        steps = list(_run_steps(verdict))
        for name in _group_agents(verdict) if steps else ():
            marker, color = styles[name]
            z = trajectory.position(name, problem.agent(name).position)[steps]
            ax.plot(z[:, 0], z[:, 1], marker=marker, markerfacecolor=color, **_SYNC)
        captions.append(sync_caption(verdict))
    return captions


def _draw_crossings(ax, problem: Problem, trajectory: Trajectory) -> bool:
    """Segments a robot would follow through an obstacle or another agent, in red."""
    cuts = crossing_segments(problem, trajectory)
    for name, k in cuts:
        z = trajectory.position(name, problem.agent(name).position)[k : k + 2]
        ax.plot(z[:, 0], z[:, 1], **_CROSSING)
    return bool(cuts)


def _draw_end_names(ax, problem: Problem, trajectory: Trajectory, styles, pt_per_unit) -> None:
    """Each agent's name at its last position, left out where it would cover a name drawn."""
    ends = np.array([trajectory.position(a.name, a.position)[-1] for a in problem.agents])
    half = np.array([[0.3 * _NAME_SIZE * len(a.name) + 1, 4.0] for a in problem.agents])
    centers = ends + (half + _POINTS["xytext"]) / pt_per_unit  # up and right of the point
    dot = np.full_like(ends, _PATH["markersize"] / 2 / pt_per_unit)
    boxes = np.vstack([ends, centers]), np.vstack([dot, half / pt_per_unit])
    shown = spread(*boxes, fixed=len(ends))[len(ends) :]
    for agent, end, keep in zip(problem.agents, ends, shown, strict=True):
        if keep:
            color = styles[agent.name][1]
            ax.annotate(agent.name, end, color=color, **{**_POINTS, "fontsize": _NAME_SIZE})


def _plan_legend(
    ax,
    problem: Problem,
    styles,
    has_sync: bool,
    crossed: bool = False,
    extra: Sequence[Artist] = (),
) -> None:
    handles: list[Artist] = [*agent_handles(problem, styles)]
    handles.append(Line2D([], [], marker="o", mfc="0.6", label="start (step 0)", **_START))
    if has_sync:
        handles.append(Line2D([], [], marker="o", mfc="0.6", label="synchronized run", **_SYNC))
    if crossed:
        handles.append(Line2D([], [], label="unsafe between steps", **_CROSSING))
    handles += replan_handles(problem)
    handles += extra
    title = "agent (capability)" if len(problem.agents) <= MANY_AGENTS else "capability"
    legend_at = dict(loc="upper left", bbox_to_anchor=(1.01, 1.0), title=title)
    ax.legend(handles=handles, **legend_at, **_LEGEND)


def plan_figure(
    problem: Problem,
    trajectory: Trajectory,
    report: MonitorReport,
    title: str | None = None,
    overlay: Callable[[Axes], list[Artist]] | None = None,
) -> Figure:
    """The map: workspace, regions, each agent's path (the straight segments a robot follows
    between waypoints), starts, synchronized runs, a star at each visit a ``visits`` counts and
    a caption per ``count`` and ``visits`` (:mod:`~stlplan.outputs.plots.team`), and in red any
    segment that crosses; for a replan (``problem.past``) the marks of
    :mod:`~stlplan.outputs.plots.past`. ``overlay`` draws more on the map's axes and returns its
    legend entries (a simulated run's, :mod:`~stlplan.outputs.plots.executed`)."""
    bounds = workspace(problem)
    (xl, xh), (yl, yh) = bounds
    width = 9.0
    fig = Figure(figsize=(width + 2.2, width * (yh - yl) / (xh - xl) + 1.2), dpi=DPI)
    ax = fig.add_subplot()
    points = np.vstack([trajectory.position(a.name, a.position) for a in problem.agents])
    pt_per_unit = 72 * width / (xh - xl)
    step_labels = points + np.array([12.0, 6.0]) / pt_per_unit
    _draw_regions(ax, problem, bounds, np.vstack([points, step_labels]), pt_per_unit)
    styles = agent_styles(problem)
    many = len(problem.agents) > MANY_AGENTS
    eps = None if many else 0.01 * max(xh - xl, yh - yl)
    for agent in problem.agents:
        z = trajectory.position(agent.name, agent.position)
        _draw_agent(ax, problem, agent.name, z, eps, styles)
    if many:
        _draw_end_names(ax, problem, trajectory, styles, pt_per_unit)
    crossed = _draw_crossings(ax, problem, trajectory)
    draw_replan_marks(ax, problem, trajectory)
    extra = overlay(ax) if overlay is not None else []
    captions = _draw_sync_runs(ax, problem, trajectory, report, styles)
    visits, counts = team.draw_on_map(ax, problem, trajectory, pt_per_unit)
    ax.set(xlim=(xl, xh), ylim=(yl, yh), aspect="equal", xlabel="x", ylabel="y")
    ax.tick_params(labelsize=8)
    ax.grid(True, color="0.9", linewidth=0.6)
    ax.set_axisbelow(True)
    _plan_legend(ax, problem, styles, bool(captions), crossed, [*extra, *visits])
    subtitle = _status_line(report)
    if problem.past is not None:
        subtitle = f"{events_note(problem.past)}   |   {subtitle}"
    _titles(ax, title or problem.mission.name, subtitle)
    for i, caption in enumerate([*captions, *counts]):
        ax.annotate(caption, (0.0, -0.09 - 0.05 * i), va="top", fontsize=9, **_AXES)
    return fig


def plot_plan(
    problem: Problem,
    trajectory: Trajectory,
    report: MonitorReport,
    path: str | os.PathLike[str],
    title: str | None = None,
) -> None:
    """Draw ``plan.png``: the map with regions, trajectories by capability, synchronized runs.

    Parameters
    ----------
    problem, trajectory, report
        The mission, the team trajectory, and the monitor's verdicts on it (groups, runs).
    path
        Where to write the PNG (written atomically).
    title
        Figure title, e.g. ``"farm: optimal"``; default the mission name.
    """
    save_figure(plan_figure(problem, trajectory, report, title), path)
