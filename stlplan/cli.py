"""The ``stlplan`` command line: a thin shell over :mod:`stlplan.api`.

Exit codes: 0 satisfied / valid; 1 a checked trajectory violates the mission; 2 usage error
(including a file the operating system refuses to read or write);
3 bad input (mission, formula, trajectory); 4 infeasible; 5 no plan within the time limit;
6 solver error or a plan the monitor rejects; 70 internal error; 128 + the signal's number when
a signal stopped the run (130 for Ctrl-C, 143 for SIGTERM), with the best plan so far written
when there was one.
"""

from __future__ import annotations

import functools
import os
import sys
from collections.abc import Callable
from enum import Enum
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console
from rich.markup import escape

from stlplan import api
from stlplan.errors import StlplanError, UsageError
from stlplan.planner import stops
from stlplan.result import PlanStatus

app = typer.Typer(
    help="Plan coordinated trajectories for a heterogeneous team from global STL tasks.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
out_console = Console()
err_console = Console(stderr=True)

EXIT_VIOLATED, EXIT_INFEASIBLE, EXIT_NO_PLAN, EXIT_SOLVER = 1, 4, 5, 6
EXIT_INTERNAL, EXIT_INTERRUPTED = 70, 130
STATUS_EXIT = {
    PlanStatus.OPTIMAL: 0,
    PlanStatus.FEASIBLE: 0,
    PlanStatus.INFEASIBLE: EXIT_INFEASIBLE,
    PlanStatus.NO_PLAN: EXIT_NO_PLAN,
    PlanStatus.ERROR: EXIT_SOLVER,
    PlanStatus.INTERRUPTED: EXIT_INTERRUPTED,
    PlanStatus.INTERRUPTED_NO_PLAN: EXIT_INTERRUPTED,
}
SCHEMA_PATH = Path("schemas") / "mission.schema.json"


def handled(command: Callable[..., None]) -> Callable[..., None]:
    """Turn stlplan errors into one message on stderr and their exit code; never a traceback."""

    @functools.wraps(command)
    def run(*args: Any, **kwargs: Any) -> None:
        try:
            command(*args, **kwargs)
        except StlplanError as exc:
            err_console.print(f"[red]error[/]: {escape(str(exc))}", highlight=False, soft_wrap=True)
            raise typer.Exit(exc.exit_code) from None
        except typer.Exit:
            raise
        except KeyboardInterrupt as exc:  # a signal outside a solve, or a second one
            err_console.print("interrupted", highlight=False)
            code = exc.exit_code if isinstance(exc, stops.Interrupted) else EXIT_INTERRUPTED
            raise typer.Exit(code) from None
        except OSError as exc:  # a file the operating system refused (disk full, permissions)
            where = f"{exc.filename}: " if exc.filename else ""
            err_console.print(
                f"[red]error[/]: {escape(where + (exc.strerror or str(exc)))}",
                highlight=False,
                soft_wrap=True,
            )
            raise typer.Exit(UsageError.exit_code) from None
        except Exception as exc:  # noqa: BLE001 - the edge of the program
            if os.environ.get("STLPLAN_DEBUG"):
                raise
            err_console.print(
                f"[red]internal error[/]: {type(exc).__name__}: {escape(str(exc))} "
                "(set STLPLAN_DEBUG=1 for a traceback)",
                highlight=False,
                soft_wrap=True,
            )
            raise typer.Exit(EXIT_INTERNAL) from None

    return run


MissionArg = Annotated[Path, typer.Argument(help="Mission file (YAML).", show_default=False)]


class Encoding(str, Enum):
    """Disjunction encodings."""

    log = "log"
    standard = "standard"


@app.command()
@handled
def validate(mission: MissionArg) -> None:
    """Check a mission file: schema, names, shapes, horizons and Patterns."""
    problem = api.validate(mission)
    groups = ", ".join(f"{t.name}: {len(t.groups)}" for t in problem.tasks)
    out_console.print(
        f"[green]valid[/]: {mission} ({len(problem.agents)} agents, "
        f"{len(problem.tasks)} tasks, {len(problem.constraints)} constraints; "
        f"groups {groups or 'none'})"
    )


InterSampleOption = Annotated[
    bool | None,
    typer.Option(
        "--inter-sample/--no-inter-sample",
        help="Judge avoidance and separation on the straight segments between steps too "
        "(default: the mission's safety.inter_sample, true); --no-inter-sample judges the "
        "steps only, as the paper does.",
        show_default=False,
    ),
]


@app.command()
@handled
def check(
    mission: MissionArg,
    trajectory: Annotated[Path, typer.Argument(help="Trajectory CSV (agent, k, x0.., u0..).")],
    inter_sample: InterSampleOption = None,
    plot: Annotated[
        Path | None,
        typer.Option(help="Also draw the map of the trajectory to this PNG (crossings in red)."),
    ] = None,
) -> None:
    """Judge a team trajectory with the independent monitor; exit 1 when anything fails."""
    problem, report = api.check(mission, trajectory, inter_sample=inter_sample)
    from stlplan.outputs.render import print_report

    print_report(out_console, report)
    if plot is not None:
        api.plot_trajectory(problem, trajectory, report, plot)
        out_console.print(f"map in {plot}")
    if not report.satisfied:
        raise typer.Exit(EXIT_VIOLATED)


@app.command()
@handled
def schema(
    out: Annotated[Path, typer.Option(help="Where to write the JSON Schema.")] = SCHEMA_PATH,
) -> None:
    """Write the mission file JSON Schema (for editors and validation)."""
    from stlplan.mission.schema import json_schema

    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json_schema(), encoding="utf-8")
    out_console.print(f"wrote {out}")


