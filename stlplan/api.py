"""The Python API under the command line: load, plan, check, write, simulate.

Every function returns typed results and raises :class:`stlplan.errors.StlplanError` subclasses on
bad input; nothing here prints.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

from stlplan.analysis.size import check_size
from stlplan.deadline import WRITING_SECONDS, Deadline, replan_by
from stlplan.errors import StlplanError, UsageError
from stlplan.mission.loader import check_enumerable, load_problem
from stlplan.mission.problem import Problem
from stlplan.monitor.verdicts import check as monitor_check
from stlplan.outputs.directory import prepare_directory, write_all, write_json, write_text
from stlplan.outputs.summary import summary_dict
from stlplan.outputs.trajio import write_trajectory_csv
from stlplan.outputs.trajread import read_trajectory_csv
from stlplan.pipeline import plan
from stlplan.planner.config import PlannerConfig
from stlplan.planner.overrides import Overrides
from stlplan.result import MonitorReport, PlanResult, PlanStatus
from stlplan.runtime import signals
from stlplan.simulation.batch import Simulation, robustness, simulate
from stlplan.simulation.settings import Simulated

DEFAULT_TOLERANCE = 1e-6
"""The monitor's tolerance when none is given: solver round-off."""

__all__ = [
    "Overrides",
    "Simulated",
    "Simulation",
    "check",
    "export_rtamt",
    "plan",
    "plot_trajectory",
    "replan",
    "robustness",
    "simulate",
    "solve",
    "summary",
    "sweep",
    "validate",
    "write_plan",
]


def validate(mission: str | Path) -> Problem:
    """Load and check a mission file, and that its model fits this machine and the mission's
    time limit (:func:`stlplan.analysis.size.check_size`); raise on the first mistake."""
    problem = load_problem(mission)
    check_size(problem)
    return problem


def export_rtamt(mission: str | Path, out: str | Path | None = None) -> tuple[list[Any], str]:
    """Each single-agent task and constraint of a mission as an RTAMT specification
    (:class:`stlplan.outputs.rtamt.RtamtSpec`), and the document ``stlplan export-rtamt`` writes
    (to ``out`` when given)."""
    from stlplan.outputs.rtamt import rtamt_document, rtamt_specs

    problem = load_problem(mission)
    specs = rtamt_specs(problem)
    text = rtamt_document(problem, str(mission), specs)
    if out is not None:
        Path(out).write_text(text, encoding="utf-8")
    return specs, text


def check(
    mission: str | Path | Problem,
    trajectory: str | Path,
    inter_sample: bool | None = None,
    tolerance: float = DEFAULT_TOLERANCE,
) -> tuple[Problem, MonitorReport]:
    """The monitor's verdicts on a trajectory CSV for a mission.

    ``inter_sample``: judge safety between steps too (None keeps the mission's
    ``safety.inter_sample``). ``tolerance``: how far each number of the trajectory may be off,
    ``tolerance * max(1, |v|)``, in the dynamics and bounds; a tolerance above the default also
    lets requirements hold at robustness ``>= EPSILON / 2 - tolerance``
    (:mod:`stlplan.formula.boundary`), for trajectories rounded by other tools.
    """
    if not (tolerance >= 0 and math.isfinite(tolerance)):
        raise UsageError(f"tolerance: expected a finite number >= 0, found {tolerance!r}")
    problem = mission if isinstance(mission, Problem) else load_problem(mission)
    problem = problem.with_inter_sample(inter_sample)
    traj = read_trajectory_csv(problem, Path(trajectory))
    slack = tolerance if tolerance > DEFAULT_TOLERANCE else 0.0
    return problem, monitor_check(problem, traj, tol=tolerance, slack=slack)


def plot_trajectory(
    problem: Problem, trajectory: str | Path, report: MonitorReport, out: str | Path
) -> None:
    """Draw the map of a trajectory CSV (``plan.png`` style) with the monitor's ``report``."""
    from stlplan.outputs.plots import plot_plan

    traj = read_trajectory_csv(problem, Path(trajectory))
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    plot_plan(problem, traj, report, out, title=f"{problem.mission.name}: {Path(trajectory).name}")


def summary(
    problem: Problem, result: PlanResult, overrides: Overrides | None = None
) -> dict[str, Any]:
    """What ``summary.json`` holds for ``result``, a plan of ``problem`` under ``overrides``."""
    overrides = overrides or Overrides()
    planned = problem.with_inter_sample(overrides.inter_sample)
    return summary_dict(planned, result, overrides.given())


