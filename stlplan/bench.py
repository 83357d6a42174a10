"""Benchmark of the farm cases and the general-STL suite, formulation against formulation.

Each farm case (``missions/<case>.yaml``) is solved from random initial states drawn as a sweep
draws them (:func:`stlplan.sweep.initial.draw_positions` with a fixed seed, runs ``0..n-1``):
uniform in the initial area, at rest, pairwise at least ``d_col`` apart. A mission of the suite
(``missions/stl/``, cases ``stl/<name>``, all of them by ``--cases suite``) has no initial area: it
is solved once per formulation, as written; so is a farm whose agents start at depots
(``scale/farm-x2-depot``, ``scale/farm-depot-small``), and so is a crowd (``crowd/crowd-N``).
Every run is solved with the default formulation (the planner's defaults: lazy obstacle and
collision rows, effort floors) and the first few runs of each case also with the straightforward
formulation (every row up front, no floors) under a generous time limit, so the two can be
compared on the same states. Every plan goes through the monitor.

This is a benchmark, not a test: it only measures. Solves run one after another (the machine's
cores go to HiGHS's threads); results are appended to ``bench.csv`` as they come and the table is
rewritten as ``bench.md`` after each solve, in ``bench-results/`` by default.

Run ``python -m stlplan.bench --help`` for the options; ``make bench`` and ``make bench-quick``.
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import json
import shlex
import sys
import time
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from stlplan.bench_report import COLUMNS, markdown
from stlplan.errors import StlplanError
from stlplan.examples import missions_dir

CASES = ("farm", "farm-case2", "farm-case3")
SCALE_CASES = ("scale/farm-x2", "scale/farm-x2-same", "scale/farm-x3", "scale/farm-x4")
"""Case I's map and tasks with the team replicated 2, 3 and 4 times (16, 24, 32 agents), crops B
and C's counts multiplied alike; ``farm-x2-same`` keeps Case I's counts for 16 agents."""
DEPOT_CASES = ("scale/farm-x2-depot", "scale/farm-depot-small")
"""Farms whose agents of one capability share a depot, no separation: classes of interchangeable
agents (``--formulations no-symmetry symmetry``); solved once, as written, like the suite."""
CROWD_CASES = ("crowd/crowd-16", "crowd/crowd-32", "crowd/crowd-64")
"""Antipodal swaps of 16, 32 and 64 single integrators past four pillars, with separation
(:mod:`stlplan.crowd`); solved once, as written."""
SUITE = tuple(f"stl/{p.stem}" for p in sorted((missions_dir() / "stl").glob("*.yaml")))
"""The general-STL suite: single- and multi-agent missions, some infeasible, solved as written."""
NO_PLAN = ("infeasible", "no_plan")
"""Statuses of a solve that ends without a plan for the monitor to judge."""

FORMULATIONS: dict[str, dict[str, Any]] = {
    "default": {},
    "sampled": {"inter_sample": False},
    "straightforward": {"lazy.enabled": False, "model.floors": False},
    "no-floors": {"model.floors": False},
    "symmetry": {"model.symmetry": True},
    "no-symmetry": {"model.symmetry": False},
    "per-element": {"model.shared_subformulas": False},
    "no-in-turn": {"repair.after_round_seconds": None, "repair.crowd_agents": None},
    "in-turn-by-time": {"repair.crowd_agents": None},
    "in-turn-always": {"repair.after_round_seconds": 0.0},
    "no-parts": {"parts.enabled": False},
    "lazy-only": {"parts.enabled": False, "model.floors": False},
    "deterministic": {"solver.deterministic": True},
    "log": {"model.encoding": "log"},
    "groups": {"model.tasks": "groups"},
    "standard": {"model.encoding": "standard"},
    "heuristics-0.01": {"solver.highs_options": {"mip_heuristic_effort": 0.01}},
    "heuristics-0.2": {"solver.highs_options": {"mip_heuristic_effort": 0.2}},
}
"""Formulation name to dotted :class:`stlplan.planner.config.PlannerConfig` overrides
(``inter_sample`` goes to the problem: ``sampled`` is the paper's semantics, safety judged at the
steps only)."""


@dataclass(frozen=True)
class Job:
    """One solve of the benchmark."""

    case: str
    run: int
    formulation: str
    time_limit: float


def initial_problem(case: str, seed: int, run: int) -> Any:
    """The problem one run of a case solves (module docstring).

    Parameters
    ----------
    case
        The case: a mission file's path under ``missions/``, without ``.yaml``.
    seed, run
        The draw of the initial states (:func:`stlplan.sweep.initial.draw_positions`).

    Returns
    -------
    Problem
        A farm case from the run's drawn initial states; a mission without an initial area
        (the suite, the farms starting at depots) as written, whatever ``seed`` and ``run``.
    """
    from stlplan.mission.loader import load_problem
    from stlplan.mission.problem import build_problem
    from stlplan.sweep.initial import draw_positions, with_initial_positions

    path = missions_dir() / f"{case}.yaml"
    problem = load_problem(path)
    mission = problem.mission
    if mission.sweep is None:  # a suite mission: its own initial states
        return problem
    positions = draw_positions(mission, seed, run)
    return build_problem(with_initial_positions(mission, positions), source=str(path))


def _overrides(job: Job, threads: int | None) -> Any:
    """The job's formulation as :class:`stlplan.api.Overrides` (inter-sample safety apart)."""
    from stlplan.api import Overrides

    chosen = dict(FORMULATIONS[job.formulation])
    inter_sample = chosen.pop("inter_sample", None)
    return Overrides(
        time_limit=job.time_limit,
        threads=threads,
        inter_sample=inter_sample,
        config=chosen,
    )


