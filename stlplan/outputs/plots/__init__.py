"""Figures of a plan: the map (``plan.png``), who serves which task when (``timeline.png``),
the team moving over the map (``plan.gif``, ``plan.mp4``) and step 1's incumbent and bound over
time (``convergence.png``).

Every figure is drawn on a :class:`matplotlib.figure.Figure` with an Agg canvas, never through
``pyplot``, so no global figure state is created or leaked, and every file is saved atomically (a
temporary file in the target directory, then :func:`os.replace`).

The package is split into :mod:`~stlplan.outputs.plots.common` (constants, styles, geometry, mission facts,
saving), :mod:`~stlplan.outputs.plots.plan` (the map), :mod:`~stlplan.outputs.plots.timeline` (the
timeline), :mod:`~stlplan.outputs.plots.animation` (the animation) with
:mod:`~stlplan.outputs.plots.video` (its encoding), :mod:`~stlplan.outputs.plots.convergence`
(incumbent and bound), :mod:`~stlplan.outputs.plots.past` (how each figure draws a replan:
the executed past, the new plan and the events at its step) and
:mod:`~stlplan.outputs.plots.team` (what the team's counts saw: who is inside when, each visit).
"""

from __future__ import annotations

from stlplan.outputs.plots.animation import PlanAnimation, animate_plan
from stlplan.outputs.plots.common import (
    obstacle_regions,
    polygon_area,
    region_vertices,
    sync_caption,
    task_presence,
    workspace,
)
from stlplan.outputs.plots.convergence import convergence_figure, plot_convergence
from stlplan.outputs.plots.plan import plan_figure, plot_plan
from stlplan.outputs.plots.timeline import plot_timeline, timeline_figure
from stlplan.outputs.plots.video import ffmpeg

__all__ = [
    "PlanAnimation",
    "animate_plan",
    "convergence_figure",
    "ffmpeg",
    "obstacle_regions",
    "plan_figure",
    "plot_convergence",
    "plot_plan",
    "plot_timeline",
    "polygon_area",
    "region_vertices",
    "sync_caption",
    "task_presence",
    "timeline_figure",
    "workspace",
]
