"""Figures of a plan: the map (``plan.png``) and who serves which task when (``timeline.png``).

Both figures are drawn on a :class:`matplotlib.figure.Figure` with an Agg canvas, never through
``pyplot``, so no global figure state is created or leaked, and both are saved atomically (a
temporary file in the target directory, then :func:`os.replace`).

The synchronized run of a synchronous task ``F[a,b] <G[0,d] phi, c, Pattern>`` is the one the
monitor reports (DESIGN 2.1): ``run`` consecutive steps from ``run_start`` in which every element of
the chosen group satisfies ``phi``, with ``rho_s = run - 1 - d``.
"""

from __future__ import annotations

import os
import secrets
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib import colormaps
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch, Polygon, Rectangle

from stlplan.formula.normal import HalfSpaces
from stlplan.formula.tree import Formula, InRegion, Not, atoms, children
from stlplan.problem import AgentModel, Problem, TaskModel
from stlplan.result import MonitorReport, Trajectory, Verdict

DPI = 150
INSIDE_TOLERANCE = 1e-6
"""Tolerance of ``G z <= h`` when deciding whether an agent is inside a region (as the monitor)."""

_MARKERS = ("o", "s", "^", "D", "v", "P", "X", "h")
_FAMILIES = ("Blues", "Reds", "Purples", "Oranges", "Greys", "YlOrBr", "Greens")
_REGION_COLORS = tuple(colormaps["Set2"](i) for i in (0, 1, 2, 3, 5, 6))  # no green, no gray
_CENTERED: dict[str, Any] = dict(ha="center", va="center")
_BOX = dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.6)
_REGION_LABEL = dict(_CENTERED, fontsize=9, fontweight="bold", color="0.15", zorder=7, bbox=_BOX)
_PATH: dict[str, Any] = dict(linewidth=1.6, markersize=4.5, markerfacecolor="white", zorder=4)
_START: dict[str, Any] = dict(markersize=9, markeredgecolor="black", linestyle="none", zorder=5)
_SYNC: dict[str, Any] = dict(markersize=10, markeredgecolor="gold", linestyle="none", zorder=5)
_SHADE: dict[str, Any] = dict(facecolor="gold", edgecolor="darkgoldenrod", hatch="..")
_BAR_LABEL = dict(_CENTERED, color="white", fontweight="bold", zorder=3, clip_on=True)
_BAR: dict[str, Any] = dict(edgecolor="white", linewidth=0.8, zorder=2)
_IDLE = dict(_CENTERED, fontsize=8, color="0.6", style="italic")
_POINTS: dict[str, Any] = dict(xytext=(4, 3), textcoords="offset points", fontsize=6, zorder=6)
_AXES: dict[str, Any] = dict(xycoords="axes fraction", annotation_clip=False)
_SUBTITLE = dict(_AXES, xytext=(0, 5), textcoords="offset points", ha="center", va="bottom")
_LEGEND: dict[str, Any] = dict(fontsize=8, title_fontsize=8, frameon=False)
_TIMELINE_NOTE = "bars: steps at which the agent is inside a region its role has in the task"


# ---------------------------------------------------------------------------------------- geometry
def workspace(problem: Problem) -> tuple[tuple[float, float], tuple[float, float]]:
    """``((x_lo, x_hi), (y_lo, y_hi))``: the union of the agents' position state bounds."""
    lo = np.min([a.state_lo[list(a.position)] for a in problem.agents], axis=0)
    hi = np.max([a.state_hi[list(a.position)] for a in problem.agents], axis=0)
    return (float(lo[0]), float(hi[0])), (float(lo[1]), float(hi[1]))


def region_vertices(
    region: HalfSpaces, bounds: tuple[tuple[float, float], tuple[float, float]]
) -> np.ndarray:
    """Vertices of ``{z : G z <= h}`` clipped to the box ``bounds``, counter-clockwise.

    Each vertex is the intersection ``g_i z = h_i, g_j z = h_j`` of two boundary lines (the
    region's rows and the box's four rows) that satisfies every row, ``G z <= h + 1e-9``.

    Returns
    -------
    numpy.ndarray
        Shape (n, 2) with n >= 3, or shape (0, 2) when the clipped region has no area.
    """
    (xl, xh), (yl, yh) = bounds
    box = [[1, 0], [-1, 0], [0, 1], [0, -1]]
    rows = np.vstack([np.asarray(region[0], float).reshape(-1, 2), box])
    rhs = np.concatenate([np.asarray(region[1], float), [xh, -xl, yh, -yl]])
    points = []
    for i in range(len(rows)):
        for j in range(i + 1, len(rows)):
            pair = rows[[i, j]]
            if abs(np.linalg.det(pair)) < 1e-12:
                continue
            z = np.linalg.solve(pair, rhs[[i, j]])
            if np.all(rows @ z <= rhs + 1e-9):
                points.append(z)
    unique = np.unique(np.round(np.array(points).reshape(-1, 2), 9), axis=0)
    if len(unique) < 3:
        return np.zeros((0, 2))
    center = unique.mean(axis=0)
    order = np.argsort(np.arctan2(unique[:, 1] - center[1], unique[:, 0] - center[0]))
    return unique[order]


