"""The command that plans again from a step of an executed trajectory."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Annotated

import typer

from stlplan import api
from stlplan.cli.files import MissionArg
from stlplan.cli.planning import (
    SOLVE_EPILOG,
    FirstPlanOption,
    GapOption,
    NoAnimationOption,
    NoHtmlOption,
    OutOption,
    RobustToOption,
    ThreadsOption,
    TimeLimitOption,
    finish,
    robust_bound,
)
from stlplan.cli.shell import JsonOption, Output, QuietOption, VerboseOption, handled, solver_output

REPLAN_EPILOG = (
    SOLVE_EPILOG.replace("(--degrade: some", "(some")
    .replace(
        "3 bad input", "3 bad input (a step outside 0..H-1, an unknown or repeated event, an "
        "executed file that does not fit the mission, a --deadline not above 0 or shorter than "
        "loading took)",
    )
    .replace(
        "5 no plan within the time limit",
        "5 no plan within the time limit (with --deadline: the current plan continued, status "
        "shifted)",
    )
)  # fmt: skip

ExecutedArg = Annotated[
    Path,
    typer.Argument(
        help="The executed trajectory (CSV, any form `stlplan check` reads): its states of "
        "steps 0..K are kept; later rows are not data.",
        metavar="EXECUTED.csv",
        show_default=False,
    ),
]
AtOption = Annotated[
    int, typer.Option("--at", help="K: the step the team is at (0..H-1).", metavar="K")
]
LostOption = Annotated[
    list[str] | None,
    typer.Option(
        "--lost", help="An agent lost at K: it stays where it was last seen.", metavar="AGENT"
    ),
]
ClosedOption = Annotated[
    list[str] | None,
    typer.Option(
        "--closed", help="A region closed at K: an obstacle for every agent.", metavar="REGION"
    ),
]
DeadlineOption = Annotated[
    str | None,
    typer.Option(
        help="Answer within this many seconds of wall time, loading and writing included: a new "
        "plan, else a degraded plan, else the current plan (the executed file's later rows) "
        "continued from the states of step K. Only trajectory.csv and summary.json are written.",
        metavar="SECONDS",
        show_default=False,
    ),
]


@handled
def replan(
    mission: MissionArg,
    executed: ExecutedArg,
    at: AtOption,
    lost: LostOption = None,
    closed: ClosedOption = None,
    out: OutOption = "out/replan",
    time_limit: TimeLimitOption = None,
    gap: GapOption = None,
    threads: ThreadsOption = None,
    first_plan: FirstPlanOption = False,
    robust_to: RobustToOption = None,
    deadline: DeadlineOption = None,
    no_animation: NoAnimationOption = False,
    no_html: NoHtmlOption = False,
    as_json: JsonOption = False,
    quiet: QuietOption = False,
    verbose: VerboseOption = False,
) -> None:
    """Plan again from step K of an executed trajectory: the past is kept as data, lost
    agents stay where they were, closed regions are avoided; verify the whole trajectory and
    write the plan of steps 0..H.

    With --json the document printed is summary.json.
    """
    from stlplan.deadline import Deadline, deadline_seconds
    from stlplan.outputs.progress import ProgressLine
    from stlplan.runtime.started import end_at_once, process_start

    output, tick = Output(as_json, quiet), time.perf_counter()
    by = None
    if deadline is not None:  # from the process's start: the wall time its caller sees
        by = Deadline.starting(deadline_seconds(deadline), process_start())
        end_at_once()
    overrides = api.Overrides(
        time_limit=time_limit,
        gap=gap,
        threads=threads,
        first_plan=True if first_plan else None,
        robust_to=robust_bound(robust_to),
    )
    problem = api.validate(mission)
    with (
        solver_output(discard=not output.full),
        ProgressLine(output.err, enabled=output.full) as line,
    ):
        again, result = api.replan(
            problem, executed, at, lost or (), closed or (), out, overrides, line.update,
            animation=not no_animation, viewer=not no_html, deadline=by,
        )  # fmt: skip
    seconds = time.perf_counter() - tick
    finish(output, result, out, verbose, lambda: api.summary(again, result, overrides), seconds)
