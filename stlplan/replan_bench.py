"""Benchmark of replanning: how fast a plan comes back after a drift, a lost agent or a closed region.

The mission (Case I by default) is planned once from its shipped initial states. For each step
``K``, the plan is replanned from ``K`` as it is (nothing changed: the plan is its own start),
then with its positions at ``K`` moved by a uniform draw in ``[-W, W]`` per component
(fixed seed, clipped to the state bounds), and the mission is replanned from ``K`` twice: once
stopping at the first plan that meets every requirement (``--first-plan``: the time to a plan
the monitor accepts) and once to the proven optimum. Then the plan is replanned with one agent
lost at a step (``vis1`` at 4, which drops nothing; ``uv1`` at 2, which drops a task), then
with a region closed at a step (``A2`` at 3, which drops its task), nothing moved. Every plan
goes through the monitor.

This is a benchmark, not a test: it only measures. Rows go to ``replan.csv`` as they come and
the table, with the median and max per kind, to ``replan.md``, in ``bench-results/`` by default.
Run ``python -m stlplan.replan_bench --help``; ``make bench-replan``.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from stlplan.mission.loader import load_problem
from stlplan.mission.problem import Problem
from stlplan.pipeline import plan
from stlplan.planner.overrides import Overrides
from stlplan.replanning import replan
from stlplan.result import PlanResult, Trajectory

FIELDS = ("kind", "step", "status", "accepted", "seconds", "objective", "gap", "message")


def moved(
    problem: Problem, trajectory: Trajectory, step: int, width: float, seed: int
) -> Trajectory:
    """``trajectory`` with every agent's position at ``step`` moved by a uniform draw in
    ``[-width, width]`` per component (clipped to the state bounds)."""
    rng = np.random.default_rng([seed, step])
    states = {}
    for agent in problem.agents:
        x = np.array(trajectory.states[agent.name], dtype=float)
        where = list(agent.position)
        x[step, where] += rng.uniform(-width, width, len(where))
        x[step] = np.clip(x[step], agent.state_lo, agent.state_hi)
        states[agent.name] = x
    return dataclasses.replace(trajectory, states=states)


def row(kind: str, step: int, result: PlanResult, seconds: float) -> dict[str, object]:
    """One replan's row: accepted when the monitor fails nothing but the tasks the plan
    dropped and what the executed past broke."""
    given_up = {d.task for d in result.dropped} | set(result.broken_by_the_past)
    failed = (
        set()
        if result.report is None
        else {v.name for v in result.report.verdicts if not v.satisfied}
    )
    accepted = result.report is not None and failed <= given_up
    return {
        "kind": kind, "step": step, "status": result.status.value, "accepted": accepted,
        "seconds": round(seconds, 3), "objective": result.objective, "gap": result.gap,
        "message": result.message,
    }  # fmt: skip


def _timed(
    problem: Problem,
    executed: Trajectory,
    step: int,
    overrides: Overrides,
    events: tuple[tuple[str, ...], tuple[str, ...]],
) -> tuple[PlanResult, float]:
    tick = time.perf_counter()
    lost, closed = events
    _, result = replan(problem, executed, step, lost, closed, overrides=overrides)
    return result, time.perf_counter() - tick


def run(args: argparse.Namespace) -> list[dict[str, object]]:
    """Every replan of the module docstring; rows written as they come."""
    problem = load_problem(args.mission)
    base = Overrides(time_limit=args.time_limit, threads=args.threads)
    _, first = plan(problem, base)
    assert first.trajectory is not None, first.message
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows: list[dict[str, object]] = []
    with (out / "replan.csv").open("w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=FIELDS)
        writer.writeheader()
        jobs: list[tuple[str, int | str, tuple[tuple[str, ...], tuple[str, ...]]]]
        jobs = [("unchanged", k, ((), ())) for k in args.steps]
        jobs += [(f"moved {args.drift:g}", k, ((), ())) for k in args.steps]
        jobs += [(f"{a} lost", k, ((a,), ())) for a, k in (s.split("@") for s in args.lose)]
        jobs += [(f"{r} closed", k, ((), (r,))) for r, k in (s.split("@") for s in args.close)]
        for kind, k, events in jobs:
            k = int(k)
            width = args.drift if kind.startswith("moved") else 0.0
            executed = moved(problem, first.trajectory, k, width, args.seed)
            for label, first_plan in (("first plan", True), ("optimum", False)):
                overrides = dataclasses.replace(base, first_plan=first_plan or None)
                result, seconds = _timed(problem, executed, k, overrides, events)
                rows.append(row(f"{kind}, {label}", k, result, seconds))
                writer.writerow(rows[-1])
                f.flush()
                print(
                    f"{kind}, {label}, K={k}: {result.status.value} in {seconds:.2f} s", flush=True
                )
    (out / "replan.md").write_text(table(rows), encoding="utf-8")
    return rows


def table(rows: Sequence[dict[str, object]]) -> str:
    """The rows, then the median and max time of each kind."""
    lines = [
        "| kind | K | status | accepted | s | objective | gap |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        gap = "-" if r["gap"] is None else f"{float(r['gap']):.2e}"  # type: ignore[arg-type]
        lines.append(
            f"| {r['kind']} | {r['step']} | {r['status']} | {r['accepted']} | {r['seconds']} "
            f"| {r['objective']} | {gap} |"
        )
    lines += ["", "| kind | runs | accepted | median s | max s |", "|---|---|---|---|---|"]
    for kind in dict.fromkeys(str(r["kind"]) for r in rows):
        mine = [r for r in rows if r["kind"] == kind]
        times = [float(r["seconds"]) for r in mine]  # type: ignore[arg-type]
        accepted = sum(1 for r in mine if r["accepted"])
        lines.append(
            f"| {kind} | {len(mine)} | {accepted} | {np.median(times):.2f} | {max(times):.2f} |"
        )
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> None:
    """Command line of the benchmark."""
    parser = argparse.ArgumentParser(
        prog="python -m stlplan.replan_bench", description=__doc__.split("\n")[0]
    )
    parser.add_argument("--mission", default="missions/farm.yaml")
    parser.add_argument("--steps", type=int, nargs="+", default=[2, 3, 4, 5, 6, 7])
    parser.add_argument("--drift", type=float, default=0.05, help="W: positions moved by up to W")
    parser.add_argument("--lose", nargs="*", default=["vis1@4", "uv1@2"], metavar="AGENT@K")
    parser.add_argument("--close", nargs="*", default=["A2@3"], metavar="REGION@K")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--time-limit", type=float, default=300.0)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--out", default="bench-results/replan")
    run(parser.parse_args(argv))


if __name__ == "__main__":
    main()
