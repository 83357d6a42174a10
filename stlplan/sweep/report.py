"""The sweep summary: the paper's Table 3 per mission, as CSV, Markdown and a figure."""

from __future__ import annotations

import csv
import io
from collections import Counter
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from stlplan.words import counted

COLUMNS = ("mission", "runs", "statuses", "mean_s", "median_s", "max_s", "rho_s", "monitor_ok")


def _time(record: dict[str, Any]) -> float:
    return float(record.get("build_seconds", 0.0)) + float(record.get("solve_seconds", 0.0))


def _counts(values: list[Any]) -> str:
    return ", ".join(f"{k}: {n}" for k, n in sorted(Counter(values).items(), key=str))


def summarize(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per mission: status counts, mean / median / max time, rho_s distribution."""
    rows = []
    for mission in sorted({r["mission"] for r in records}):
        mine = [r for r in records if r["mission"] == mission]
        times = np.array([_time(r) for r in mine if "solve_seconds" in r] or [np.nan])
        rho = [_fmt(r.get("rho_s")) for r in mine if r.get("rho_s") is not None]
        rows.append(
            {
                "mission": mission,
                "runs": len(mine),
                "statuses": _counts([r["status"] for r in mine]),
                "mean_s": round(float(np.nanmean(times)), 2) if np.isfinite(times).any() else None,
                "median_s": round(float(np.nanmedian(times)), 2)
                if np.isfinite(times).any()
                else None,
                "max_s": round(float(np.nanmax(times)), 2) if np.isfinite(times).any() else None,
                "rho_s": _counts(rho) or "-",
                "monitor_ok": sum(1 for r in mine if r.get("monitor_satisfied")),
            }
        )
    return rows


def _fmt(value: Any) -> str:
    return str(int(value)) if float(value).is_integer() else f"{value:.3g}"


def to_csv(rows: list[dict[str, Any]], columns: Sequence[str] = COLUMNS) -> str:
    """The table as CSV text."""
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=columns, extrasaction="ignore")
    writer.writeheader()
    writer.writerows(rows)
    return buffer.getvalue()


def to_markdown(rows: list[dict[str, Any]], columns: Sequence[str] = COLUMNS) -> str:
    """The table as a Markdown table (a sweep's: build + solve seconds, mean / median / max)."""
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    for row in rows:
        lines.append(
            "| " + " | ".join("-" if row[c] is None else str(row[c]) for c in columns) + " |"
        )
    return "\n".join(lines) + "\n"


def plot_times(records: list[dict[str, Any]], path: Path) -> None:
    """Solve-time distribution per mission (box plot with the runs as dots)."""
    from matplotlib.figure import Figure

    missions = sorted({r["mission"] for r in records})
    data = [
        [_time(r) for r in records if r["mission"] == m and "solve_seconds" in r] for m in missions
    ]
    fig = Figure(figsize=(max(4.0, 1.6 * len(missions) + 2), 4), dpi=150)
    ax = fig.add_subplot()
    ax.boxplot([d or [np.nan] for d in data], showfliers=False)
    ax.set_xticks(range(1, len(missions) + 1), missions)
    rng = np.random.default_rng(0)
    for i, values in enumerate(data, start=1):
        ax.scatter(i + rng.uniform(-0.12, 0.12, len(values)), values, s=12, alpha=0.6)
    ax.set_ylabel("build + solve time [s]")
    ax.set_title(f"stlplan sweep: {counted(sum(len(d) for d in data), 'run')}")
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path)
