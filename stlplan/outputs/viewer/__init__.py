"""The interactive viewer (``plan.html``): the map and the timeline side by side, with a slider.

One self-contained HTML file drawn with plotly, plotly.js inline, so it opens from disk in a
browser with no network. The map (:mod:`~stlplan.outputs.viewer.map`) shows the regions,
coloured and named as on ``plan.png``, each agent's path with a point per step, and a marker per
agent at the slider's step; the timeline beside it (:mod:`~stlplan.outputs.viewer.timeline`)
shows per agent the steps at which it serves each task, as on ``timeline.png``, the synchronized
runs shaded, and a dashed line at the slider's step. Hovering a point gives the agent, the step
``k``, its state ``x(k)`` and the tasks it serves at ``k``. The team's counts
(:mod:`~stlplan.outputs.viewer.team`) add a star on the map at each visit a ``visits`` counts, a
lane per counted agent on the timeline, and a line per ``count`` and ``visits`` under the title.

The page (:mod:`~stlplan.outputs.viewer.page`) has one plotly frame per step ``k = 0..H``; the
slider and the play button move through them, and between two steps plotly's transition slides
each marker along the straight segment ``z(k) -> z(k+1)``, the path a robot follows between
waypoints. Missions whose states hold more than a position are drawn in the agents' position
components, as on ``plan.png``.
"""

from __future__ import annotations

from stlplan.outputs.viewer.map import hover_texts
from stlplan.outputs.viewer.page import viewer_figure, write_viewer

__all__ = ["hover_texts", "viewer_figure", "write_viewer"]
