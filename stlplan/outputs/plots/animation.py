"""The team moving over the map: ``plan.gif``, and ``plan.mp4`` where ``ffmpeg`` is installed.

The map (regions, obstacles hatched, each agent's path faintly, the legend) is drawn once; every
frame restores that picture and draws only what moves: a marker per agent with a trail of its last
:data:`TRAIL_STEPS` steps, its name where it covers no marker or other name, a gold ring around the
agents of a synchronous task's chosen group while its synchronized run lasts (with the caption
``sync run k=3-9: crop_C``), and the step and time. A replan's map
(:mod:`~stlplan.outputs.plots.past`) draws each path's executed part solid and its new plan
dashed, a ring at each agent's place at the replan's step ``K``, a lost agent as a cross from ``K``
on and each closed region hatched from ``K`` on. Between steps ``k`` and ``k + 1`` an agent is drawn on
the straight segment ``z(k) + s (z(k+1) - z(k))``, ``0 <= s < 1``, the path a robot follows between
waypoints, at :data:`FRAMES_PER_STEP` points: ``H * FRAMES_PER_STEP + 1`` frames in all, or
:data:`MAX_FRAMES` spread evenly over ``[0, H]`` for a long horizon (the animation then runs
through more steps a second). The time is counted in steps of the dynamics (``t = k + s``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.artist import Artist
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.text import Annotation, Text
from PIL import Image

from stlplan.mission.problem import Problem
from stlplan.outputs.plots.common import (
    _LEGEND,
    _group_agents,
    _run_steps,
    _sync_verdicts,
    agent_handles,
    agent_styles,
    spread,
    workspace,
    write_atomically,
)
from stlplan.outputs.plots.past import (
    CROSS,
    closed_patches,
    draw_path,
    draw_rings,
    replan_handles,
    replan_step,
)
from stlplan.outputs.plots.plan import _draw_regions
from stlplan.outputs.plots.video import encode_mp4, ffmpeg, quantizer
from stlplan.result import MonitorReport, Trajectory

FRAMES_PER_STEP = 3
"""Frames drawn per step of the plan: at ``k``, ``k + 1/3`` and ``k + 2/3``."""
MAX_FRAMES = 241
"""At most this many frames, whatever the horizon."""
FRAME_MS = 100
"""How long one frame lasts, milliseconds: a step lasts ``FRAMES_PER_STEP * FRAME_MS``."""
HOLD_MS = 1500
"""How long the last frame stays before the animation starts over, milliseconds."""
TRAIL_STEPS = 3
"""The trail behind each marker covers this many steps."""
ANIMATION_DPI = 80
MAP_INCHES = 6.4
"""The map's longer side; the shorter one follows the workspace's aspect."""
MARGINS = (0.5, 0.35, 0.7)
"""Left, bottom and top margins around the map, inches."""
_GHOST: dict[str, Any] = dict(linewidth=0.8, alpha=0.35, zorder=3)
"""The whole path of an agent, faint under the moving marker."""
_TRAIL: dict[str, Any] = dict(linewidth=2.0, alpha=0.7, solid_capstyle="round", zorder=5)
_MARKER: dict[str, Any] = dict(
    markersize=8, markeredgecolor="black", linestyle="none", zorder=6, clip_on=False
)
_RING: dict[str, Any] = dict(
    marker="o",
    markersize=17,
    mfc="none",
    mec="gold",
    mew=2.5,
    linestyle="none",
    zorder=5,
    clip_on=False,
)
_ABOVE: dict[str, Any] = dict(va="bottom", zorder=8, clip_on=False)
_CLOCK: dict[str, Any] = dict(_ABOVE, fontsize=10, family="monospace", ha="left")
_CAPTION: dict[str, Any] = dict(_ABOVE, fontsize=9, fontweight="bold", ha="right")
_NAME: dict[str, Any] = dict(fontsize=7.5, va="center", ha="left", zorder=7, clip_on=False)
_NAME_OFFSET = 6.0
_CAPTION_BOX = dict(boxstyle="round,pad=0.25", fc="lightyellow", ec="gold")


def frame_times(horizon: int) -> np.ndarray:
    """``t = k + i / FRAMES_PER_STEP`` for ``k < H``, then ``H``: one entry per frame (at most
    :data:`MAX_FRAMES`, evenly spread over ``[0, H]``)."""
    return np.linspace(0, horizon, min(horizon * FRAMES_PER_STEP, MAX_FRAMES - 1) + 1)


def positions_at(path: np.ndarray, t: float) -> np.ndarray:
    """Points on the waypoints ``path`` (shape ``(H + 1, ..., 2)``) at time ``t`` in ``[0, H]``."""
    k = min(int(math.floor(t)), len(path) - 2)
    s = t - k
    return np.asarray(path[k] + s * (path[k + 1] - path[k]))


def trail(path: np.ndarray, t: float) -> np.ndarray:
    """The path from ``max(0, t - TRAIL_STEPS)`` to ``t``: its waypoints between, both ends."""
    start = max(0.0, t - TRAIL_STEPS)
    inner = np.arange(math.floor(start) + 1, math.ceil(t))
    times = [start, *inner.tolist(), t]
    return np.array([positions_at(path, float(s)) for s in times])


@dataclass
class _Movers:
    """The artists a frame redraws, by kind."""

    trails: list[Line2D]
    markers: list[Line2D]
    names: list[Annotation]
    rings: list[Line2D]
    caption: Text
    clock: Text
    crosses: dict[int, Line2D] = field(default_factory=dict)
    """A replan's lost agents (by index): the cross drawn instead of the marker from ``K`` on."""


