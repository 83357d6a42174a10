"""Shared pieces of the figures: constants and styles, geometry, mission facts and atomic saving.

The synchronized run of a synchronous task ``F[a,b] <G[0,d] phi, c, Pattern>`` is the one the
monitor reports (DESIGN 2.1): ``run`` consecutive steps from ``run_start`` in which every element of
the chosen group satisfies ``phi``, with ``rho_s = run - 1 - d``.
"""

from __future__ import annotations

import os
import secrets
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib import colormaps
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from stlplan.formula.normal import HalfSpaces
from stlplan.formula.tree import (
    Always,
    Eventually,
    Formula,
    InRegion,
    Not,
    Until,
    children,
    horizon,
)
from stlplan.mission.problem import AgentModel, Problem, TaskModel
from stlplan.result import MonitorReport, Trajectory, Verdict
from stlplan.words import counted

DPI = 150
MANY_AGENTS = 12
"""Past this many agents the legend has one entry per capability and paths carry no step labels."""
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
_LIMIT: dict[str, Any] = dict(facecolor="0.9", edgecolor="0.5", hatch="xx", lw=0.8, zorder=2)
_LIMIT_VIOLATED: dict[str, Any] = dict(_LIMIT, edgecolor="#d62728", lw=1.6)
_LIMIT_LABEL = dict(_CENTERED, color="0.1", zorder=3, clip_on=True, bbox=_BOX)
_TIMELINE_NOTE = "bars: the agent in a region of its role, at steps the task's formula reads it"


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
    """Regions the constraints use under ``!in(...)``: places agents must stay out of (not a
    replan's closed regions, which are drawn as closed from the replan's step on)."""
    closures = problem.past.closures() if problem.past is not None else {}
    mission = (c for c in problem.constraints if c.name not in closures)
    found = (r for c in mission for r in _negated_regions(c.formula))
    return tuple(dict.fromkeys(found))


