"""Figures of a plan: the map (``plan.png``) and who serves which task when (``timeline.png``).

Both figures are drawn on a :class:`matplotlib.figure.Figure` with an Agg canvas, never through
``pyplot``, so no global figure state is created or leaked, and both are saved atomically (a
temporary file in the target directory, then :func:`os.replace`).

The package is split into :mod:`~stlplan.outputs.plots.common` (constants, styles, geometry, mission facts,
saving), :mod:`~stlplan.outputs.plots.plan` (the map) and :mod:`~stlplan.outputs.plots.timeline` (the timeline).
"""

from __future__ import annotations

from stlplan.outputs.plots.common import (
    obstacle_regions,
    polygon_area,
    region_vertices,
    sync_caption,
    task_presence,
    workspace,
)
from stlplan.outputs.plots.plan import plan_figure, plot_plan
from stlplan.outputs.plots.timeline import plot_timeline, timeline_figure

__all__ = [
    "obstacle_regions",
    "plan_figure",
    "plot_plan",
    "plot_timeline",
    "polygon_area",
    "region_vertices",
    "sync_caption",
    "task_presence",
    "timeline_figure",
    "workspace",
]