def solve_job(job: Job, seed: int, threads: int | None) -> dict[str, Any]:
    """Solve one job through the API (plan, then the monitor); never raises for a bad solve."""
    from stlplan import api

    row: dict[str, Any] = {
        "case": job.case, "seed": seed, "run": job.run, "formulation": job.formulation
    }  # fmt: skip
    problem = initial_problem(job.case, seed, job.run)
    overrides = _overrides(job, threads)
    tick, cpu = time.perf_counter(), time.process_time()
    try:
        _, result = api.plan(problem, overrides)
    except StlplanError as exc:  # the monitor rejected the plan, or HiGHS failed
        row.update(status="error", accepted=False, message=str(exc))
        row["wall_s"] = round(time.perf_counter() - tick, 2)
        row["cpu_s"] = round(time.process_time() - cpu, 2)
        return row
    size = result.model_size
    report = result.report
    row.update(
        variables=size.variables if size else None,
        binaries=size.binaries if size else None,
        constraints=size.constraints if size else None,
        build_s=round(result.build_seconds or 0.0, 2),
        solve_s=round(result.solve_seconds or 0.0, 2),
        wall_s=round(time.perf_counter() - tick, 2),
        cpu_s=round(time.process_time() - cpu, 2),
        first_plan_s=None
        if result.first_plan_seconds is None
        else round(result.first_plan_seconds, 2),
        decisions=decisions(result.round_log),
        first_plan_stage=result.trace.get("first_plan"),
        final_plan_stage=result.trace.get("final_plan"),
        rounds=result.rounds,
        requirements_added=result.requirements_added,
        requirements_candidates=result.requirements_candidates,
        requirements_unneeded=result.requirements_unneeded,
        status=result.status.value,
        accepted=None
        if report is None and result.status.value in NO_PLAN
        else bool(report is not None and report.satisfied),
        gap=None if result.gap is None else f"{result.gap:.2e}",
        rho_s=None if report is None else report.rho_s,
        objective=_step1_objective(result),
        bound=None if result.bound is None else round(result.bound, 6) + 0.0,
        effort=None if result.effort is None else round(result.effort, 4) + 0.0,
        message=result.message,
    )
    return row


def decisions(round_log: Sequence[Mapping[str, Any]]) -> str:
    """A digest of a run's decisions: each lazy round's part, stage, termination, nodes and
    requirements held. Two versions of the code that should change no result give the same
    digest on a deterministic run (``--formulations deterministic``)."""
    keys = ("part", "stage", "ended", "nodes", "held")
    taken = [{k: r.get(k) for k in keys} for r in round_log]
    return hashlib.sha1(json.dumps(taken, sort_keys=True).encode()).hexdigest()[:12]


def plan_jobs(args: argparse.Namespace) -> Iterator[Job]:
    """Every run with each formulation, then the first runs with the comparison ones."""
    for case in args.cases:
        as_written = case in SUITE + DEPOT_CASES + CROWD_CASES
        runs = 1 if as_written else args.runs  # one initial state, as written
        for run in range(args.first_run, args.first_run + runs):
            for name in args.formulations:
                yield Job(case, run, name, args.time_limit)
            if run < args.first_run + args.compare_runs and case in args.compare_cases:
                for name in args.compare:
                    yield Job(case, run, name, args.compare_time_limit)


def _step1_objective(result: Any) -> float | None:
    """The optimum of problem (step1) the solver proved (before step 2 moved the plan)."""
    solver = result.solver
    value = solver.objective if solver is not None else result.objective
    return None if value is None else round(value, 6) + 0.0  # never -0.0 in bench.csv


