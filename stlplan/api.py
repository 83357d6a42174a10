"""The Python API under the command line: load, plan, check, write.

Every function returns typed results and raises :class:`stlplan.errors.StlplanError` subclasses on
bad input; nothing here prints.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from stlplan.errors import SolverError
from stlplan.mission.loader import load_problem
from stlplan.mission.problem import Problem
from stlplan.monitor.verdicts import check as monitor_check
from stlplan.outputs.directory import prepare_directory, write_all, write_json
from stlplan.outputs.summary import summary_dict
from stlplan.outputs.trajio import read_trajectory_csv, write_trajectory_csv
from stlplan.planner import stops
from stlplan.planner.diagnose import cheap_reasons, diagnose
from stlplan.planner.figures import reported
from stlplan.result import Diagnosis, MonitorReport, PlanResult, PlanStatus


def validate(mission: str | Path) -> Problem:
    """Load and check a mission file; raise on the first mistake."""
    return load_problem(mission)


def check(
    mission: str | Path | Problem, trajectory: str | Path, inter_sample: bool | None = None
) -> tuple[Problem, MonitorReport]:
    """The monitor's verdicts on a trajectory CSV for a mission (``inter_sample``: judge safety
    between steps too; None keeps the mission's ``safety.inter_sample``)."""
    problem = mission if isinstance(mission, Problem) else load_problem(mission)
    problem = problem.with_inter_sample(inter_sample)
    return problem, monitor_check(problem, read_trajectory_csv(problem, Path(trajectory)))


def plot_trajectory(
    problem: Problem, trajectory: str | Path, report: MonitorReport, out: str | Path
) -> None:
    """Draw the map of a trajectory CSV (``plan.png`` style) with the monitor's ``report``."""
    from stlplan.outputs.plots import plot_plan

    traj = read_trajectory_csv(problem, Path(trajectory))
    plot_plan(problem, traj, report, out, title=f"{problem.mission.name}: {Path(trajectory).name}")


def _verified(problem: Problem, result: PlanResult, gap: float) -> PlanResult:
    """Attach the monitor's report and report the written plan's figures
    (:func:`stlplan.planner.figures.reported`); a plan the monitor rejects is an error, never an output.
    """
    if result.trajectory is None:
        return result
    report = monitor_check(problem, result.trajectory)
    failed = [v for v in report.verdicts if not v.satisfied]
    if failed:
        lines = "; ".join(f"{v.name}: {v.detail}" for v in failed)
        raise SolverError(f"the solver's plan is rejected by the monitor ({lines})")
    return reported(problem, result, report, gap)


@contextlib.contextmanager
def _quiet_pyomo() -> Iterator[None]:
    """Silence Pyomo's warnings about solver values a hair outside bounds (solver round-off)."""
    logger = logging.getLogger("pyomo.core")
    level = logger.level
    logger.setLevel(logging.ERROR)
    try:
        yield
    finally:
        logger.setLevel(level)


def plan(
    mission: str | Path | Problem,
    progress: Callable[[Any], None] | None = None,
    diagnose_infeasible: bool = True,
    inter_sample: bool | None = None,
    **overrides: Any,
) -> tuple[Problem, PlanResult]:
    """Solve a mission and verify the plan with the monitor.

    ``inter_sample`` turns safety on the segments between steps on or off (None keeps the
    mission's ``safety.inter_sample``).

    ``overrides`` are :class:`stlplan.planner.solve.PlanOptions` fields (``time_limit``, ``gap``,
    ``threads``, ``seed``, ``encoding``, ``two_step``); None keeps the mission's value. The time
    limit bounds the whole call, diagnosis included. An infeasible mission comes back with a
    :class:`~stlplan.result.Diagnosis` (cheap reasons found before solving, or a minimal
    conflict found by feasibility solves).

    In the main thread, SIGINT and SIGTERM during a solve stop HiGHS and the best plan so far
    comes back verified with status ``interrupted`` (:mod:`stlplan.planner.stops`); a second signal, or
    one outside a solve, raises :class:`stlplan.planner.stops.Interrupted`.
    """
    from stlplan.planner.solve import PlanOptions
    from stlplan.planner.solve import plan as solve_plan

    problem = mission if isinstance(mission, Problem) else load_problem(mission)
    problem = problem.with_inter_sample(inter_sample)
    options = PlanOptions.from_mission(problem.mission, **overrides)
    deadline = time.perf_counter() + options.time_limit
    reasons = cheap_reasons(problem)
    if reasons:
        diagnosis = Diagnosis(reasons, tuple(dict.fromkeys(r.split("'")[1] for r in reasons)))
        message = f"infeasible before solving: {len(reasons)} requirement(s) cannot be met in time"
        return problem, PlanResult(PlanStatus.INFEASIBLE, message, diagnosis=diagnosis)
    with stops.stop_on_signals(), _quiet_pyomo():
        result = solve_plan(problem, options, progress=progress, deadline=deadline)
        if result.status is PlanStatus.INFEASIBLE and diagnose_infeasible:
            result = _diagnosed(problem, options, result, deadline)
        return problem, _verified(problem, result, options.gap)


class _DiagnosisStopped(Exception):
    """A stop request ended the diagnosis."""


PROBE_LIMIT, DIAGNOSIS_LIMIT = 30.0, 120.0
"""Time limit of one feasibility solve of the diagnosis, and of the whole diagnosis, seconds
(both within what is left of the run's time limit)."""


