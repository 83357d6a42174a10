"""Shared pieces of the figures: constants and styles, geometry, mission facts and atomic saving.

The synchronized run of a synchronous task ``F[a,b] <G[0,d] phi, c, Pattern>`` is the one the
monitor reports (DESIGN 2.1): ``run`` consecutive steps from ``run_start`` in which every element of
the chosen group satisfies ``phi``, with ``rho_s = run - 1 - d``.
"""

from __future__ import annotations

import os
import secrets
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib import colormaps
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from stlplan.formula.normal import HalfSpaces
from stlplan.formula.tree import Formula, InRegion, Not, atoms, children
from stlplan.mission.problem import AgentModel, Problem, TaskModel
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


def _titles(ax, title: str, subtitle: str) -> None:
    ax.set_title(title, fontsize=13, fontweight="bold", pad=18)
    ax.annotate(subtitle, (0.5, 1.0), fontsize=9, color="0.3", **_SUBTITLE)
