"""The convergence figure (``convergence.png``): the whole problem's incumbent and bound over
step 1, as ``summary.json``'s ``convergence`` records them (:mod:`stlplan.planner.run.convergence`
says which figures count)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from stlplan.mission.problem import Problem
from stlplan.outputs.plots.common import _LEGEND, DPI, _titles, save_figure
from stlplan.planner.run.outcome import relative_gap
from stlplan.result import ConvergencePoint, PlanResult

_INCUMBENT: dict[str, Any] = dict(color="#2ca02c", linestyle="-", linewidth=2.0)
_BOUND: dict[str, Any] = dict(color="#1f77b4", linestyle="--", linewidth=1.8)
_FIRST: dict[str, Any] = dict(
    color="#d62728", marker="*", markersize=13, linestyle="none", zorder=5
)
_GAP: dict[str, Any] = dict(color="#1f77b4", alpha=0.1, linewidth=0)
_NOTE: dict[str, Any] = dict(ha="center", va="center", fontsize=9, color="0.5", style="italic")


def series(points: Sequence[ConvergencePoint], name: str) -> np.ndarray:
    """The figure ``name`` (``incumbent`` or ``bound``) of every point, NaN where unknown."""
    values = [getattr(p, name) for p in points]
    return np.array([np.nan if v is None else v for v in values], dtype=float)


def final_words(points: Sequence[ConvergencePoint]) -> str:
    """The last point in words: incumbent, bound and their relative gap (as HiGHS's)."""
    last = points[-1]
    found = "no plan" if last.incumbent is None else f"incumbent {last.incumbent:.6g}"
    bound = "no bound" if last.bound is None else f"bound {last.bound:.6g}"
    gap = relative_gap(last.incumbent, last.bound)
    if gap is None:
        return f"{found}, {bound} at {last.at:.1f} s"
    return f"final gap {gap:.2%} ({found}, {bound}) at {last.at:.1f} s"


def _mark_first(ax, points: Sequence[ConvergencePoint], first: float | None) -> None:
    """A star on the incumbent where the first plan meeting every requirement was found."""
    if first is None:
        return
    ax.axvline(first, color="0.6", linestyle=":", linewidth=1.0, zorder=1)
    found = [p for p in points if p.incumbent is not None]
    earlier = [p for p in found if p.at <= first + 1e-9]
    value = (earlier[-1] if earlier else found[0]).incumbent if found else None
    if value is not None:
        ax.plot([first], [value], label=f"first plan ({first:.1f} s)", **_FIRST)


def _fit_values(ax, values: np.ndarray) -> None:
    """Plain tick labels, and a span of at least 0.2 % of the values' size, so that a flat
    record shows its value rather than round-off."""
    ax.ticklabel_format(axis="y", useOffset=False, style="plain")
    finite = values[~np.isnan(values)]
    if finite.size == 0:
        return
    lo, hi = float(finite.min()), float(finite.max())
    least = 2e-3 * max(1.0, abs(lo), abs(hi))
    if hi - lo < least:
        middle = (hi + lo) / 2
        ax.set_ylim(middle - least, middle + least)


def convergence_figure(
    problem: Problem, points: Sequence[ConvergencePoint], first_plan: float | None
) -> Figure:
    """Incumbent (solid) and bound (dashed) of step 1 against time, steps held until the next
    point, the gap between them shaded and the first plan starred."""
    at = np.array([p.at for p in points], dtype=float)
    incumbent, bound = series(points, "incumbent"), series(points, "bound")
    fig = Figure(figsize=(8.0, 4.6), dpi=DPI, layout="constrained")
    ax = fig.add_subplot()
    both = ~np.isnan(incumbent) & ~np.isnan(bound)
    if both.any():
        ax.fill_between(at, incumbent, bound, where=both, step="post", label="gap", **_GAP)
    for values, label, style in (
        (bound, "bound (proven, upper)", _BOUND),
        (incumbent, "incumbent (a plan meeting every requirement)", _INCUMBENT),
    ):
        if not np.isnan(values).all():
            ax.step(at, values, where="post", label=label, **style)
            ax.plot(at, values, "o", color=style["color"], markersize=3)
    _mark_first(ax, points, first_plan)
    end = max(float(at.max()), first_plan or 0.0)
    ax.set_xlim(0.0, end * 1.04 + 0.05)
    if at[0] > 0.15 * end:  # a long wait: say why nothing is drawn there
        note = f"no plan or bound\nof the whole team\nbefore {at[0]:.1f} s"
        ax.text(
            0.01 * end, 0.5, note, transform=ax.get_xaxis_transform(), **{**_NOTE, "ha": "left"}
        )
    _fit_values(ax, np.concatenate([incumbent, bound]))
    ax.set_xlabel("seconds since planning started")
    ax.set_ylabel("step-1 objective (maximized)")
    ax.grid(True, color="0.9", linewidth=0.8)
    ax.legend(loc="best", **_LEGEND)
    _titles(ax, f"{problem.mission.name}: incumbent and bound of step 1", final_words(points))
    return fig


def plot_convergence(problem: Problem, result: PlanResult, path: str | os.PathLike[str]) -> None:
    """Draw ``convergence.png`` from ``result``'s convergence record (at least one point)."""
    if not result.convergence:
        raise ValueError("no convergence point to draw")
    figure = convergence_figure(problem, result.convergence, result.first_plan_seconds)
    save_figure(figure, path)