def _directory(value: str) -> str:
    """An output directory must be named: ``--out ''`` would write into the current folder."""
    if not value.strip():
        raise typer.BadParameter("expected a directory name, found an empty string")
    return value


SOLVE_EPILOG = (
    "Exit codes: 0 a plan (optimal, or feasible at the time limit), 3 bad input, 4 infeasible "
    "(with a diagnosis in summary.json), 5 no plan within the time limit, 6 solver error or a "
    "plan the monitor rejects, 130 / 143 stopped by Ctrl-C / SIGTERM (the best plan so far is "
    "written when there is one; Ctrl-C twice writes nothing)."
)


@app.command(epilog=SOLVE_EPILOG)
@handled
def solve(
    mission: MissionArg,
    out: Annotated[str, typer.Option(help="Output directory.", callback=_directory)] = "out",
    time_limit: Annotated[
        float | None,
        typer.Option(help="Seconds for the whole run (default: mission's).", min=0.001),
    ] = None,
    gap: Annotated[
        float | None, typer.Option(help="Relative optimality gap (default: mission's).", min=0.0)
    ] = None,
    threads: Annotated[
        int | None, typer.Option(help="HiGHS threads (default: mission's or HiGHS').", min=1)
    ] = None,
    seed: Annotated[int | None, typer.Option(help="HiGHS random seed.", min=0)] = None,
    one_step: Annotated[
        bool,
        typer.Option("--one-step", help="Skip step 2 (effort minimization with decisions fixed)."),
    ] = False,
    encoding: Annotated[
        Encoding | None,
        typer.Option(help="Disjunction encoding (default: the mission's, standard)."),
    ] = None,
    inter_sample: InterSampleOption = None,
    quiet: Annotated[
        bool, typer.Option("--quiet", "-q", help="Print only the one-line result.")
    ] = False,
) -> None:
    """Plan a mission: solve the MILP, verify with the monitor, write CSV, JSON and plots."""
    from stlplan.outputs.progress import ProgressLine
    from stlplan.outputs.render import print_plan

    overrides = api.Overrides(
        time_limit=time_limit,
        gap=gap,
        threads=threads,
        seed=seed,
        encoding=None if encoding is None else encoding.value,
        two_step=False if one_step else None,
        inter_sample=inter_sample,
    )
    with ProgressLine(err_console, enabled=not quiet) as line:
        result = api.solve(mission, out=out, overrides=overrides, progress=line.update)
    if not quiet:
        print_plan(out_console, result)
    code = STATUS_EXIT[result.status]
    stopped_by = stops.last_signal()
    if result.status.interrupted and stopped_by is not None:  # 130 for Ctrl-C, 143 for TERM
        code = 128 + stopped_by
    verdict = "satisfied" if code == 0 else result.status.value
    target = err_console if code else out_console
    target.print(f"{verdict}: {result.message}; outputs in {out}")
    raise typer.Exit(code)


@app.command()
@handled
def sweep(
    missions: Annotated[
        list[Path], typer.Argument(help="Mission files (YAML).", show_default=False)
    ],
    runs: Annotated[int, typer.Option(help="Random initial states per mission.", min=1)] = 30,
    seed: Annotated[
        int, typer.Option(help="Seed: run i of seed S always gets the same state.", min=0)
    ] = 0,
    workers: Annotated[
        int | None, typer.Option(help="Local worker processes (default: cores).", min=1)
    ] = None,
    scheduler: Annotated[
        str | None, typer.Option(help="Dask scheduler address, e.g. tcp://host:8786.")
    ] = None,
    out: Annotated[str, typer.Option(help="Output directory.", callback=_directory)] = "out/sweep",
    time_limit: Annotated[float | None, typer.Option(help="Seconds per solve.", min=0.001)] = None,
    resume: Annotated[
        bool, typer.Option("--resume", help="Skip runs already in OUT/runs.jsonl.")
    ] = False,
) -> None:
    """Solve missions from random initial states; print and write the paper's Table 3."""
    from stlplan.sweep.progress import SweepProgress

    if scheduler:
        where = f"on the Dask cluster at {scheduler}"
    else:
        where = f"in {workers} local processes" if workers else "in one local process per core"
    err_console.print(f"sweep runs {where}")
    with SweepProgress(err_console) as bar:
        rows = api.sweep(
            list(missions),
            runs,
            seed,
            out,
            workers,
            scheduler,
            resume,
            on_record=bar.advance,
            on_start=bar.start,
            overrides=api.Overrides(time_limit=time_limit),
        )
    from stlplan.sweep.progress import print_table

    print_table(out_console, rows)
    folder = Path(out)
    out_console.print(f"records in {folder / 'runs.jsonl'}; table in {folder / 'table.md'}")


def main() -> None:
    """Console entry point (``stlplan``)."""
    try:
        app()
    except KeyboardInterrupt as exc:
        err_console.print("interrupted")
        sys.exit(exc.exit_code if isinstance(exc, stops.Interrupted) else EXIT_INTERRUPTED)
