"""Where the time of a solve goes: lazy rounds, requirements, nodes, first plan, binding rows.

Each case is solved from the bench's random initial states (:func:`stlplan.bench.initial_problem`,
seed 0 by default), with safety between steps and with the paper's sampled semantics. For each
solve the round log (:attr:`stlplan.result.PlanResult.round_log`) gives

* the lazy rounds, and the requirements the final models hold (what the rounds added), by
  kind: separation or a constraint (obstacles, closed regions), at a step (sampled) or on a
  segment (between steps);
* HiGHS's branch-and-bound nodes over every round, and in the longest round;
* the time to the first plan that meets every requirement;

and step 1's plan (:attr:`~stlplan.result.PlanResult.values`) says which requirements *bind* at
the optimum: those of the whole problem (added or not) the plan meets with less than
:data:`BINDING` to spare above the model's least margin, by kind. Rows go to ``profile.csv`` and the table, one row per case and semantics (means and
maxima over states), to ``profile.md``. Run ``python -m stlplan.profile_bench --help``.
"""

from __future__ import annotations

import argparse
import csv
import os
import statistics
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from stlplan.bench import initial_problem
from stlplan.mission.problem import Problem
from stlplan.pipeline import plan
from stlplan.planner.backend.values import var_key
from stlplan.planner.config import PlannerConfig
from stlplan.planner.encoding.alphas import alpha_values
from stlplan.planner.encoding.deferred import kind
from stlplan.planner.encoding.model import build_model
from stlplan.planner.overrides import Overrides
from stlplan.result import PlanResult

BINDING = 1e-3
"""A requirement binds when the plan meets it with less than this to spare: step 1's plan is
within the gap (1e-4) of the optimum, and may sit that far from a boundary it would touch."""
KINDS = ("separation segment", "constraint segment", "separation step", "constraint step")
FIELDS = (
    "case", "semantics", "run", "status", "wall_s", "first_plan_s", "rounds", "nodes",
    "longest_round_s", "longest_round_nodes", *(f"added {k}" for k in KINDS),
    *(f"binding {k}" for k in KINDS),
)  # fmt: skip


def step1_states(problem: Problem, values: Mapping[tuple[str, Any], float]) -> dict[str, Any]:
    """The agents' states of step 1's plan, from its variable values (a state with no value
    is an error: the count would silently miss it)."""
    states = {}
    for agent in problem.agents:
        x = np.array(
            [
                [values.get(("x", (agent.name, k, i)), np.nan) for i in range(agent.n)]
                for k in range(problem.horizon + 1)
            ]
        )
        x[0] = agent.initial_state
        if np.isnan(x).any():
            raise ValueError(f"step 1's plan has no value for some state of '{agent.name}'")
        states[agent.name] = x
    return states


def binding(problem: Problem, result: PlanResult, config: PlannerConfig) -> dict[str, int]:
    """The requirements of ``problem`` that step 1's plan meets with less than :data:`BINDING`
    to spare above its own margin ``r`` (the model's, or the plan's value of it when the
    mission maximizes it), by kind."""
    pm = build_model(problem, config)
    assert pm.deferral is not None
    states = step1_states(problem, result.values)
    margin = pm.margin if isinstance(pm.margin, float) else result.values[var_key(pm.margin)]
    found = dict.fromkeys(KINDS, 0)
    for requirement in pm.deferral.lazy:
        if float(alpha_values(requirement, states).max()) - margin < BINDING:
            found[kind(requirement)] += 1
    return found


def profile_one(case: str, run: int, sampled: bool, args: argparse.Namespace) -> dict[str, Any]:
    """Solve one state of one case and profile it (module docstring)."""
    problem = initial_problem(case, args.seed, run)
    overrides = Overrides(
        time_limit=args.time_limit, threads=args.threads, inter_sample=False if sampled else None
    )
    tick = time.perf_counter()
    used, result = plan(problem, overrides)
    log = result.round_log
    longest = max(log, key=lambda r: r["seconds"]) if log else {}
    config = PlannerConfig.model_validate(dict(result.config))
    row: dict[str, Any] = {
        "case": case, "semantics": "sampled" if sampled else "between steps", "run": run,
        "status": result.status.value, "wall_s": round(time.perf_counter() - tick, 2),
        "first_plan_s": result.first_plan_seconds, "rounds": result.rounds,
        "nodes": sum(r.get("nodes") or 0 for r in log),
        "longest_round_s": longest.get("seconds"), "longest_round_nodes": longest.get("nodes"),
    }  # fmt: skip
    row.update({f"added {k}": result.requirements_by_kind.get(k, 0) for k in KINDS})
    if result.values:
        row.update({f"binding {k}": v for k, v in binding(used, result, config).items()})
    return row