def _diagnosed(problem: Problem, options: Any, result: PlanResult, deadline: float) -> PlanResult:
    """``result`` with a minimal conflict found by feasibility solves (deletion filter), each
    infeasible verdict confirmed (recorded as a diagnosis probe), all before ``deadline``."""
    from stlplan.planner.solve import plan as solve_plan

    probe = dataclasses.replace(options, time_limit=PROBE_LIMIT, two_step=False)
    confirmations = list(result.confirmations)

    def feasibility(subset: Problem) -> PlanStatus:
        found = solve_plan(subset, probe, deadline=deadline)
        confirmations.extend(
            dataclasses.replace(c, where=f"diagnosis probe, {c.where}") for c in found.confirmations
        )
        if found.status.interrupted:
            raise _DiagnosisStopped
        return found.status

    budget = max(0.0, min(DIAGNOSIS_LIMIT, deadline - time.perf_counter()))
    try:
        diagnosis = diagnose(problem, feasibility, budget)
        out = dataclasses.replace(result, diagnosis=diagnosis)
    except _DiagnosisStopped:
        out = dataclasses.replace(result, message=result.message + " (diagnosis interrupted)")
    return dataclasses.replace(out, confirmations=tuple(confirmations))


def write_plan(
    problem: Problem, result: PlanResult, out: str | Path, options: dict[str, Any] | None = None
) -> list[Path]:
    """Write ``trajectory.csv``, ``summary.json``, ``plan.png``, ``timeline.png`` (all or none).

    Without a plan, only ``summary.json`` is written.
    """
    from stlplan.outputs.plots import plot_plan, plot_timeline

    out = Path(out)
    summary = summary_dict(problem, result, options or {})
    files: dict[str, Callable[[Path], None]] = {"summary.json": lambda p: write_json(summary, p)}
    traj, report = result.trajectory, result.report
    if traj is not None and report is not None:
        title = f"{problem.mission.name}: {result.status.value}"
        files["trajectory.csv"] = lambda p: write_trajectory_csv(problem, traj, p)
        files["plan.png"] = lambda p: plot_plan(problem, traj, report, p, title=title)
        files["timeline.png"] = lambda p: plot_timeline(problem, traj, report, p)
    return write_all(out, files)


def solve(
    mission: str | Path,
    out: str | Path | None = None,
    progress: Callable[[Any], None] | None = None,
    inter_sample: bool | None = None,
    **overrides: Any,
) -> PlanResult:
    """Plan, verify and (with ``out``) write the plan directory; returns the verified result."""
    problem = load_problem(mission)  # a bad mission leaves no output folder behind
    created = out is not None and not Path(out).exists()
    if out is not None:
        prepare_directory(Path(out))
    try:
        with stops.stop_on_signals():  # a signal while writing: nothing is written
            problem, result = plan(
                problem, progress=progress, inter_sample=inter_sample, **overrides
            )
            if out is not None:
                options = {k: v for k, v in overrides.items() if v is not None}
                write_plan(problem, result, out, options)
    except KeyboardInterrupt:
        if created and out is not None:
            with contextlib.suppress(OSError):
                Path(out).rmdir()  # only when still empty
        raise
    return result


def _write_text(path: Path, text: str) -> None:
    path.write_text(text, encoding="utf-8")


def sweep(
    missions: list[str | Path],
    runs: int,
    seed: int = 0,
    out: str | Path = "out/sweep",
    workers: int | None = None,
    scheduler: str | None = None,
    resume: bool = False,
    on_record: Callable[[dict[str, Any]], None] | None = None,
    on_start: Callable[[int], None] | None = None,
    **overrides: Any,
) -> list[dict[str, Any]]:
    """Solve every mission from ``runs`` random initial states; returns the summary rows.

    Records go to ``out/runs.jsonl`` as runs finish; the table is written as ``table.csv`` and
    ``table.md`` and the time distribution as ``solve-times.png``.
    """
    import os

    from stlplan.sweep import report
    from stlplan.sweep.runner import execute, pending, read_records

    out = Path(out)
    prepare_directory(out)
    workers = workers or max(1, min(os.cpu_count() or 1, runs * len(missions)))
    if workers > 1 or scheduler:
        overrides.setdefault("threads", 1)
    specs = _sweep_specs(
        missions, runs, seed, {k: v for k, v in overrides.items() if v is not None}
    )
    todo = pending(specs, out, resume)
    if on_start is not None:
        on_start(len(todo))
    execute(todo, out, workers, scheduler, on_record)
    wanted = {(s.mission_key, s.run, s.seed) for s in specs}
    records = [r for r in read_records(out) if (r["mission"], r["run"], r["seed"]) in wanted]
    rows = report.summarize(records)
    write_all(
        out,
        {
            "table.csv": lambda p: _write_text(p, report.to_csv(rows)),
            "table.md": lambda p: _write_text(p, report.to_markdown(rows)),
            "solve-times.png": lambda p: report.plot_times(records, p),
        },
    )
    return rows


def _sweep_specs(
    missions: list[str | Path], runs: int, seed: int, overrides: dict[str, Any]
) -> list[Any]:
    """One :class:`stlplan.sweep.runner.RunSpec` per mission and run; a bad mission fails here."""
    from stlplan.errors import MissionError
    from stlplan.sweep.runner import RunSpec

    specs = []
    for path in missions:
        problem = load_problem(path)
        if problem.mission.sweep is None:
            raise MissionError("a sweep needs 'sweep: {initial_region: NAME}'", source=str(path))
        text = Path(path).read_text(encoding="utf-8")
        specs += [
            RunSpec(Path(path).stem, text, str(path), i, seed, overrides) for i in range(runs)
        ]
    return specs
