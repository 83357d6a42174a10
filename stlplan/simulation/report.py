"""What a simulation reports: a row per run, one line overall, the JSON document, and the
fraction of runs satisfied against the disturbance bound for each policy (``robustness.png``)."""

from __future__ import annotations

import statistics
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from stlplan.simulation.settings import POLICIES
from stlplan.words import counted

COLUMNS = (
    "run", "status", "rho_s", "dropped", "replans", "replan_median_s", "replan_max_s", "note"
)  # fmt: skip
"""The table's columns: one row per run (``note``: what failed, or the error)."""


def row(record: Mapping[str, Any]) -> dict[str, Any]:
    """A run's row of the table (times rounded to milliseconds)."""
    return {
        "run": record["run"],
        "status": record["status"],
        "rho_s": _number(record.get("rho_s")),
        "dropped": ", ".join(record.get("dropped") or []) or None,
        "replans": record.get("replans"),
        "replan_median_s": _number(record.get("replan_median_s"), 3),
        "replan_max_s": _number(record.get("replan_max_s"), 3),
        "note": _note(record),
    }


def _note(record: Mapping[str, Any]) -> str | None:
    """The error of a run that failed, or the verdicts a violated run failed."""
    if record["status"] == "error":
        return str(record.get("message"))
    failed = record.get("failed") or []
    return f"failed: {', '.join(failed)}" if failed else None


def _number(value: float | None, digits: int = 6) -> float | None:
    return None if value is None else round(float(value), digits)


def overall(records: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The runs, how many satisfy the mission and the fraction, the replan time (median and
    max over every replan of every run), how many replans planned with smaller margins, and
    with a deadline what the replans answered by it (``came_back``: how many of each)."""
    seconds = [s for r in records for s in r.get("replan_seconds") or []]
    satisfied = sum(1 for r in records if r.get("satisfied"))
    came_back: dict[str, int] = {}
    for r in records:
        for kind, n in (r.get("came_back") or {}).items():
            came_back[kind] = came_back.get(kind, 0) + n
    return {
        "runs": len(records),
        "satisfied": satisfied,
        "satisfied_fraction": satisfied / len(records) if records else None,
        "replans": len(seconds),
        "replan_median_s": statistics.median(seconds) if seconds else None,
        "replan_max_s": max(seconds) if seconds else None,
        "reduced_margins": sum(len(r.get("reduced_margins") or []) for r in records),
        "came_back": came_back,
    }


def line(summary: Mapping[str, Any]) -> str:
    """``4 of 5 runs satisfied (80%); 40 replans, median 0.05 s, max 0.21 s`` (and with a
    deadline ``; by the deadline: 31 new plan, 9 shifted plan``)."""
    runs, fraction = summary["runs"], summary["satisfied_fraction"]
    text = f"{summary['satisfied']} of {counted(runs, 'run')} satisfied ({fraction:.0%})"
    if not summary["replans"]:
        return text + "; no replan"
    reduced, came_back = summary.get("reduced_margins"), summary.get("came_back")
    answers = ", ".join(f"{n} {kind}" for kind, n in (came_back or {}).items())
    return (
        f"{text}; {counted(summary['replans'], 'replan')}, median "
        f"{summary['replan_median_s']:.2f} s, max {summary['replan_max_s']:.2f} s"
        + (f"; {reduced} with smaller margins" if reduced else "")
        + (f"; by the deadline: {answers}" if answers else "")
    )


def document(records: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The ``--json`` document: ``runs`` (each run's record without its trajectory) and the
    overall figures, ``satisfied_fraction`` among them."""
    runs = [{k: v for k, v in r.items() if k != "executed"} for r in records]
    figures = {k: v for k, v in overall(records).items() if k != "runs"}
    return {"runs": runs, **figures}


def configuration(record: Mapping[str, Any]) -> str:
    """What a curve of the robustness figure stands for: ``every``, ``never, robust to 0.02``,
    ``on-deviation, vis1 lost at 4``."""
    parts = [str(record.get("replan"))]
    if record.get("robust_to"):
        parts.append(f"robust to {record['robust_to']:g}")
    parts += [f"{name} lost at {k}" for name, k in record.get("lose") or []]
    parts += [f"{name} closed at {k}" for name, k in record.get("close") or []]
    return ", ".join(parts)


def points(records: Iterable[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """One point per configuration and disturbance bound: its runs, the fraction satisfied and
    the runs that ended in an error (they count as not satisfied); by policy
    (:data:`~stlplan.simulation.settings.POLICIES`' order), configuration, bound."""
    groups: dict[tuple[int, str, float], list[Mapping[str, Any]]] = {}
    for record in records:
        order = POLICIES.index(record["replan"]) if record.get("replan") in POLICIES else 99
        key = (order, configuration(record), float(record["disturbance"]))
        groups.setdefault(key, []).append(record)
    found = []
    for (_, name, w), mine in sorted(groups.items()):
        satisfied = sum(1 for r in mine if r.get("satisfied"))
        found.append(
            {
                "configuration": name,
                "disturbance": w,
                "runs": len(mine),
                "satisfied": satisfied,
                "satisfied_fraction": satisfied / len(mine),
                "errors": sum(1 for r in mine if r.get("status") == "error"),
            }
        )
    return found


_CURVES: tuple[dict[str, Any], ...] = (
    dict(marker="o", markersize=8, linewidth=2.2, linestyle="-"),
    dict(marker="s", markersize=5, linewidth=1.4, linestyle="--"),
    dict(marker="^", markersize=6, linewidth=1.4, linestyle=":"),
    dict(marker="D", markersize=5, linewidth=1.2, linestyle="-."),
)
"""Curves told apart by marker and line as well as colour, so that equal curves stay visible."""
_NOTE: dict[str, Any] = dict(
    xytext=(5, -10), textcoords="offset points", fontsize=7, color="0.35", style="italic"
)


def plot_robustness(found: Sequence[Mapping[str, Any]], title: str, path: Path) -> None:
    """The fraction of runs satisfied against the disturbance bound ``W``, one curve per
    configuration (:func:`points`), each point labelled with its number of runs."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7.0, 4.2), dpi=150)
    ax = fig.add_subplot()
    names = list(dict.fromkeys(p["configuration"] for p in found))
    for i, name in enumerate(names):
        mine = [p for p in found if p["configuration"] == name]
        w = [p["disturbance"] for p in mine]
        y = [p["satisfied_fraction"] for p in mine]
        ax.plot(w, y, label=name, **_CURVES[i % len(_CURVES)])
        for p in mine:
            if p["errors"]:
                note = f"{p['errors']} error{'s' if p['errors'] > 1 else ''}"
                ax.annotate(note, (p["disturbance"], p["satisfied_fraction"]), **_NOTE)
    runs = sorted({p["runs"] for p in found})
    each = f"{counted(runs[0], 'run')} per point" if len(runs) == 1 else "runs per point vary"
    ax.set(xlabel="disturbance bound W (per state component and step)", ylim=(-0.04, 1.04))
    ax.set_ylabel("fraction of runs satisfied")
    ax.set_title(f"{title}: fraction satisfied against W ({each})", fontsize=10)
    ax.yaxis.set_major_formatter("{x:.0%}")
    ax.grid(True, color="0.9")
    ax.legend(title="replanning", fontsize=8, title_fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
