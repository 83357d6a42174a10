"""The timeline figure (``timeline.png``): which agent serves which task at which step, and the
steps each constraint binds which agents."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.artist import Artist
from matplotlib.figure import Figure
from matplotlib.patches import Patch, Rectangle

import stlplan.outputs.plots.team as team
from stlplan.mission.problem import Problem
from stlplan.outputs.plots.common import (
    _BAR,
    _BAR_LABEL,
    _IDLE,
    _LEGEND,
    _LIMIT,
    _LIMIT_LABEL,
    _LIMIT_VIOLATED,
    _SHADE,
    _TIMELINE_NOTE,
    DPI,
    _capability_key,
    _group_agents,
    _run_steps,
    _sync_verdicts,
    _titles,
    limit_windows,
    polygon_area,
    region_vertices,
    save_figure,
    sync_caption,
    task_colors,
    task_service,
    workspace,
)
from stlplan.outputs.plots.past import events_note, timeline_marks
from stlplan.result import MonitorReport, Trajectory


def _segments(steps: Mapping[int, tuple[str, ...]]) -> list[tuple[int, int, tuple[str, ...]]]:
    # maximal runs of consecutive steps with the same set of regions
    out: list[tuple[int, int, tuple[str, ...]]] = []
    for k in sorted(steps):
        if out and out[-1][1] == k - 1 and out[-1][2] == steps[k]:
            out[-1] = (out[-1][0], k, steps[k])
        else:
            out.append((k, k, steps[k]))
    return out


def _smallest(problem: Problem, names: Sequence[str], bounds) -> str:
    return min(names, key=lambda n: polygon_area(region_vertices(problem.regions[n], bounds)))


def _draw_lane(ax, problem: Problem, lane, steps, style) -> None:
    # lane = (bottom, height); style = (colour, points per step on the x axis)
    (y0, height), (color, step_pt) = lane, style
    background = Rectangle((-0.5, y0), problem.horizon + 1, height, color=color, alpha=0.12)
    ax.add_patch(background)
    bounds, size = workspace(problem), 7 if height > 0.3 else 6
    for first, last, names in _segments(steps):
        width = last - first + 0.9
        corner = (first - 0.45, y0 + 0.05 * height)
        ax.add_patch(Rectangle(corner, width, 0.9 * height, facecolor=color, **_BAR))
        label = _smallest(problem, names, bounds)
        if 0.62 * size * len(label) <= width * step_pt:  # the label fits in the bar
            ax.text((first + last) / 2, y0 + height / 2, label, fontsize=size, **_BAR_LABEL)


def _draw_task_bars(ax, problem, trajectory, report, rows, style) -> None:
    """Per agent, a lane for each task it serves, then one for each count or visits that finds
    it (:mod:`~stlplan.outputs.plots.team`); ``no task`` across the row of an agent with none."""
    (colors, step_pt), (marks, regions) = style
    for name, tasks in task_service(problem, trajectory, report).items():
        counted = team.marks_of(marks, name)
        lanes = len(tasks) + len(counted)
        for lane, (task, steps) in enumerate(tasks.items()):
            box = team.lane_box(rows[name], lane, lanes)
            _draw_lane(ax, problem, box, steps, (colors[task], step_pt))
        for lane, mark in enumerate(counted, start=len(tasks)):
            team.draw_lane(ax, mark, name, team.lane_box(rows[name], lane, lanes), regions)
        if not tasks and not counted:
            ax.text(problem.horizon / 2, rows[name], "no task", **_IDLE)


def _draw_sync_shading(ax, report: MonitorReport, rows) -> list[Patch]:
    handles = []
    for verdict in _sync_verdicts(report):
        steps = _run_steps(verdict)
        if not steps:
            continue
        for name in _group_agents(verdict):
            corner = (steps[0] - 0.5, rows[name] - 0.5)
            ax.add_patch(Rectangle(corner, len(steps), 1, alpha=0.3, lw=1.2, zorder=0, **_SHADE))
        handles.append(Patch(alpha=0.4, label=sync_caption(verdict), **_SHADE))
    return handles


def _timeline_axes(ax, problem: Problem, rows: Mapping[str, int], limits) -> None:
    horizon, count = problem.horizon, len(rows) + len(limits)
    ax.set_xlim(-0.6, horizon + 0.6)
    ax.set_ylim(-0.6, count - 0.4)
    ax.set_xticks(range(0, horizon + 1, 1 if horizon <= 30 else (horizon + 29) // 30))
    labels = [f"{a.name} ({_capability_key(a)})" for a in problem.agents]
    labels += [f"{limit.name} ({limit.kind})" for limit in limits]
    ticks = [rows[a.name] for a in problem.agents] + list(range(len(limits) - 1, -1, -1))
    ax.set_yticks(ticks, labels, fontsize=9)
    for label in ax.get_yticklabels()[len(rows) :]:
        label.set_style("italic")
    if limits:
        ax.axhline(len(limits) - 0.5, color="0.35", linewidth=1.2, zorder=1)
    ax.tick_params(axis="x", labelsize=9)
    ax.set_xlabel("step k", fontsize=10)
    for y in range(count + 1):
        ax.axhline(y - 0.5, color="0.8", linewidth=0.6, zorder=0)
    ax.grid(True, axis="x", color="0.92", linewidth=0.6)
    ax.set_axisbelow(True)


def _draw_limits(ax, problem: Problem, report: MonitorReport, step_pt: float) -> list:
    """One row per constraint (and the separation) under the agents: a hatched bar over the steps
    its formula reads, labelled with the agents it binds; edged in red when the monitor says it
    is violated."""
    verdicts, limits = {v.name: v for v in report.verdicts}, limit_windows(problem)
    for row, limit in zip(range(len(limits) - 1, -1, -1), limits, strict=True):
        verdict = verdicts.get(limit.name)
        style = _LIMIT if verdict is None or verdict.satisfied else _LIMIT_VIOLATED
        first, last = limit.window
        corner, width = (first - 0.45, row - 0.3), last - first + 0.9
        ax.add_patch(Rectangle(corner, width, 0.6, **style))
        everyone = len(limit.binds) == len(problem.agents) > 1
        text = (
            f"all {len(limit.binds)} agents" if everyone else _fitted(limit.binds, width * step_pt)
        )
        ax.text((first + last) / 2, row, text, fontsize=7, **_LIMIT_LABEL)
    if not limits:
        return []
    return [Patch(label="constraint: the steps it reads", **_LIMIT)]


def _fitted(names: Sequence[str], width_pt: float, size: float = 7) -> str:
    """``names`` joined, cut to ``uv1, uv2 +6`` or ``8 agents`` where the bar is too short."""
    for shown in range(len(names), 0, -1):
        text = ", ".join(names[:shown]) + (f" +{len(names) - shown}" if shown < len(names) else "")
        if 0.6 * size * len(text) <= width_pt:
            return text
    return f"{len(names)} agents" if len(names) > 1 else names[0]


def timeline_figure(problem: Problem, trajectory: Trajectory, report: MonitorReport) -> Figure:
    """One row per agent over steps ``0..H``: when each agent serves each task, and sync runs."""
    limits = limit_windows(problem)
    rows = {a.name: len(problem.agents) + len(limits) - 1 - i for i, a in enumerate(problem.agents)}
    colors, marks = task_colors(problem), team.team_marks(problem, trajectory)
    regions = team.region_colors(problem)
    width = float(np.clip(0.65 * (problem.horizon + 1.2) + 1.8, 8.0, 16.0))
    step_pt = 72 * (width - 1.8) / (problem.horizon + 1.2)
    height = 0.5 * (len(rows) + len(limits)) + 2.4
    fig = Figure(figsize=(width, height), dpi=DPI, layout="constrained")
    ax = fig.add_subplot()
    _draw_task_bars(ax, problem, trajectory, report, rows, ((colors, step_pt), (marks, regions)))
    served = [t for t in problem.tasks if t.roles]  # a task that only counts has no bars
    handles: list[Artist] = [Patch(color=colors[t.name], label=t.name) for t in served]
    handles += team.handles(marks, regions)
    handles += _draw_sync_shading(ax, report, rows)
    handles += _draw_limits(ax, problem, report, step_pt)
    handles += timeline_marks(ax, problem, rows)
    _timeline_axes(ax, problem, rows, limits)
    fig.legend(handles=handles, loc="outside lower center", ncols=min(4, len(handles)), **_LEGEND)
    note = _TIMELINE_NOTE + ("; hatched: the steps a constraint reads" if limits else "")
    note += "".join(f"\n{team.caption(m)}" for m in marks if m.visits)
    if problem.past is not None:
        note = f"{events_note(problem.past)}\n{note}"
    _titles(ax, f"{problem.mission.name}: which agent serves which task when", note)
    return fig


def plot_timeline(
    problem: Problem, trajectory: Trajectory, report: MonitorReport, path: str | os.PathLike[str]
) -> None:
    """Draw ``timeline.png``: per agent, the steps at which it serves each task's regions.

    An agent of a task's group (from the monitor's verdict) filling role ``r`` gets a bar at step
    ``k`` when ``z(k)`` lies in a region ``R`` with ``in(r, R)`` in the task's formula; the
    synchronized run of each synchronous task is shaded across its group's rows.
    """
    save_figure(timeline_figure(problem, trajectory, report), path)