def machine_header(threads: int | None, gap: float = 1e-4) -> str:
    """One line on the solver and machine the figures come from."""
    import os
    import platform

    import highspy

    version = f"{highspy.HIGHS_VERSION_MAJOR}.{highspy.HIGHS_VERSION_MINOR}"
    return (
        f"HiGHS {version}, threads {threads or 'auto'}, relative gap {gap:g} (the missions'), "
        f"{os.cpu_count()} cores, Python {platform.python_version()}, "
        f"{time.strftime('%Y-%m-%d %H:%M')}"
    )


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """Command-line options (see ``python -m stlplan.bench --help``)."""
    parser = argparse.ArgumentParser(prog="python -m stlplan.bench", description=__doc__.split(
        "\n\n")[0])  # fmt: skip
    parser.add_argument("--cases", nargs="+", default=list(CASES),
                        choices=(*CASES, *SCALE_CASES, *DEPOT_CASES, *CROWD_CASES, *SUITE,
                                 "suite"),
                        help="farm cases, scaled farms (scale/farm-xK), farms with depots, crowds "
                        "(crowd/crowd-N), suite missions (stl/NAME), or 'suite' for all of "
                        "them")  # fmt: skip
    parser.add_argument("--runs", type=int, default=30, help="initial states per case")
    parser.add_argument("--first-run", type=int, default=0, help="index of the first state")
    parser.add_argument("--seed", type=int, default=0, help="seed of the initial states")
    parser.add_argument("--formulations", nargs="+", default=["default"], choices=FORMULATIONS)
    parser.add_argument("--time-limit", type=float, default=600.0, help="per solve, s")
    parser.add_argument("--compare", nargs="*", default=["straightforward"], choices=FORMULATIONS,
                        help="formulations also solved on the first --compare-runs states")  # fmt: skip
    parser.add_argument("--compare-runs", type=int, default=3)
    parser.add_argument(
        "--compare-cases", nargs="*", default=list(CASES), choices=CASES + SCALE_CASES
    )
    parser.add_argument("--compare-time-limit", type=float, default=900.0)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--base", default="default", choices=FORMULATIONS,
                        help="formulation the others are compared with, state by state")  # fmt: skip
    parser.add_argument("--out", type=Path, default=Path("bench-results"))
    parser.add_argument("--name", default="bench", help="file stem of the CSV and Markdown")
    parser.add_argument("--render", action="store_true",
                        help="solve nothing: rewrite NAME.md from NAME.csv")  # fmt: skip
    args = parser.parse_args(argv)
    args.cases = [c for case in args.cases for c in (SUITE if case == "suite" else (case,))]
    return args


def render(csv_path: Path, md_path: Path, base: str = "default") -> None:
    """Rewrite the Markdown of an earlier run from its CSV (header and command kept)."""
    with open(csv_path, newline="", encoding="utf-8") as handle:
        rows: list[dict[str, Any]] = [{**r, "run": int(r["run"])} for r in csv.DictReader(handle)]
    old = md_path.read_text(encoding="utf-8").splitlines() if md_path.exists() else []
    header = next((line for line in old if line.startswith("HiGHS ")), "(machine not recorded)")
    command = next((line[10:-1] for line in old if line.startswith("Command: `")), "(unknown)")
    md_path.write_text(markdown(rows, command, header, base), encoding="utf-8")


def main(argv: Sequence[str] | None = None) -> int:
    """Run the benchmark; returns 0 when every plan was accepted by the monitor (a solve may
    also end without a plan: infeasible, or none within the time limit)."""
    args = parse_args(argv)
    command = "python -m stlplan.bench " + shlex.join(sys.argv[1:] if argv is None else argv)
    args.out.mkdir(parents=True, exist_ok=True)
    csv_path, md_path = args.out / f"{args.name}.csv", args.out / f"{args.name}.md"
    if args.render:
        render(csv_path, md_path, args.base)
        print(md_path.read_text(encoding="utf-8"))
        return 0
    header = machine_header(args.threads)
    rows: list[dict[str, Any]] = []
    jobs = list(plan_jobs(args))
    with open(csv_path, "w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=COLUMNS, extrasaction="ignore")
        writer.writeheader()
        for n, job in enumerate(jobs, 1):
            row = solve_job(job, args.seed, args.threads)
            rows.append(row)
            writer.writerow(row)
            handle.flush()
            md_path.write_text(markdown(rows, command, header, args.base), encoding="utf-8")
            print(f"[{n}/{len(jobs)}] {job.case} run {job.run} {job.formulation}: "
                  f"{row.get('status')} in {row.get('wall_s')} s, objective "
                  f"{row.get('objective')}, rounds {row.get('rounds')}", file=sys.stderr,
                  flush=True)  # fmt: skip
    print(md_path.read_text(encoding="utf-8") if rows else "no solves")
    return 0 if all(r.get("accepted") or r.get("status") in NO_PLAN for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