def polygon_area(vertices: np.ndarray) -> float:
    """Shoelace area ``|sum(x_i y_{i+1} - x_{i+1} y_i)| / 2``."""
    x, y = vertices[:, 0], vertices[:, 1]
    return float(abs(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y)) / 2)


def inside(region: HalfSpaces, points: np.ndarray) -> np.ndarray:
    """Whether each point (rows of ``points``) satisfies ``G z <= h + tolerance``."""
    rows, rhs = np.asarray(region[0], float).reshape(-1, 2), np.asarray(region[1], float)
    return np.all(points @ rows.T <= rhs + INSIDE_TOLERANCE, axis=1)


# ---------------------------------------------------------------------------------- mission facts
def _negated_regions(formula: Formula) -> Iterator[str]:
    if isinstance(formula, Not) and isinstance(formula.atom, InRegion):
        yield formula.atom.region
    for child in children(formula):
        yield from _negated_regions(child)


def obstacle_regions(problem: Problem) -> tuple[str, ...]:
    """Regions the constraints use under ``!in(...)``: places agents must stay out of."""
    found = (r for c in problem.constraints for r in _negated_regions(c.formula))
    return tuple(dict.fromkeys(found))


def role_regions(task: TaskModel, role: str) -> tuple[str, ...]:
    """Regions the task's formula mentions as ``in(role, R)`` for this role."""
    found = (a.region for a in atoms(task.formula) if isinstance(a, InRegion) and a.role == role)
    return tuple(dict.fromkeys(found))


def task_presence(
    problem: Problem, trajectory: Trajectory, task: TaskModel, verdict: Verdict
) -> dict[str, dict[int, tuple[str, ...]]]:
    """For each agent of the verdict's group: step -> regions of its role it is inside.

    An agent filling role ``r`` in an element is present at step ``k`` when its position ``z(k)``
    lies in a region ``R`` with ``in(r, R)`` in the task's formula. Steps with no region are left out.
    """
    presence: dict[str, dict[int, tuple[str, ...]]] = {}
    for element in verdict.group or ():
        for role, name in task.binding(element).items():
            agent = problem.agent(name)
            z = trajectory.position(name, agent.position)
            steps = presence.setdefault(name, {})
            for region in role_regions(task, role):
                for k in np.flatnonzero(inside(problem.regions[region], z)):
                    steps[int(k)] = steps.get(int(k), ()) + (region,)
    return presence


def _capability_key(agent: AgentModel) -> str:
    return "+".join(sorted(agent.capabilities)) or "no capability"


def agent_styles(problem: Problem) -> dict[str, tuple[str, tuple[float, ...]]]:
    """Agent name -> (marker, colour): marker and colour family by capability, shade by agent."""
    by_key: dict[str, list[str]] = {}
    for agent in problem.agents:
        by_key.setdefault(_capability_key(agent), []).append(agent.name)
    styles = {}
    for i, names in enumerate(by_key.values()):
        cmap = colormaps[_FAMILIES[i % len(_FAMILIES)]]
        shades = np.linspace(0.85, 0.5, len(names)) if len(names) > 1 else [0.75]
        for name, shade in zip(names, shades, strict=True):
            styles[name] = (_MARKERS[i % len(_MARKERS)], tuple(cmap(float(shade))))
    return styles


def _sync_verdicts(report: MonitorReport) -> list[Verdict]:
    return [v for v in report.verdicts if v.kind == "synchronous" and v.group]


def _run_steps(verdict: Verdict) -> range:
    if verdict.run_start is None or not verdict.run_length:
        return range(0)
    return range(verdict.run_start, verdict.run_start + verdict.run_length)