def write_plan(
    problem: Problem,
    result: PlanResult,
    out: str | Path,
    options: dict[str, Any] | None = None,
    animation: bool = True,
    viewer: bool = True,
    figures: bool = True,
) -> list[Path]:
    """Write ``trajectory.csv``, ``summary.json``, ``plan.png``, ``timeline.png``,
    ``convergence.png``, with ``animation`` ``plan.gif`` (and ``plan.mp4`` where ``ffmpeg`` is
    installed), and with ``viewer`` ``plan.html`` (:mod:`stlplan.outputs.viewer`), all or none.
    Without ``figures``, only ``trajectory.csv`` and ``summary.json`` (a replan on a deadline).

    ``convergence.png`` needs a point in :attr:`stlplan.result.PlanResult.convergence`.
    Without a plan, only ``summary.json`` is written (and ``convergence.png`` but for an
    infeasible mission).
    """
    out = Path(out)
    summary = summary_dict(problem, result, options or {})
    files: dict[str, Callable[[Path], None]] = {"summary.json": lambda p: write_json(summary, p)}
    traj, report = result.trajectory, result.report
    if traj is not None and report is not None:
        files["trajectory.csv"] = lambda p: write_trajectory_csv(problem, traj, p)
    if not figures:
        return write_all(out, files, owned=PLAN_FILES)
    from stlplan.outputs.plots import PlanAnimation, ffmpeg, plot_plan, plot_timeline
    from stlplan.outputs.plots.convergence import plot_convergence

    if result.convergence and result.status is not PlanStatus.INFEASIBLE:
        files["convergence.png"] = lambda p: plot_convergence(problem, result, p)
    if traj is not None and report is not None:
        title = f"{problem.mission.name}: {result.status.value}"
        files["plan.png"] = lambda p: plot_plan(problem, traj, report, p, title=title)
        files["timeline.png"] = lambda p: plot_timeline(problem, traj, report, p)
        if animation:
            movie = PlanAnimation(problem, traj, report, title)  # frames shared by both files
            files["plan.gif"] = movie.write_gif
            if ffmpeg() is not None:
                files["plan.mp4"] = movie.write_mp4
        if viewer:
            from stlplan.outputs.viewer import write_viewer

            files["plan.html"] = lambda p: write_viewer(problem, traj, report, p, title=title)
    return write_all(out, files, owned=PLAN_FILES)


PLAN_FILES = (
    "summary.json",
    "trajectory.csv",
    "plan.png",
    "timeline.png",
    "convergence.png",
    "plan.gif",
    "plan.mp4",
    "plan.html",
)
"""Everything a solve writes into its output folder (a rerun removes what it does not write)."""


def solve(
    mission: str | Path | Problem,
    out: str | Path | None = None,
    overrides: Overrides | None = None,
    progress: Callable[[Any], None] | None = None,
    animation: bool = True,
    viewer: bool = True,
) -> PlanResult:
    """Plan, verify and (with ``out``) write the plan directory; returns the verified result.

    ``animation``: write ``plan.gif`` (and ``plan.mp4``) too; ``viewer``: write ``plan.html``
    too (:func:`write_plan`). ``progress`` is called with each
    :class:`~stlplan.planner.run.clock.Progress`, one call at a time, from the thread that solves
    (with two threads or more, parts are solved in threads of their own).
    """
    # a bad mission leaves no output folder behind
    problem = mission if isinstance(mission, Problem) else load_problem(mission)
    config = PlannerConfig.from_mission(problem.mission, (overrides or Overrides()).dotted())
    if config.model.tasks == "groups":
        check_enumerable(problem)
    check_size(problem, config)
    with _plan_folder(out, overrides, animation, viewer) as write:
        planned, result = plan(problem, overrides, progress=progress)
        write(planned, result)
    return result


@contextlib.contextmanager
def _plan_folder(
    out: str | Path | None,
    overrides: Overrides | None,
    animation: bool,
    viewer: bool,
    figures: bool = True,
) -> Iterator[Callable[[Problem, PlanResult], None]]:
    """The block plans and writes its plan directory (with ``out``) by the function it is
    given, all or nothing: the folder is prepared first, a signal while writing writes nothing,
    and a folder made for the run is removed again on Ctrl-C."""
    created = out is not None and not Path(out).exists()
    if out is not None:
        prepare_directory(Path(out))

    def write(problem: Problem, result: PlanResult) -> None:
        if out is not None:
            given = (overrides or Overrides()).given()
            write_plan(problem, result, out, given, animation, viewer, figures)

    try:
        with signals.stop_on_signals():
            yield write
    except KeyboardInterrupt:
        if created and out is not None:
            with contextlib.suppress(OSError):
                Path(out).rmdir()  # only when still empty
        raise


