"""How the figures draw a replan (``problem.past``, DESIGN 2.13-14).

The executed steps ``0..K`` of each path are drawn solid and the new plan from ``K`` on dashed, in
the agent's colour; a ring marks each agent's place at the replan's step ``K``, a cross the place
where a lost agent stays, and hatching each region closed at ``K``. The timeline shades the
executed steps, draws a dashed line at ``K`` and hatches a lost agent's row from ``K`` on, beneath its bars.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from matplotlib.artist import Artist
from matplotlib.lines import Line2D
from matplotlib.patches import Patch, Polygon, Rectangle
from matplotlib.patheffects import withStroke

from stlplan.mission.problem import Past, Problem
from stlplan.outputs.plots.common import region_vertices, workspace
from stlplan.result import Trajectory

INK = "0.1"
"""The colour of the replan's marks: ring, cross, hatching and the timeline's line."""
FUTURE: dict[str, Any] = dict(linestyle=(0, (4.0, 2.0)))
"""A path from the replan's step on: dashed."""
RING: dict[str, Any] = dict(
    marker="o",
    markersize=13,
    mfc="none",
    mec=INK,
    mew=1.4,
    linestyle="none",
    zorder=6,
    clip_on=False,
)
"""Each agent's place at the replan's step."""
CROSS: dict[str, Any] = dict(
    marker="x",
    markersize=13,
    mec=INK,
    mew=3.0,
    linestyle="none",
    zorder=5.5,  # over the paths and runs, under the step labels
    clip_on=False,
    path_effects=[withStroke(linewidth=6.0, foreground="white")],
)
"""Where a lost agent stays: a dark cross with a white halo, seen over any path or region."""
CLOSED: dict[str, Any] = dict(
    facecolor="none", edgecolor=INK, hatch="////", linewidth=1.8, linestyle="--", zorder=2
)
"""A region closed at the replan's step, over its own colours."""
_EXECUTED: dict[str, Any] = dict(facecolor="0.55", alpha=0.14, linewidth=0, zorder=0.5)
_REPLAN_LINE: dict[str, Any] = dict(color=INK, linestyle="--", linewidth=1.6, zorder=2.8)
"""The timeline's line at the replan's step: over the bars, under their labels."""
_LOST_ROW: dict[str, Any] = dict(facecolor="0.93", edgecolor="0.6", hatch="//", zorder=1.5)
"""A lost agent's row from ``K`` on: hatched, beneath its bars (the service the monitor still
counts where it stays)."""
_LOST_TEXT: dict[str, Any] = dict(
    ha="center", va="center", fontsize=8, style="italic", color="0.25", zorder=3
)


def replan_step(problem: Problem) -> int | None:
    """The replan's step ``K``, or None for a plan from the initial states."""
    return None if problem.past is None else problem.past.step


def events_note(past: Past) -> str:
    """``replanned from step 4: vis1 lost, C closed`` (no colon without events)."""
    events = past.events()
    return f"replanned from step {past.step}" + (f": {', '.join(events)}" if events else "")


def executed_and_planned(z: np.ndarray, step: int) -> tuple[np.ndarray, np.ndarray]:
    """A path's executed points (steps ``0..K``) and its planned ones (``K..H``): both hold
    step ``K``, so the two parts meet."""
    return z[: step + 1], z[step:]


def draw_path(ax, problem: Problem, name: str, z: np.ndarray, **style: Any) -> list[Line2D]:
    """Agent ``name``'s path ``z`` (shape ``(H + 1, 2)``) on ``ax`` with the line ``style``:
    whole without a past; for a replan its executed part solid and its new plan dashed (none for
    a lost agent, which stays where it was at ``K``)."""
    past = problem.past
    if past is None:
        return ax.plot(z[:, 0], z[:, 1], **style)
    executed, planned = executed_and_planned(z, past.step)
    lines = ax.plot(executed[:, 0], executed[:, 1], **style)
    if name not in past.lost:
        lines += ax.plot(planned[:, 0], planned[:, 1], **style, **FUTURE)
    return lines


def step_note(problem: Problem, name: str, k: int) -> str:
    """What step ``k`` of agent ``name`` is in a replan (`` (executed)``, `` (new plan)``,
    `` (lost at step K)``), for its hover text; ``""`` without a past."""
    past = problem.past
    if past is None:
        return ""
    if k <= past.step:
        return " (executed)"
    return f" (lost at step {past.step})" if name in past.lost else " (new plan)"