def region_styles(problem: Problem, bounds) -> dict[str, dict[str, Any]]:
    """Region name -> the keywords of its polygon on the map (face and edge colour, alpha, hatch),
    for the regions with some area inside ``bounds``, largest first: obstacles grey and hatched,
    the sweep's initial region green, the others the :data:`_REGION_COLORS` in turn."""
    obstacles = set(obstacle_regions(problem))
    initial = problem.mission.sweep.initial_region if problem.mission.sweep else None
    shapes = {n: region_vertices(r, bounds) for n, r in problem.regions.items()}
    areas = {n: polygon_area(v) for n, v in shapes.items() if len(v)}
    colors = iter(_REGION_COLORS * (1 + len(areas) // len(_REGION_COLORS)))
    styles = {}
    for name in sorted(areas, key=lambda n: -areas[n]):
        if name in obstacles:
            styles[name] = dict(facecolor="0.65", edgecolor="0.3", hatch="///", alpha=0.6)
        elif name == initial:
            styles[name] = dict(facecolor="tab:green", edgecolor="darkgreen", alpha=0.25)
        else:
            color = next(colors)
            styles[name] = dict(facecolor=color, edgecolor=color, alpha=0.35)
    return styles


def read_windows(formula: Formula, lo: int, hi: int) -> Iterator[tuple[InRegion, int, int]]:
    """Each ``in(r, R)`` of ``formula`` (none under ``!``: being inside does not serve it) with
    the first and last step it is read at when ``formula`` is decided at every step of
    ``[lo, hi]``: ``G[a,b]`` and ``F[a,b]`` read their child on ``[lo + a, hi + b]``, ``l U[a,b]
    r`` reads ``r`` there and ``l`` on ``[lo, hi + b]``."""
    if isinstance(formula, InRegion):
        yield formula, lo, hi
    elif isinstance(formula, (Always, Eventually)):
        yield from read_windows(formula.child, lo + formula.interval.lo, hi + formula.interval.hi)
    elif isinstance(formula, Until):
        yield from read_windows(formula.left, lo, hi + formula.interval.hi)
        yield from read_windows(formula.right, lo + formula.interval.lo, hi + formula.interval.hi)
    elif not isinstance(formula, Not):
        for child in children(formula):
            yield from read_windows(child, lo, hi)


def role_windows(problem: Problem, task: TaskModel, role: str) -> list[tuple[str, int, int]]:
    """``(R, first, last)`` for each ``in(role, R)`` the task's formula reads, with the steps it
    is read at: from step 0, or for a synchronous task from every step of ``[a, H - h(phi)]``
    (its run starts in ``[a, b]`` and may last to the end)."""
    sync = task.sync
    lo, hi = (0, 0) if sync is None else (sync.a, problem.horizon - horizon(task.formula))
    return [
        (atom.region, first, min(last, problem.horizon))
        for atom, first, last in read_windows(task.formula, lo, hi)
        if atom.role == role
    ]


def task_presence(
    problem: Problem, trajectory: Trajectory, task: TaskModel, verdict: Verdict
) -> dict[str, dict[int, tuple[str, ...]]]:
    """For each agent of the verdict's group: step -> regions of its role it is inside.

    An agent filling role ``r`` in an element is present at step ``k`` when its position ``z(k)``
    lies in a region ``R`` with ``in(r, R)`` in the task's formula, and the formula reads that
    ``in(r, R)`` at ``k`` (:func:`role_windows`: ``F[13,16] in(p, Home)`` only at steps 13 to
    16). Steps with no region are left out.
    """
    presence: dict[str, dict[int, tuple[str, ...]]] = {}
    for element in verdict.group or ():
        for role, name in task.binding(element).items():
            agent = problem.agent(name)
            z = trajectory.position(name, agent.position)
            steps = presence.setdefault(name, {})
            for region, first, last in role_windows(problem, task, role):
                for k in np.flatnonzero(inside(problem.regions[region], z)):
                    if first <= k <= last and region not in steps.get(int(k), ()):
                        steps[int(k)] = steps.get(int(k), ()) + (region,)
    return presence


Service = dict[str, dict[str, dict[int, tuple[str, ...]]]]
"""Agent -> task -> step -> regions of its role the agent is inside at that step."""


def task_service(problem: Problem, trajectory: Trajectory, report: MonitorReport) -> Service:
    """Which agent serves which task when, for the timeline and the viewer's hover text.

    Every agent of the mission is a key, in the mission's order. Under it come the tasks whose
    verdict's group holds the agent, in the mission's order, each with the steps of
    :func:`task_presence` (none when the agent never enters a region of its role).
    """
    verdicts = {v.name: v for v in report.verdicts}
    service: Service = {a.name: {} for a in problem.agents}
    for task in problem.tasks:
        verdict = verdicts.get(task.name)
        if verdict is None or not verdict.group:
            continue
        presence = task_presence(problem, trajectory, task, verdict)
        for name in _group_agents(verdict):
            service[name][task.name] = presence.get(name, {})
    return service


def task_colors(problem: Problem) -> dict[str, tuple[float, float, float, float]]:
    """Task name -> its colour on the timeline: matplotlib's ``tab10`` in the mission's order."""
    return {t.name: to_rgba(colormaps["tab10"](i % 10)) for i, t in enumerate(problem.tasks)}


@dataclass(frozen=True)
class Limit:
    """A requirement on every step of a window rather than a task to serve: a constraint or the
    separation, for the timeline."""

    name: str
    kind: str
    window: tuple[int, int]
    """First and last step its formula reads (the separation: ``0..H``)."""
    binds: tuple[str, ...]
    """The agents it binds, in the mission's order."""


def first_step(formula: Formula) -> int:
    """The first step past ``k`` that deciding ``formula`` at ``k`` reads (0 for an atom)."""
    if isinstance(formula, (Always, Eventually)):
        return formula.interval.lo + first_step(formula.child)
    return min((first_step(c) for c in children(formula)), default=0)


def limit_windows(problem: Problem) -> list[Limit]:
    """The constraints (a replan's closed regions among them, of kind ``from step K``), then the
    separation (when the mission has one), as :class:`Limit`."""
    order = {a.name: i for i, a in enumerate(problem.agents)}
    past = problem.past
    closures = past.closures() if past is not None else {}
    limits = []
    for constraint in problem.constraints:
        bound = {name for binding in constraint.bindings for name in binding.values()}
        last = min(horizon(constraint.formula), problem.horizon)
        window = (min(first_step(constraint.formula), last), last)
        binds = tuple(sorted(bound, key=order.__getitem__))
        kind = f"from step {past.step}" if past and constraint.name in closures else "constraint"
        limits.append(Limit(constraint.name, kind, window, binds))
    if problem.separation is not None:
        everyone = tuple(a.name for a in problem.agents)
        limits.append(
            Limit("separation", f">= {problem.separation:g}", (0, problem.horizon), everyone)
        )
    return limits


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
        darkest = 0.5 if len(names) <= 4 else 0.4  # more agents: a wider range of shades
        shades = np.linspace(0.85, darkest, len(names)) if len(names) > 1 else [0.75]
        for name, shade in zip(names, shades, strict=True):
            styles[name] = (_MARKERS[i % len(_MARKERS)], tuple(cmap(float(shade))))
    return styles


def agent_handles(problem: Problem, styles) -> list[Line2D]:
    """Legend entries of the team: one per agent (name and capability) up to
    :data:`MANY_AGENTS` agents, one per capability beyond (its middle shade and its head count)."""
    if len(problem.agents) <= MANY_AGENTS:
        return [
            _agent_handle(styles[a.name], f"{a.name} ({_capability_key(a)})")
            for a in problem.agents
        ]
    by_key: dict[str, list[str]] = {}
    for agent in problem.agents:
        by_key.setdefault(_capability_key(agent), []).append(agent.name)
    return [
        _agent_handle(styles[names[len(names) // 2]], f"{key} ({counted(len(names), 'agent')})")
        for key, names in by_key.items()
    ]


def _agent_handle(style: tuple[str, Any], label: str) -> Line2D:
    marker, color = style
    return Line2D([], [], color=color, marker=marker, mfc="white", label=label)


def spread(points: np.ndarray, half: np.ndarray, fixed: int = 0) -> np.ndarray:
    """Which boxes to show, greedily in order: box ``i`` centred at ``points[i]`` (display units)
    with half-sizes ``half[i]`` is kept when it misses every box kept before it; the first
    ``fixed`` boxes (markers a label must not cover) are always kept."""
    keep = np.arange(len(points)) < fixed
    for i in range(fixed, len(points)):
        gaps = np.abs(points[keep] - points[i]) - half[keep] - half[i]
        keep[i] = not np.any(np.all(gaps < 0, axis=1))
    return keep


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
def write_atomically(path: str | os.PathLike[str], write: Callable[[Path], None]) -> None:
    """Call ``write`` on a temporary file beside ``path`` (created empty, the umask applying as
    to any new file), then rename it to ``path``: a reader sees the old file or the whole new
    one. A failed write leaves no temporary file behind."""
    target = Path(path)
    tmp = target.with_name(f".{target.name}.{secrets.token_hex(6)}.tmp")
    os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))  # unlike mkstemp's 0o600
    try:
        write(tmp)
        os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def save_figure(fig: Figure, path: str | os.PathLike[str]) -> None:
    """Write ``fig`` as PNG to ``path`` atomically: a temporary file beside it, then a rename."""
    FigureCanvasAgg(fig)
    write_atomically(
        path,
        lambda tmp: fig.savefig(tmp, format="png", dpi=DPI, bbox_inches="tight", pad_inches=0.15),
    )


def _titles(ax, title: str, subtitle: str) -> None:
    # the subtitle grows upwards from the axes: the title stands above its every line
    ax.set_title(title, fontsize=13, fontweight="bold", pad=18 + 11 * subtitle.count("\n"))
    ax.annotate(subtitle, (0.5, 1.0), fontsize=9, color="0.3", **_SUBTITLE)
