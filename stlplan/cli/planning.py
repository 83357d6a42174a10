"""Commands that plan: solve one mission, sweep missions over random initial states."""

from __future__ import annotations

import time
from collections.abc import Callable
from enum import Enum
from pathlib import Path
from typing import Annotated, Any, NoReturn

import typer

from stlplan import api
from stlplan.cli.files import InterSampleOption, MissionArg
from stlplan.cli.shell import (
    EXIT_DEGRADED,
    EXIT_INFEASIBLE,
    EXIT_INTERRUPTED,
    EXIT_NO_PLAN,
    EXIT_SOLVER,
    EXITS_COMMON,
    JsonOption,
    Output,
    QuietOption,
    VerboseOption,
    handled,
    solver_output,
)
from stlplan.mission.schema import MAGNITUDE_TEXT, MAX_MAGNITUDE, MAX_SEED, MAX_THREADS
from stlplan.result import PlanResult, PlanStatus
from stlplan.runtime import signals
from stlplan.words import counted

STATUS_EXIT = {
    PlanStatus.OPTIMAL: 0,
    PlanStatus.FEASIBLE: 0,
    PlanStatus.INFEASIBLE: EXIT_INFEASIBLE,
    PlanStatus.NO_PLAN: EXIT_NO_PLAN,
    PlanStatus.ERROR: EXIT_SOLVER,
    PlanStatus.INTERRUPTED: EXIT_INTERRUPTED,
    PlanStatus.INTERRUPTED_NO_PLAN: EXIT_INTERRUPTED,
    PlanStatus.DEGRADED: EXIT_DEGRADED,
    PlanStatus.SHIFTED: EXIT_NO_PLAN,  # no new plan by a replan's deadline
}

SOLVE_EPILOG = (
    "Exit codes: 0 a plan (optimal, or feasible at the time limit), 2 usage error, 3 bad input "
    "(or a model too large for this machine or the time limit), 4 infeasible (with a diagnosis in summary.json), 5 no plan within the time limit, 6 solver "
    "error or a plan the monitor rejects, 7 a degraded plan (--degrade: some tasks dropped, named in summary.json), 70 internal error, 130 / 143 stopped by Ctrl-C / "
    "SIGTERM (the best plan so far is written when there is one; Ctrl-C twice writes nothing)."
)
SWEEP_EPILOG = (
    "Exit codes: 0 the sweep finished (a failed run is a record, not an exit code), "
    f"{EXITS_COMMON} A sweep stopped by a signal goes on with --resume."
)


class Encoding(str, Enum):
    """Disjunction encodings."""

    log = "log"
    standard = "standard"


class TaskForm(str, Enum):
    """Task encodings."""

    selection = "selection"
    groups = "groups"


def _directory(value: str) -> str:
    """An output directory must be named: ``--out ''`` would write into the current folder."""
    if not value.strip():
        raise typer.BadParameter("expected a directory name, found an empty string")
    return value


def _gap(value: float | None) -> float | None:
    """A relative gap of 1 or more would call any plan optimal."""
    if value is not None and not 0 <= value < 1:  # NaN fails it too
        raise typer.BadParameter(f"expected a relative gap 0 <= G < 1, found {value:g}")
    return value


def _seconds(value: float | None) -> float | None:
    """A time limit: a finite number of seconds from 0.001 to 1e6."""
    if value is not None and not 0.001 <= value <= MAX_MAGNITUDE:  # NaN fails it too
        raise typer.BadParameter(
            f"expected seconds from 0.001 to {MAGNITUDE_TEXT}, found {value:g}"
        )
    return value


OutOption = Annotated[
    str, typer.Option(help="Output directory.", callback=_directory, metavar="DIR")
]


def exit_code(result: PlanResult) -> int:
    """The exit code of a planning run's result (130 / 143 when a signal stopped it)."""
    code = STATUS_EXIT[result.status]
    stopped_by = signals.last_signal()
    if result.status.interrupted and stopped_by is not None:  # 130 for Ctrl-C, 143 for TERM
        code = 128 + stopped_by
    return code