@dataclass
class PlanAnimation:
    """The frames of a plan's animation, rendered once and written as GIF and MP4.

    Parameters
    ----------
    problem, trajectory, report
        The mission, the team trajectory, and the monitor's verdicts on it (groups, runs).
    title
        Figure title; default the mission name.
    """

    problem: Problem
    trajectory: Trajectory
    report: MonitorReport
    title: str | None = None
    _frames: list[Image.Image] = field(default_factory=list, repr=False)

    def frames(self) -> list[Image.Image]:
        """One paletted image per entry of :func:`frame_times`, all on one palette (a byte per
        pixel: a long animation stays small in memory)."""
        if not self._frames:
            self._frames = _render(self.problem, self.trajectory, self.report, self.title)
        return self._frames

    def write_gif(self, path) -> None:
        """Write the animation as a looping GIF (Pillow), atomically."""
        images = self.frames()
        durations = [FRAME_MS] * (len(images) - 1) + [HOLD_MS]

        def write(tmp: Path) -> None:
            images[0].save(
                tmp,
                format="GIF",
                save_all=True,
                append_images=images[1:],
                duration=durations,
                loop=0,
            )

        write_atomically(path, write)

    def write_mp4(self, path) -> None:
        """Write the animation as H.264 MP4 through ``ffmpeg``, atomically.

        Raises
        ------
        OSError
            When ``ffmpeg`` is not installed or fails (with its message).
        """
        exe = ffmpeg()
        if exe is None:
            raise OSError("ffmpeg is not installed: an MP4 cannot be written")
        frames = self.frames()
        frames = frames + [frames[-1]] * (HOLD_MS // FRAME_MS)
        write_atomically(path, lambda tmp: encode_mp4(exe, frames, tmp, FRAME_MS))


def animate_plan(
    problem: Problem,
    trajectory: Trajectory,
    report: MonitorReport,
    path,
    title: str | None = None,
) -> int:
    """Write ``plan.gif`` to ``path`` (atomically); returns the number of frames."""
    movie = PlanAnimation(problem, trajectory, report, title)
    movie.write_gif(path)
    return len(movie.frames())


# ----------------------------------------------------------------------------------------- drawing
def _figure(problem: Problem, title: str | None, legend: list[Artist]) -> tuple[Figure, Any]:
    """The map at most ``MAP_INCHES`` wide and high, with fixed margins for the tick labels, the
    title and the clock above, and the legend on the right (as wide as its longest entry)."""
    bounds = workspace(problem)
    (xl, xh), (yl, yh) = bounds
    scale = MAP_INCHES / max(xh - xl, yh - yl)
    width, height = scale * (xh - xl), scale * (yh - yl)
    left, bottom, top = MARGINS
    right = 0.8 + 0.07 * max(len(str(h.get_label())) for h in legend)  # ~ 8-point characters
    size = (left + width + right, bottom + height + top)
    fig = Figure(figsize=size, dpi=ANIMATION_DPI)
    ax = fig.add_axes((left / size[0], bottom / size[1], width / size[0], height / size[1]))
    ax.set(xlim=(xl, xh), ylim=(yl, yh), aspect="equal")
    ax.tick_params(labelsize=7)
    ax.grid(True, color="0.9", linewidth=0.6)
    ax.set_axisbelow(True)
    title = title or problem.mission.name
    if problem.past is not None:
        title += f", replanned from step {problem.past.step}"
    ax.set_title(title, fontsize=11, fontweight="bold", pad=22)
    ax.legend(handles=legend, loc="upper left", bbox_to_anchor=(1.02, 1.0), **_LEGEND)
    _draw_regions(ax, problem, bounds, np.zeros((0, 2)), 72 * scale)
    return fig, ax


def _legend(problem: Problem, styles, has_sync: bool) -> list[Artist]:
    handles: list[Artist] = [*agent_handles(problem, styles)]
    if has_sync:
        handles.append(Line2D([], [], label="synchronized run", **{**_RING, "markersize": 10}))
    return handles + replan_handles(problem)


def _movers(ax, problem: Problem, styles, report: MonitorReport) -> _Movers:
    """The moving artists, empty and animated: the map's one full draw leaves them out."""
    trails, markers, names = [], [], []
    for agent in problem.agents:
        marker, color = styles[agent.name]
        (line,) = ax.plot([], [], color=color, animated=True, **_TRAIL)
        (dot,) = ax.plot([], [], marker=marker, mfc=color, animated=True, **_MARKER)
        trails.append(line)
        markers.append(dot)
        names.append(
            ax.annotate(
                agent.name,
                (0, 0),
                xytext=(_NAME_OFFSET, 0),
                textcoords="offset points",
                color=color,
                animated=True,
                **_NAME,
            )
        )
    rings = [ax.plot([], [], animated=True, **_RING)[0] for _ in _sync_verdicts(report)]
    above = dict(transform=ax.transAxes, animated=True)
    caption = ax.text(0.99, 1.015, "", bbox=_CAPTION_BOX, **above, **_CAPTION)
    clock = ax.text(0.0, 1.015, "", **above, **_CLOCK)
    lost = problem.past.lost if problem.past is not None else frozenset()
    crosses = {
        i: ax.plot([], [], animated=True, **CROSS)[0]
        for i, agent in enumerate(problem.agents)
        if agent.name in lost
    }
    return _Movers(trails, markers, names, rings, caption, clock, crosses)


def _render(
    problem: Problem, trajectory: Trajectory, report: MonitorReport, title: str | None
) -> list[Image.Image]:
    """Draw the static map once, then each frame's moving artists over a copy of it; the first
    and last frames (drawn first) give the palette every frame is stored on."""
    styles = agent_styles(problem)
    fig, ax = _figure(problem, title, _legend(problem, styles, bool(_sync_verdicts(report))))
    paths = np.stack([trajectory.position(a.name, a.position) for a in problem.agents], axis=1)
    for i, agent in enumerate(problem.agents):
        draw_path(ax, problem, agent.name, paths[:, i], color=styles[agent.name][1], **_GHOST)
    draw_rings(ax, problem, trajectory)
    movers = _movers(ax, problem, styles, report)
    canvas = FigureCanvasAgg(fig)
    before, after = _backgrounds(canvas, ax, problem)
    step = replan_step(problem)

    def frame(t: float) -> np.ndarray:
        canvas.restore_region(after if step is not None and t >= step else before)
        for artist in _update(movers, ax, problem, paths, report, t):
            ax.draw_artist(artist)
        return np.asarray(canvas.buffer_rgba())[..., :3].copy()

    times = frame_times(problem.horizon).tolist()
    first, last = frame(times[0]), frame(times[-1])
    quantize = quantizer(first, last)
    middle = (quantize(frame(t)) for t in times[1:-1])
    return [quantize(first), *middle, quantize(last)]


def _backgrounds(canvas: FigureCanvasAgg, ax, problem: Problem) -> tuple[Any, Any]:
    """The map with everything but the animated artists, before a replan's step and from it on
    (its closed regions hatched; the same map without a closed region)."""
    canvas.draw()
    before = canvas.copy_from_bbox(ax.figure.bbox)
    closed = [ax.add_patch(patch) for patch in closed_patches(problem)]
    if not closed:
        return before, before
    canvas.draw()
    return before, canvas.copy_from_bbox(ax.figure.bbox)


def _update(
    movers: _Movers, ax, problem: Problem, paths: np.ndarray, report: MonitorReport, t: float
) -> list[Artist]:
    """Move every artist to time ``t``; returns those to draw, back to front."""
    here = positions_at(paths, t)
    behind = trail(paths, t)
    for i, (line, dot) in enumerate(zip(movers.trails, movers.markers, strict=True)):
        line.set_data(behind[:, i, 0], behind[:, i, 1])
        dot.set_data([here[i, 0]], [here[i, 1]])
    shown = _place_names(movers.names, ax, problem, here)
    rings = _sync_rings(movers.rings, problem, here, report, t)
    movers.clock.set_text(_clock(problem, t))
    runs = [f"k={r.steps[0]}-{r.steps[-1]}: {r.name}" for r in rings]
    movers.caption.set_text("sync run " + "; ".join(runs))
    shown += [movers.caption] if runs else []
    drawn = [r.ring for r in rings]
    markers = _lost_crosses(movers, problem, here, t)
    return [*movers.trails, *drawn, *markers, *shown, movers.clock]


def _clock(problem: Problem, t: float) -> str:
    """``step k = 3 / 9   t = 3.33``, and for a replan whether the step is ``executed`` or of
    the ``new plan``."""
    step, H = min(int(math.floor(t)), problem.horizon), problem.horizon
    text = f"step k = {step:>{len(str(H))}} / {H}   t = {t:5.2f}"
    K = replan_step(problem)
    return text if K is None else f"{text}   {'executed' if t < K else 'new plan'}"


def _lost_crosses(movers: _Movers, problem: Problem, here: np.ndarray, t: float) -> list[Artist]:
    """The markers to draw at ``t``: a lost agent's cross in place of its marker from ``K`` on."""
    K = replan_step(problem)
    markers: list[Artist] = list(movers.markers)
    for i, cross in movers.crosses.items():
        cross.set_data([here[i, 0]], [here[i, 1]])
        if K is not None and t >= K:
            markers[i] = cross
    return markers


def _place_names(names: list[Annotation], ax, problem: Problem, here: np.ndarray) -> list[Artist]:
    """Names beside the markers, each left out where it would cover a marker or a name placed
    before it."""
    scale = ax.figure.dpi / 72  # points to pixels
    half = np.array([[0.3 * _NAME["fontsize"] * len(a.name) + 1, 4.0] for a in problem.agents])
    markers = ax.transData.transform(here)
    centers = markers + (half + [_NAME_OFFSET, 0.0]) * scale
    dot = np.full_like(markers, _MARKER["markersize"] / 2 * scale)
    boxes = np.vstack([markers, centers]), np.vstack([dot, half * scale])
    keep = spread(*boxes, fixed=len(markers))[len(markers) :]
    for name, point in zip(names, here, strict=True):
        name.xy = (float(point[0]), float(point[1]))
    return [name for name, k in zip(names, keep, strict=True) if k]


@dataclass(frozen=True)
class _Run:
    """A synchronized run drawn at this frame: its task, steps and ring."""

    name: str
    steps: range
    ring: Line2D


def _sync_rings(
    rings: list[Line2D], problem: Problem, here: np.ndarray, report: MonitorReport, t: float
) -> list[_Run]:
    """Rings around the chosen group's agents of each synchronized run that lasts at ``t``."""
    index = {a.name: i for i, a in enumerate(problem.agents)}
    active = []
    for verdict, ring in zip(_sync_verdicts(report), rings, strict=True):
        steps = _run_steps(verdict)
        if steps and steps[0] <= t <= steps[-1]:
            points = here[[index[name] for name in _group_agents(verdict)]]
            ring.set_data(points[:, 0], points[:, 1])
            active.append(_Run(verdict.name, steps, ring))
    return active