def replan(
    mission: str | Path | Problem,
    executed: str | Path,
    at: int,
    lost: Sequence[str] = (),
    closed: Sequence[str] = (),
    out: str | Path | None = None,
    overrides: Overrides | None = None,
    progress: Callable[[Any], None] | None = None,
    animation: bool = True,
    viewer: bool = True,
    deadline: Deadline | None = None,
) -> tuple[Problem, PlanResult]:
    """Plan again from step ``at`` of the ``executed`` trajectory file (DESIGN 2.13-14), with
    agents ``lost`` and regions ``closed`` at that step; verify the whole trajectory and (with
    ``out``) write the plan directory of steps ``0..H``.

    The file's states of steps ``0..at`` are the executed past (inputs optional, later rows not
    data); its later rows, when complete, are where the solver starts. Returns the replanned
    problem (its past, its events as constraints: what the monitor judged) and the result.

    With a ``deadline`` (:mod:`stlplan.deadline`) the answer, written, comes by it: a new plan,
    a degraded plan, or the file's later rows continued from the states of ``at`` (when they
    are complete); only ``trajectory.csv`` and ``summary.json`` are written.

    Raises
    ------
    EventError, TrajectoryError
        A step outside ``0..H-1``, unknown or repeated events, an executed file that does not fit
        the mission or leaves its state bounds (nothing is written).
    DeadlineError
        A ``deadline`` already spent by loading (nothing is written).
    """
    from stlplan.mission.past import check_step, replanned
    from stlplan.replanning import replan as replan_problem
    from stlplan.replanning import trajectory_start

    problem = mission if isinstance(mission, Problem) else load_problem(mission)
    check_step(problem, at)
    past = read_trajectory_csv(problem, executed, through=at)
    again = replanned(problem, past, at, lost, closed)  # every bad input before writing
    config = PlannerConfig.from_mission(problem.mission, (overrides or Overrides()).dotted())
    check_size(again, config)
    start, current = None, None
    with contextlib.suppress(StlplanError):  # later rows incomplete: no start from them
        current = read_trajectory_csv(problem, executed)
        start = trajectory_start(again, current, at)
    if deadline is not None:
        deadline.check_loaded("starting and loading the mission and the executed trajectory")
        animation = viewer = False
    figures = deadline is None
    with _plan_folder(out, overrides, animation, viewer, figures) as write:
        if deadline is None:
            planned, result = replan_problem(
                problem, past, at, lost, closed, overrides, progress, start
            )
        else:
            planned, result = replan_by(
                deadline, problem, past, at, lost, closed, overrides, progress, start,
                current if current is not None and current.known == "inputs" else None,
                reserve=WRITING_SECONDS if out is not None else 0.0,
            )  # fmt: skip
        write(planned, result)
    return planned, result


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
    overrides: Overrides | None = None,
) -> list[dict[str, Any]]:
    """Solve every mission from ``runs`` random initial states; returns the summary rows.

    Records go to ``out/runs.jsonl`` as runs finish; the table is written as ``table.csv`` and
    ``table.md`` and the time distribution as ``solve-times.png``.
    """
    from stlplan.sweep import report
    from stlplan.sweep.identity import claim
    from stlplan.sweep.runner import (
        check_scheduler,
        execute,
        pending,
        read_records,
        workers_and_settings,
    )

    workers, overrides = workers_and_settings(
        workers, scheduler, runs * len(missions), overrides or Overrides()
    )
    out = Path(out)
    specs = _sweep_specs(missions, runs, seed, overrides)  # every mission checked first
    todo = pending(specs, out, resume)
    check_scheduler(scheduler)
    prepare_directory(out)
    claim(out, specs, resume)
    if on_start is not None:
        on_start(len(todo))
    execute(todo, out, workers, scheduler, on_record)
    wanted = {(s.mission_key, s.run, s.seed) for s in specs}
    records = [r for r in read_records(out) if (r["mission"], r["run"], r["seed"]) in wanted]
    rows = report.summarize(records)
    write_all(
        out,
        {
            "table.csv": lambda p: write_text(p, report.to_csv(rows)),
            "table.md": lambda p: write_text(p, report.to_markdown(rows)),
            "solve-times.png": lambda p: report.plot_times(records, p),
        },
    )
    return rows


def _sweep_specs(
    missions: list[str | Path], runs: int, seed: int, overrides: Overrides
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