def _figures(rows: Sequence[Mapping[str, Any]], field: str) -> list[float]:
    return [float(r[field]) for r in rows if r.get(field) is not None]


def summary(rows: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """One row per case and semantics: means (and maxima) over its states."""
    groups: dict[tuple[str, str], list[Mapping[str, Any]]] = {}
    for row in rows:
        groups.setdefault((row["case"], row["semantics"]), []).append(row)
    out = []
    for (case, semantics), mine in groups.items():
        found: dict[str, Any] = {"case": case, "semantics": semantics, "states": len(mine)}
        found["status"] = ", ".join(sorted({str(r["status"]) for r in mine}))
        for field in ("wall_s", "first_plan_s", "rounds", "nodes", "longest_round_s"):
            values = _figures(mine, field)
            found[field] = (statistics.fmean(values), max(values)) if values else (None, None)
        for field in FIELDS[9:]:
            values = _figures(mine, field)
            found[field] = statistics.fmean(values) if values else None
        out.append(found)
    return out


def table(found: Sequence[Mapping[str, Any]], header: str) -> str:
    """The summary as markdown: the times and rounds, then the requirements by kind."""

    def pair(value: tuple[float | None, float | None], digits: int = 1) -> str:
        return " / ".join("-" if v is None else f"{v:.{digits}f}" for v in value)

    def one(value: float | None) -> str:
        return "-" if value is None else f"{value:.1f}"

    lines = [header, "", "| case | semantics | states | status | wall s, mean / max | first plan "
             "s, mean / max | rounds, mean / max | nodes, mean / max | longest round s, mean / "
             "max |", "|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for f in found:
        lines.append(
            f"| {f['case']} | {f['semantics']} | {f['states']} | {f['status']} "
            f"| {pair(f['wall_s'])} | {pair(f['first_plan_s'])} | {pair(f['rounds'])} "
            f"| {pair(f['nodes'], 0)} | {pair(f['longest_round_s'])} |"
        )
    kinds = " | ".join(f"{k}: added / binding" for k in KINDS)
    lines += ["", f"| case | semantics | {kinds} |", "|---|---|" + "---|" * len(KINDS)]
    for f in found:
        cells = " | ".join(f"{one(f[f'added {k}'])} / {one(f[f'binding {k}'])}" for k in KINDS)
        lines.append(f"| {f['case']} | {f['semantics']} | {cells} |")
    return "\n".join(lines) + "\n"


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="python -m stlplan.profile_bench", description=__doc__)
    parser.add_argument("--cases", nargs="+", default=["farm", "farm-case2", "farm-case3"])
    parser.add_argument("--runs", type=int, default=3, help="random states per case")
    parser.add_argument("--seed", type=int, default=0, help="seed of the random states")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--time-limit", type=float, default=300.0, help="per solve, s")
    parser.add_argument(
        "--semantics", nargs="+", choices=("between", "sampled"), default=["between", "sampled"]
    )
    parser.add_argument("--out", default="bench-results/profile")
    return parser.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> None:
    args = parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    with (out / "profile.csv").open("w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=FIELDS)
        writer.writeheader()
        for case in args.cases:
            for semantics in args.semantics:
                for run in range(args.runs):
                    row = profile_one(case, run, semantics == "sampled", args)
                    writer.writerow(row)
                    f.flush()
                    rows.append(row)
                    print(f"{case} {row['semantics']} state {run}: {row['status']}, "
                          f"{row['wall_s']} s, {row['rounds']} rounds", flush=True)  # fmt: skip
    header = (
        f"Seed {args.seed}, states 0-{args.runs - 1}, {args.threads} HiGHS thread(s), "
        f"{args.time_limit:g} s per solve, load average {os.getloadavg()[0]:.1f} at the end"
    )
    (out / "profile.md").write_text(table(summary(rows), header), encoding="utf-8")
    print(f"table in {out / 'profile.md'}")


if __name__ == "__main__":
    main()