TimeLimitOption = Annotated[
    float | None,
    typer.Option(
        help="Seconds for the whole run, 0.001 to 1e6 (default: the mission's).",
        callback=_seconds,
        metavar="SECONDS",
    ),
]
GapOption = Annotated[
    float | None,
    typer.Option(
        help="Relative optimality gap, 0 <= GAP < 1 (default: the mission's).",
        metavar="GAP",
        callback=_gap,
    ),
]
ThreadsOption = Annotated[
    int | None,
    typer.Option(
        help=f"Threads, 1 to {MAX_THREADS}: HiGHS's, and independent parts solved at the same "
        "time (default: the mission's or HiGHS').",
        min=1,
        max=MAX_THREADS,
        metavar="N",
    ),
]
SeedOption = Annotated[
    int | None, typer.Option(help="HiGHS random seed.", min=0, max=MAX_SEED, metavar="N")
]
OneStepOption = Annotated[
    bool, typer.Option("--one-step", help="Skip step 2 (effort minimization with decisions fixed).")
]
EncodingOption = Annotated[
    Encoding | None,
    typer.Option(
        help="Disjunction encoding (default: the mission's, standard).", metavar="log|standard"
    ),
]
TasksOption = Annotated[
    TaskForm | None,
    typer.Option(
        help="Task encoding: select elements, or enumerate groups as the paper does "
        "(default: the mission's, selection).",
        metavar="selection|groups",
    ),
]

DegradeOption = Annotated[
    bool,
    typer.Option(
        "--degrade",
        help="When the mission cannot be met whole, plan as many tasks as possible (by task "
        "priority, else by count) and name each task dropped (exit 7).",
    ),
]
FirstPlanOption = Annotated[
    bool,
    typer.Option(
        "--first-plan",
        help="Stop at the first plan that meets every requirement (its gap is printed beside it).",
    ),
]
DeterministicOption = Annotated[
    bool,
    typer.Option(
        "--deterministic",
        help="Take every decision on the solver's work, not the clock (one thread): two runs "
        "decide alike whatever the machine's load, to compare versions of the code.",
    ),
]
RobustToOption = Annotated[
    str | None,
    typer.Option(
        "--robust-to",
        help="Plan margins one step of an additive disturbance bounded by W per state "
        "component cannot break (default: the mission's execution.disturbance).",
        metavar="W",
        show_default=False,
    ),
]


def robust_bound(text: str | None) -> float | None:
    """``--robust-to`` as a number (checked as ``simulate`` checks it: exit 3 when it is not a
    finite number >= 0)."""
    from stlplan.simulation.settings import bound

    return None if text is None else bound(text, "--robust-to")


NoAnimationOption = Annotated[
    bool,
    typer.Option(
        "--no-animation",
        help="Write no animation (plan.gif, plan.mp4).",
    ),
]
NoHtmlOption = Annotated[
    bool,
    typer.Option(
        "--no-html",
        help="Write no interactive viewer (plan.html).",
    ),
]


@handled
def solve(
    mission: MissionArg,
    out: OutOption = "out",
    time_limit: TimeLimitOption = None,
    gap: GapOption = None,
    threads: ThreadsOption = None,
    seed: SeedOption = None,
    one_step: OneStepOption = False,
    encoding: EncodingOption = None,
    tasks: TasksOption = None,
    inter_sample: InterSampleOption = None,
    degrade: DegradeOption = False,
    first_plan: FirstPlanOption = False,
    deterministic: DeterministicOption = False,
    robust_to: RobustToOption = None,
    no_animation: NoAnimationOption = False,
    no_html: NoHtmlOption = False,
    as_json: JsonOption = False,
    quiet: QuietOption = False,
    verbose: VerboseOption = False,
) -> None:
    """Plan a mission: solve the MILP, verify with the monitor, write CSV, JSON, plots, the
    animation and the interactive viewer (plan.html).

    With --json the document printed is summary.json.
    """
    from stlplan.outputs.progress import ProgressLine

    output, tick = Output(as_json, quiet), time.perf_counter()
    overrides = api.Overrides(
        time_limit=time_limit,
        gap=gap,
        threads=threads,
        seed=seed,
        encoding=None if encoding is None else encoding.value,
        tasks=None if tasks is None else tasks.value,
        two_step=False if one_step else None,
        degrade=True if degrade else None,
        first_plan=True if first_plan else None,
        deterministic=True if deterministic else None,
        robust_to=robust_bound(robust_to),
        inter_sample=inter_sample,
    )
    problem = api.validate(mission)
    with (
        solver_output(discard=not output.full),
        ProgressLine(output.err, enabled=output.full) as line,
    ):
        result = api.solve(
            problem,
            out=out,
            overrides=overrides,
            progress=line.update,
            animation=not no_animation,
            viewer=not no_html,
        )
    seconds = time.perf_counter() - tick
    finish(output, result, out, verbose, lambda: api.summary(problem, result, overrides), seconds)