def closed_patches(problem: Problem, **style: Any) -> list[Polygon]:
    """A hatched polygon per region closed at the replan's step (none without a past), labelled
    ``closed from step K: C``; ``style`` adds to or overrides :data:`CLOSED`."""
    past, bounds = problem.past, workspace(problem)
    if past is None:
        return []
    patches = []
    for region in past.closed:
        vertices = region_vertices(problem.regions[region], bounds)
        if len(vertices):
            label = f"closed from step {past.step}: {region}"
            patches.append(Polygon(vertices, closed=True, label=label, **{**CLOSED, **style}))
    return patches


def places_at_replan(problem: Problem, trajectory: Trajectory) -> tuple[np.ndarray, np.ndarray]:
    """The positions at the replan's step ``K`` of the agents not lost and of those lost, each
    of shape ``(n, 2)`` (both empty without a past)."""
    past = problem.past
    if past is None:
        return np.zeros((0, 2)), np.zeros((0, 2))
    at = {a.name: trajectory.position(a.name, a.position)[past.step] for a in problem.agents}
    ringed = [z for name, z in at.items() if name not in past.lost]
    crossed = [z for name, z in at.items() if name in past.lost]
    return np.array(ringed).reshape(-1, 2), np.array(crossed).reshape(-1, 2)


def draw_rings(ax, problem: Problem, trajectory: Trajectory) -> None:
    """A ring at the place at ``K`` of each agent not lost, on the map ``ax``."""
    ringed, _ = places_at_replan(problem, trajectory)
    if len(ringed):
        ax.plot(ringed[:, 0], ringed[:, 1], **RING)


def draw_replan_marks(ax, problem: Problem, trajectory: Trajectory) -> None:
    """The rings of :func:`draw_rings`, a cross where each lost agent stays and the closed
    regions' hatching, on the map ``ax``."""
    draw_rings(ax, problem, trajectory)
    _, crossed = places_at_replan(problem, trajectory)
    if len(crossed):
        ax.plot(crossed[:, 0], crossed[:, 1], **CROSS)
    for patch in closed_patches(problem):
        ax.add_patch(patch)


def replan_handles(problem: Problem) -> list[Artist]:
    """Legend entries of a replan: executed and planned paths, the ring at ``K``, the lost
    agents' cross, each closed region's hatching (none without a past)."""
    past = problem.past
    if past is None:
        return []
    K = past.step
    handles: list[Artist] = [
        Line2D([], [], color="0.45", label=f"executed (steps 0-{K})"),
        Line2D([], [], color="0.45", label=f"new plan (from step {K})", **FUTURE),
        Line2D([], [], label=f"replan at step {K}", **RING),
    ]
    if past.lost:
        lost = ", ".join(sorted(past.lost))
        handles.append(Line2D([], [], label=f"lost at step {K}: {lost}", **CROSS))
    handles += [
        Patch(**{**CLOSED, "linestyle": "-", "linewidth": 1.0}, label=p.get_label())
        for p in closed_patches(problem)
    ]
    return handles


def timeline_marks(ax, problem: Problem, rows: Mapping[str, int]) -> list[Artist]:
    """On the timeline ``ax``: the executed steps shaded, a dashed line at ``K`` and each lost
    agent's row hatched from ``K`` on beneath its bars, the service the monitor still counts
    where it stays (``rows``: agent -> row); returns the legend entries."""
    past = problem.past
    if past is None:
        return []
    K, H = past.step, problem.horizon
    ax.axvspan(-0.6, K, **_EXECUTED)
    ax.axvline(K, **_REPLAN_LINE)
    for name in past.lost:
        ax.add_patch(Rectangle((K, rows[name] - 0.5), H + 0.6 - K, 1.0, **_LOST_ROW))
        ax.text((K + H + 0.6) / 2, rows[name], f"lost at step {K}", **_LOST_TEXT)
    handles: list[Artist] = [
        Patch(label=f"executed (steps 0-{K})", **{**_EXECUTED, "alpha": 0.3}),
        Line2D([], [], label=f"replan at step {K}", **_REPLAN_LINE),
    ]
    if past.lost:
        handles.append(Patch(label="lost agent: hatched from the replan", **_LOST_ROW))
    return handles
