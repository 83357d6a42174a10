"""The command that executes a plan many times under a disturbance, with events, in a loop that
replans; and draws the fraction of runs satisfied against the disturbance."""

from __future__ import annotations

from enum import Enum
from pathlib import Path
from typing import Annotated

import typer

from stlplan import api
from stlplan.cli.files import MissionArg
from stlplan.cli.planning import (
    OutOption,
    ResumeOption,
    SchedulerOption,
    SolveTimeOption,
    ThreadsOption,
    WorkersOption,
    exit_code,
    where_runs,
)
from stlplan.cli.shell import EXITS_COMMON, JsonOption, Output, QuietOption, handled, solver_output
from stlplan.sweep.progress import SweepProgress
from stlplan.words import counted

SIMULATE_EPILOG = (
    "Exit codes: 0 the simulation finished (a run that fails the mission is a record, not an exit "
    "code) or --plot drew its figure, 4 / 5 / 6 the mission has no plan to execute (infeasible, "
    "none within the time limit, solver error), "
    + EXITS_COMMON.replace(
        "file)",
        "file; a disturbance that is not a number >= 0, --runs below 1, --lose or --close naming "
        "an unknown agent or region or a step outside 0..H-1, an agent lost or a region closed "
        "twice, a --deadline not above 0)",
    )
    + " A simulation stopped by a signal goes on with --resume."
)


class Replanning(str, Enum):
    """When the loop replans."""

    every = "every"
    on_deviation = "on-deviation"
    never = "never"


DeadlineOption = Annotated[
    str | None,
    typer.Option(
        help="Each replan answers within this many seconds of wall time: a new plan, else a "
        "degraded plan, else the current plan shifted on from its step.",
        metavar="SECONDS",
        show_default=False,
    ),
]
RunsOption = Annotated[int, typer.Option(help="Runs, at least 1.", metavar="N")]
SeedOption = Annotated[
    int,
    typer.Option(
        help="Seed: run r of seed S always gets the same disturbance.", min=0, metavar="S"
    ),
]
DisturbanceOption = Annotated[
    str | None,
    typer.Option(
        help="W: each state component gets one draw per step, uniform in [-W, W] (default: "
        "the mission's execution.disturbance, else 0).",
        metavar="W",
        show_default=False,
    ),
]
RobustOption = Annotated[
    str | None,
    typer.Option(
        help="Plan and replan with margins against this disturbance (default: the mission's "
        "execution.disturbance, whatever --disturbance is).",
        metavar="W2",
        show_default=False,
    ),
]
LoseOption = Annotated[
    list[str] | None,
    typer.Option(
        "--lose", help="An agent lost at step K: it stays where it is.", metavar="AGENT@K"
    ),
]
CloseOption = Annotated[
    list[str] | None,
    typer.Option(
        "--close", help="A region closed at step K: an obstacle from K on.", metavar="REGION@K"
    ),
]
ReplanOption = Annotated[
    Replanning,
    typer.Option(
        help="Replan at every step, when the states leave the plan or an event comes, or never "
        "(open loop).",
        metavar="every|on-deviation|never",
    ),
]
PlotOption = Annotated[
    bool,
    typer.Option(
        "--plot",
        help="Simulate nothing: draw OUT/robustness.png, the fraction of runs satisfied against "
        "W for each policy, from every simulation of MISSION recorded in OUT or below it.",
    ),
]


@handled
def simulate(
    mission: MissionArg,
    runs: RunsOption = 20,
    seed: SeedOption = 0,
    disturbance: DisturbanceOption = None,
    robust_to: RobustOption = None,
    lose: LoseOption = None,
    close: CloseOption = None,
    replan: ReplanOption = Replanning.on_deviation,
    workers: WorkersOption = None,
    scheduler: SchedulerOption = None,
    out: OutOption = "out/simulate",
    resume: ResumeOption = False,
    threads: ThreadsOption = None,
    time_limit: SolveTimeOption = None,
    deadline: DeadlineOption = None,
    plot: PlotOption = False,
    as_json: JsonOption = False,
    quiet: QuietOption = False,
) -> None:
    """Execute the mission's plan N times on its own dynamics under a bounded disturbance, with
    agents lost and regions closed, replanning by the policy; judge each executed trajectory
    with the monitor and write OUT/runs.jsonl, OUT/table.md and run 0's map (OUT/run-0.png).

    With --json the document printed holds runs (one object per run) and satisfied_fraction.
    """
    from stlplan.deadline import deadline_seconds
    from stlplan.simulation.settings import bound, check_runs, events

    output = Output(as_json, quiet)
    if plot:
        _plot(output, mission, out)
        return
    problem = api.validate(mission)
    default = float(problem.mission.execution.disturbance)
    simulated = api.Simulated(
        default if disturbance is None else bound(disturbance, "--disturbance"),
        replan.value,
        events(lose or (), close or ()),
        None if deadline is None else deadline_seconds(deadline),
    )
    overrides = api.Overrides(
        time_limit=time_limit,
        threads=threads,
        robust_to=None if robust_to is None else bound(robust_to, "--robust-to"),
    )
    simulated.check(problem)  # bad input before any line is printed
    check_runs(runs)
    where = where_runs(workers, scheduler)

    def started(total: int) -> None:  # every check passed: the runs begin
        if output.full:
            output.err.print(f"simulation runs {where}")
        bar.start(total)

    with (
        solver_output(discard=not output.full),
        SweepProgress(output.err, enabled=output.full, label="simulate") as bar,
    ):
        done = api.simulate(
            mission, simulated, runs, seed, out, workers, scheduler, resume, overrides,
            on_record=bar.advance, on_start=started,
        )  # fmt: skip
    _finish(output, done, where)


def _finish(output: Output, done: api.Simulation, where: str) -> None:
    """Print the simulation (a table of runs and one line; one line with --quiet; the document
    with --json); exit with the first plan's code when there was nothing to execute."""
    from stlplan.simulation import report
    from stlplan.sweep.progress import print_table

    first = done.first
    unplanned = None
    if first is not None and first.trajectory is None:
        unplanned = f"no plan to execute: {first.status.value}: {first.message}"
    if output.as_json:
        output.document(done.document() | ({"message": unplanned} if unplanned else {}))
    elif unplanned:
        output.line(unplanned, error=True)
    if first is not None and unplanned:
        raise typer.Exit(exit_code(first))
    if output.as_json:
        return
    if output.full:
        rows = [report.row(r) for r in done.records]
        print_table(output.out, rows, report.COLUMNS, "Simulation runs (replan times in s)")
    output.line(
        f"simulation {where}: {report.line(done.summary())}; records in "
        f"{done.out / 'runs.jsonl'}; table in {done.out / 'table.md'}"
    )


def _plot(output: Output, mission: Path, out: str) -> None:
    """``--plot``: draw ``OUT/robustness.png`` from the simulations recorded below ``out``."""
    found = api.robustness(mission, out)
    if output.as_json:
        output.document({"points": found, "figure": str(Path(out) / "robustness.png")})
        return
    curves = len({p["configuration"] for p in found})
    runs = sum(p["runs"] for p in found)
    output.line(
        f"robustness figure of {counted(runs, 'run')} in "
        f"{counted(curves, 'configuration')}: {Path(out) / 'robustness.png'}"
    )