def finish(
    output: Output,
    result: PlanResult,
    out: str,
    verbose: bool,
    summary: Callable[[], Any],
    seconds: float | None = None,
) -> NoReturn:
    """Print a planning run's result (its ``summary`` document with ``--json``, one line with
    ``--quiet``), the run having taken ``seconds`` in all, and exit with its code."""
    from stlplan.outputs.render import print_plan

    code = exit_code(result)
    if output.as_json:
        output.document(summary())
    elif output.full:  # the status line and the monitor's verdict are in the plan's report
        print_plan(output.out, result, verbose, seconds)
        output.line(f"outputs in {out}")
    else:  # --quiet: one line on stdout, whatever the outcome (the exit code tells it apart)
        verdict = "satisfied" if code == 0 else result.status.value
        output.line(f"{verdict}: {result.message}; outputs in {out}")
    raise typer.Exit(code)


MissionsArg = Annotated[
    list[Path], typer.Argument(help="Mission files (YAML).", metavar="MISSION", show_default=False)
]
RunsOption = Annotated[
    int, typer.Option(help="Random initial states per mission.", min=1, metavar="N")
]
SweepSeedOption = Annotated[
    int, typer.Option(help="Seed: run i of seed S always gets the same state.", min=0, metavar="S")
]
WorkersOption = Annotated[
    int | None,
    typer.Option(help="Local worker processes (default: one per core).", min=1, metavar="W"),
]
SchedulerOption = Annotated[
    str | None,
    typer.Option(help="Dask scheduler address, e.g. tcp://host:8786.", metavar="ADDRESS"),
]
SolveTimeOption = Annotated[
    float | None,
    typer.Option(
        help="Seconds per solve, 0.001 to 1e6 (default: the mission's).",
        callback=_seconds,
        metavar="SECONDS",
    ),
]
ResumeOption = Annotated[
    bool, typer.Option("--resume", help="Skip runs already in OUT/runs.jsonl.")
]


def where_runs(workers: int | None, scheduler: str | None) -> str:
    """Where a batch of runs goes: ``on the Dask cluster at ...``, ``in 2 local processes``."""
    if scheduler:
        return f"on the Dask cluster at {scheduler}"
    if workers:
        return f"in {counted(workers, 'local process', 'local processes')}"
    return "in one local process per core"


@handled
def sweep(
    missions: MissionsArg,
    runs: RunsOption = 30,
    seed: SweepSeedOption = 0,
    workers: WorkersOption = None,
    scheduler: SchedulerOption = None,
    out: OutOption = "out/sweep",
    time_limit: SolveTimeOption = None,
    threads: ThreadsOption = None,
    resume: ResumeOption = False,
    as_json: JsonOption = False,
    quiet: QuietOption = False,
) -> None:
    """Solve missions from random initial states; print and write the paper's Table 3.

    Each run's HiGHS takes --threads (default: one when runs share the machine or go to a
    cluster). With --json the document printed is the table: one object per mission.
    """
    from stlplan.sweep.progress import SweepProgress, print_table

    output = Output(as_json, quiet)
    where = where_runs(workers, scheduler)

    def started(total: int) -> None:  # every check passed: the runs begin
        if output.full:
            output.err.print(f"sweep runs {where}")
        bar.start(total)

    with (
        solver_output(discard=not output.full),
        SweepProgress(output.err, enabled=output.full) as bar,
    ):
        rows = api.sweep(
            list(missions),
            runs,
            seed,
            out,
            workers,
            scheduler,
            resume,
            on_record=bar.advance,
            on_start=started,
            overrides=api.Overrides(time_limit=time_limit, threads=threads),
        )
    folder = Path(out)
    if as_json:
        output.document(rows)
        return
    if output.full:
        print_table(output.out, rows)
    total = sum(int(row["runs"]) for row in rows)
    output.line(
        f"sweep of {counted(total, 'run')} over {counted(len(rows), 'mission')} {where}: records in "
        f"{folder / 'runs.jsonl'}; table in {folder / 'table.md'}"
    )
