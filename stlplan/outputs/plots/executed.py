"""How the map draws a simulated run (:mod:`stlplan.simulation`).

The executed paths are solid (the map of :func:`~stlplan.outputs.plots.plan.plan_figure`, with
the monitor's verdicts on them), the plan they set out to execute dashed and thinner in the same
colours, and the events at their own steps: a cross where each lost agent stays, and each closed
region hatched, labelled with its step (the marks of :mod:`~stlplan.outputs.plots.past`).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch, Polygon

from stlplan.mission.problem import Problem
from stlplan.outputs.plots.common import agent_styles, region_vertices, save_figure, workspace
from stlplan.outputs.plots.past import CLOSED, CROSS, FUTURE
from stlplan.outputs.plots.plan import plan_figure
from stlplan.result import MonitorReport, Trajectory

PLANNED: dict[str, Any] = dict(linewidth=1.0, alpha=0.75, zorder=3.5, **FUTURE)
"""The plan a run set out to execute: dashed and thin, under the executed paths."""


def executed_figure(
    problem: Problem,
    executed: Trajectory,
    planned: Trajectory,
    report: MonitorReport,
    events: Sequence[tuple[str, str, int]],
    title: str,
) -> Figure:
    """The map of a simulated run.

    Parameters
    ----------
    problem, executed, report
        The mission, the executed trajectory and the monitor's verdicts on it.
    planned
        The plan the run set out to execute (its first plan).
    events
        ``(kind, name, step)`` with kind ``lose`` or ``close``.
    title
        The figure's title.
    """
    styles = agent_styles(problem)

    def overlay(ax: Axes) -> list[Artist]:
        for agent in problem.agents:
            z = planned.position(agent.name, agent.position)
            ax.plot(z[:, 0], z[:, 1], color=styles[agent.name][1], **PLANNED)
        handles: list[Artist] = [
            Line2D([], [], color="0.45", label="executed"),
            Line2D([], [], color="0.45", label="planned", **PLANNED),
        ]
        return handles + _events(ax, problem, executed, events)

    return plan_figure(problem, executed, report, title, overlay)


def _events(
    ax: Axes, problem: Problem, executed: Trajectory, events: Sequence[tuple[str, str, int]]
) -> list[Artist]:
    """A cross where each lost agent stays, each closed region hatched; their legend entries."""
    handles: list[Artist] = []
    for kind, name, k in events:
        if kind == "lose":
            z = executed.position(name, problem.agent(name).position)[k]
            ax.plot([z[0]], [z[1]], **CROSS)
            handles.append(Line2D([], [], label=f"{name} lost at step {k}", **CROSS))
            continue
        label = f"closed from step {k}: {name}"
        vertices = region_vertices(problem.regions[name], workspace(problem))
        if len(vertices):
            ax.add_patch(Polygon(vertices, closed=True, **CLOSED))
        handles.append(Patch(**{**CLOSED, "linestyle": "-", "linewidth": 1.0}, label=label))
    return handles


def plot_executed(
    problem: Problem,
    executed: Trajectory,
    planned: Trajectory,
    report: MonitorReport,
    events: Sequence[tuple[str, str, int]],
    path: str | os.PathLike[str],
    title: str,
) -> None:
    """Draw :func:`executed_figure` to ``path`` (PNG, written atomically)."""
    save_figure(executed_figure(problem, executed, planned, report, events, title), path)