def sync_caption(verdict: Verdict) -> str:
    """``crop_C synchronized: steps 3-9 (run 7, rho_s = 5)``, or why there is no run."""
    steps = _run_steps(verdict)
    rho = "" if verdict.rho_s is None else f", rho_s = {verdict.rho_s:g}"
    if not steps:
        return f"{verdict.name}: no synchronized run" + (f" ({rho[2:]})" if rho else "")
    return f"{verdict.name} synchronized: steps {steps[0]}-{steps[-1]} (run {len(steps)}{rho})"


def _group_agents(verdict: Verdict) -> list[str]:
    return list(dict.fromkeys(name for element in verdict.group or () for name in element))


def _status_line(report: MonitorReport) -> str:
    failed = [v.name for v in report.verdicts if not v.satisfied]
    shown = ", ".join(failed[:3]) + (f" and {len(failed) - 3} more" if len(failed) > 3 else "")
    text = f"monitor: violated {shown}" if failed else "monitor: all requirements hold"
    return text if report.rho_s is None else f"{text};  rho_s(Phi) = {report.rho_s:g}"


# ------------------------------------------------------------------------------------------ saving
def save_figure(fig: Figure, path: str | os.PathLike[str]) -> None:
    """Write ``fig`` as PNG to ``path`` atomically: a temporary file beside it, then a rename."""
    target = Path(path)
    FigureCanvasAgg(fig)
    tmp = target.with_name(f".{target.name}.{secrets.token_hex(6)}.tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)  # umask applies, unlike mkstemp
    try:
        with os.fdopen(fd, "wb") as stream:
            fig.savefig(stream, format="png", dpi=DPI, bbox_inches="tight", pad_inches=0.15)
        os.replace(tmp, target)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


# -------------------------------------------------------------------------------------- plan.png
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


def _region_style(name: str, obstacles: set[str], initial: str | None, colors) -> dict:
    if name in obstacles:
        return dict(facecolor="0.65", edgecolor="0.3", hatch="///", alpha=0.6)
    if name == initial:
        return dict(facecolor="tab:green", edgecolor="darkgreen", alpha=0.25)
    color = next(colors)
    return dict(facecolor=color, edgecolor=color, alpha=0.35)


def _draw_regions(ax, problem: Problem, bounds, avoid: np.ndarray, pt_per_unit: float) -> None:
    obstacles = set(obstacle_regions(problem))
    initial = problem.mission.sweep.initial_region if problem.mission.sweep else None
    shapes = {n: region_vertices(r, bounds) for n, r in problem.regions.items()}
    shapes = {n: v for n, v in shapes.items() if len(v)}
    colors = iter(_REGION_COLORS * (1 + len(shapes) // len(_REGION_COLORS)))
    for name in sorted(shapes, key=lambda n: -polygon_area(shapes[n])):
        style = _region_style(name, obstacles, initial, colors)
        ax.add_patch(Polygon(shapes[name], closed=True, linewidth=1.2, zorder=1, **style))
    for name in sorted(shapes, key=lambda n: polygon_area(shapes[n])):  # small regions first
        x, y = _label_spot(shapes[name], name, avoid, pt_per_unit)
        avoid = np.vstack([avoid, [x, y]])
        ax.text(x, y, name, **_REGION_LABEL)


def _step_clusters(points: np.ndarray, eps: float) -> list[tuple[int, int]]:
    # consecutive steps whose positions stay within eps of the first one share one label
    clusters, start = [], 0
    for k in range(1, len(points) + 1):
        if k == len(points) or np.max(np.abs(points[k] - points[start])) > eps:
            clusters.append((start, k - 1))
            start = k
    return clusters


def _draw_agent(ax, z: np.ndarray, style: tuple[str, tuple[float, ...]], eps: float) -> None:
    marker, color = style
    ax.plot(z[:, 0], z[:, 1], color=color, marker=marker, **_PATH)
    ax.plot(z[0, 0], z[0, 1], marker=marker, markerfacecolor=color, **_START)
    for first, last in _step_clusters(z, eps):
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


def _plan_legend(ax, problem: Problem, styles, has_sync: bool) -> None:
    handles = []
    for agent in problem.agents:
        marker, color = styles[agent.name]
        label = f"{agent.name} ({_capability_key(agent)})"
        handles.append(Line2D([], [], color=color, marker=marker, mfc="white", label=label))
    handles.append(Line2D([], [], marker="o", mfc="0.6", label="start (step 0)", **_START))
    if has_sync:
        handles.append(Line2D([], [], marker="o", mfc="0.6", label="synchronized run", **_SYNC))
    legend_at = dict(loc="upper left", bbox_to_anchor=(1.01, 1.0), title="agent (capability)")
    ax.legend(handles=handles, **legend_at, **_LEGEND)


def _titles(ax, title: str, subtitle: str) -> None:
    ax.set_title(title, fontsize=13, fontweight="bold", pad=18)
    ax.annotate(subtitle, (0.5, 1.0), fontsize=9, color="0.3", **_SUBTITLE)


def plan_figure(
    problem: Problem, trajectory: Trajectory, report: MonitorReport, title: str | None = None
) -> Figure:
    """The map: workspace, regions, each agent's path, starts and synchronized runs."""
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
    eps = 0.01 * max(xh - xl, yh - yl)
    for agent in problem.agents:
        _draw_agent(ax, trajectory.position(agent.name, agent.position), styles[agent.name], eps)
    captions = _draw_sync_runs(ax, problem, trajectory, report, styles)
    ax.set(xlim=(xl, xh), ylim=(yl, yh), aspect="equal", xlabel="x", ylabel="y")
    ax.tick_params(labelsize=8)
    ax.grid(True, color="0.9", linewidth=0.6)
    ax.set_axisbelow(True)
    _plan_legend(ax, problem, styles, bool(captions))
    _titles(ax, title or problem.mission.name, _status_line(report))
    for i, caption in enumerate(captions):
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


# ---------------------------------------------------------------------------------- timeline.png
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


def _lanes(problem: Problem, report: MonitorReport) -> dict[str, list[str]]:
    verdicts = {v.name: v for v in report.verdicts}
    lanes: dict[str, list[str]] = {a.name: [] for a in problem.agents}
    for task in problem.tasks:
        verdict = verdicts.get(task.name)
        for name in _group_agents(verdict) if verdict else ():
            lanes[name].append(task.name)
    return lanes


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
    colors, step_pt = style
    verdicts, lanes = {v.name: v for v in report.verdicts}, _lanes(problem, report)
    for task in problem.tasks:
        verdict = verdicts.get(task.name)
        if verdict is None or not verdict.group:
            continue
        for name, steps in task_presence(problem, trajectory, task, verdict).items():
            height = 0.84 / len(lanes[name])
            y0 = rows[name] + 0.42 - height * (lanes[name].index(task.name) + 1)
            _draw_lane(ax, problem, (y0, height), steps, (colors[task.name], step_pt))
    for name, served in lanes.items():
        if not served:
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


def _timeline_axes(ax, problem: Problem, rows: Mapping[str, int]) -> None:
    horizon, count = problem.horizon, len(rows)
    ax.set_xlim(-0.6, horizon + 0.6)
    ax.set_ylim(-0.6, count - 0.4)
    ax.set_xticks(range(0, horizon + 1, 1 if horizon <= 30 else (horizon + 29) // 30))
    labels = [f"{a.name} ({_capability_key(a)})" for a in problem.agents]
    ax.set_yticks([rows[a.name] for a in problem.agents], labels, fontsize=9)
    ax.tick_params(axis="x", labelsize=9)
    ax.set_xlabel("step k", fontsize=10)
    for y in range(count + 1):
        ax.axhline(y - 0.5, color="0.8", linewidth=0.6, zorder=0)
    ax.grid(True, axis="x", color="0.92", linewidth=0.6)
    ax.set_axisbelow(True)


def timeline_figure(problem: Problem, trajectory: Trajectory, report: MonitorReport) -> Figure:
    """One row per agent over steps ``0..H``: when each agent serves each task, and sync runs."""
    rows = {a.name: len(problem.agents) - 1 - i for i, a in enumerate(problem.agents)}
    colors = {t.name: colormaps["tab10"](i % 10) for i, t in enumerate(problem.tasks)}
    width = float(np.clip(0.65 * (problem.horizon + 1.2) + 1.8, 8.0, 16.0))
    step_pt = 72 * (width - 1.8) / (problem.horizon + 1.2)
    fig = Figure(figsize=(width, 0.5 * len(rows) + 2.4), dpi=DPI, layout="constrained")
    ax = fig.add_subplot()
    _draw_task_bars(ax, problem, trajectory, report, rows, (colors, step_pt))
    handles = [Patch(color=colors[t.name], label=t.name) for t in problem.tasks]
    handles += _draw_sync_shading(ax, report, rows)
    _timeline_axes(ax, problem, rows)
    fig.legend(handles=handles, loc="outside lower center", ncols=min(4, len(handles)), **_LEGEND)
    _titles(ax, f"{problem.mission.name}: which agent serves which task when", _TIMELINE_NOTE)
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
