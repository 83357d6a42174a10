"""The benchmark's report: a summary per case and formulation, the same states side by side,
and one row per solve, as Markdown (:mod:`stlplan.bench` solves and writes the rows)."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

from stlplan.result import PlanStatus

GAP = 1e-4
"""The missions' relative gap: two optimal objectives of one state agree within it."""

COLUMNS = (
    "case", "seed", "run", "formulation", "variables", "binaries", "constraints", "build_s",
    "solve_s", "wall_s", "cpu_s", "first_plan_s", "decisions", "first_plan_stage",
    "final_plan_stage", "rounds", "requirements_added", "requirements_candidates",
    "requirements_unneeded", "status", "accepted", "gap", "rho_s", "objective", "bound",
    "effort", "message",
)  # fmt: skip


def summary_rows(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per case and formulation: runs, how many ended with a plan, optimal and accepted counts,
    mean/median/max wall time, the latest first plan and the largest gap of a plan: the written
    plan's, and step 1's plan's to the bound."""
    out = []
    keys = sorted({(r["case"], r["formulation"]) for r in rows}, key=lambda k: (k[0], k[1]))
    for case, name in keys:
        mine = [r for r in rows if r["case"] == case and r["formulation"] == name]
        times = np.array([float(r["wall_s"]) for r in mine])
        out.append({
            "case": case,
            "formulation": name,
            "runs": len(mine),
            "with_plan": sum(1 for r in mine if _has_plan(r)),
            "optimal": sum(1 for r in mine if r.get("status") == "optimal"),
            "infeasible": sum(1 for r in mine if r.get("status") == "infeasible"),
            "accepted": sum(1 for r in mine if r.get("accepted") in (True, "True")),
            "mean_s": round(float(times.mean()), 1),
            "median_s": round(float(np.median(times)), 1),
            "max_s": round(float(times.max()), 1),
            "mean_cpu_s": _mean(r.get("cpu_s") for r in mine),
            "mean_rounds": round(float(np.mean([float(r.get("rounds") or 1) for r in mine])), 1),
            "max_first_plan_s": _largest(r.get("first_plan_s") for r in mine),
            "max_gap": _largest(r.get("gap") for r in mine if _has_plan(r)),
            "max_step1_gap": _largest(_step1_gap(r) for r in mine if _has_plan(r)),
        })  # fmt: skip
    return out


def _step1_gap(row: dict[str, Any]) -> float | None:
    """The gap of step 1's plan (before step 2 moved it) to the bound the run ended with."""
    objective, bound = _number(row.get("objective")), _number(row.get("bound"))
    if objective is None or bound is None or objective == 0:
        return None
    return round(max(0.0, (bound - objective) / abs(objective)), 6)


def _has_plan(row: dict[str, Any]) -> bool:
    """Whether the solve of ``row`` ended with a plan."""
    return PlanStatus(row.get("status") or "error").has_plan


def _largest(values: Iterator[Any]) -> float | None:
    """The largest of the recorded numbers; None when one is missing (a run without it)."""
    numbers = [_number(v) for v in values]
    if not numbers or None in numbers:
        return None
    return max(n for n in numbers if n is not None)


def side_by_side(rows: Sequence[dict[str, Any]], base: str = "default") -> list[dict[str, Any]]:
    """Per state solved by ``base`` and another formulation: both times, their ratio, objectives.

    ``agree``: both optimal and the objectives within the relative gap of each other, or the
    other stopped at its limit with an objective no better than ``base``'s (a maximization), or
    both infeasible. ``speed_up`` compares wall times, ``cpu_ratio`` the process CPU times (the
    fairer figure on a shared machine: HiGHS runs in the process, on the threads given).
    """
    index = {(r["case"], r["run"], r["formulation"]): r for r in rows}
    out = []
    for (case, run, name), other in index.items():
        mine = index.get((case, run, base))
        if name == base or mine is None:
            continue
        a, b = _number(mine.get("objective")), _number(other.get("objective"))
        ta, tb = float(mine["wall_s"]), float(other["wall_s"])
        agree = None
        if mine.get("status") == other.get("status") == "infeasible":
            agree = True
        elif a is not None and b is not None:
            both = mine.get("status") == other.get("status") == "optimal"
            agree = abs(a - b) <= GAP * max(abs(a), abs(b)) if both else b <= a + GAP * abs(a)
        ca, cb = _number(mine.get("cpu_s")), _number(other.get("cpu_s"))
        out.append({
            "case": case, "run": run, "formulation": name, f"{base}_s": ta,
            "other_s": tb, "speed_up": round(tb / ta, 1) if ta > 0 else None,
            "other_status": other.get("status"), f"{base}_objective": a,
            "other_objective": b, "agree": agree,
            "cpu_ratio": round(cb / ca, 2) if ca and cb is not None else None,
        })  # fmt: skip
    return out


def _mean(values: Iterator[Any]) -> float | None:
    """Mean of the recorded numbers (None where none was recorded)."""
    numbers = [float(v) for v in values if v not in (None, "")]
    return round(float(np.mean(numbers)), 1) if numbers else None


def _number(value: Any) -> float | None:
    return None if value in (None, "") else float(value)


def markdown(
    rows: Sequence[dict[str, Any]], command: str, header: str, base: str = "default"
) -> str:
    """The summary table, the side-by-side comparison, then one row per solve, as Markdown."""

    def table(records: Sequence[dict[str, Any]], columns: Sequence[str]) -> list[str]:
        lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
        for r in records:
            lines.append("| " + " | ".join(_cell(r.get(c)) for c in columns) + " |")
        return lines

    summary = summary_rows(rows)
    lines = [f"# stlplan benchmark\n\n{header}\n\nCommand: `{command}`\n", "## Summary\n"]
    lines += table(summary, list(summary[0]) if summary else ["case"])
    pairs = side_by_side(rows, base)
    if pairs:
        lines += ["", f"## Side by side (same states; speed_up = other time / {base} time)\n"]
        lines += table(pairs, list(pairs[0]))
    lines += ["", "## Runs (wall_s: plan + monitor, seconds)\n"]
    lines += table(rows, [c for c in COLUMNS if c != "message"])
    return "\n".join(lines) + "\n"


def _cell(value: Any) -> str:
    if value is None or value == "":
        return "-"
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)
