"""The ``stlplan`` command line: a thin shell over :mod:`stlplan.api`.

Exit codes: 0 satisfied / valid; 1 a checked trajectory violates the mission; 2 usage error
(including a file the operating system refuses to read or write);
3 bad input (mission, formula, trajectory); 4 infeasible; 5 no plan within the time limit;
6 solver error or a plan the monitor rejects; 70 internal error; 128 + the signal's number when
a signal stopped the run (130 for Ctrl-C, 143 for SIGTERM), with the best plan so far written
when there was one.
"""

from __future__ import annotations

import sys
from typing import Annotated

import typer

from stlplan import __version__
from stlplan.cli import files, planning, replanning, simulating
from stlplan.cli.help import Command, Group
from stlplan.cli.shell import EXIT_INTERRUPTED, console
from stlplan.runtime import signals, started

EPILOG = (
    "Exit codes: 0 satisfied or valid, 1 a checked trajectory violates the mission, 2 usage "
    "error, 3 bad input, 4 infeasible, 5 no plan within the time limit, 6 solver error or a plan "
    "the monitor rejects, 7 a degraded plan (solve --degrade, replan), 70 internal error, "
    "130 / 143 stopped by Ctrl-C / SIGTERM. Every "
    "command takes --json (one JSON document on stdout) and --quiet (one line)."
)

app = typer.Typer(
    cls=Group,
    help="Plan coordinated trajectories for a heterogeneous team from global STL tasks.",
    epilog=EPILOG,
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,
)


def _version(value: bool) -> None:
    if value:
        sys.stdout.write(f"stlplan {__version__}\n")
        raise typer.Exit(0)


@app.callback()
def _root(
    version: Annotated[
        bool,
        typer.Option(
            "--version", help="Print the version and exit.", callback=_version, is_eager=True
        ),
    ] = False,
) -> None:
    """Plan coordinated trajectories for a heterogeneous team from global STL tasks."""


COMMANDS = (
    (files.validate, files.VALIDATE_EPILOG, "Check a mission file."),
    (files.check, files.CHECK_EPILOG, "Judge a trajectory from any tool with the monitor."),
    (files.schema, files.SCHEMA_EPILOG, "Write the mission file JSON Schema."),
    (files.example, files.EXAMPLE_EPILOG, "List the shipped missions, or write one."),
    (files.export_rtamt, files.EXPORT_EPILOG, "Write the tasks as RTAMT specifications."),
    (planning.solve, planning.SOLVE_EPILOG, "Plan a mission, verify it, write the plan."),
    (planning.sweep, planning.SWEEP_EPILOG, "Solve missions from random initial states."),
    (replanning.replan, replanning.REPLAN_EPILOG, "Plan again from a step of an executed plan."),
    (
        simulating.simulate,
        simulating.SIMULATE_EPILOG,
        "Execute a plan under disturbance, in a loop.",
    ),
)
for command, epilog, short_help in COMMANDS:
    name = command.__name__.replace("_", "-")
    app.command(name, cls=Command, epilog=epilog, short_help=short_help)(command)


def main() -> None:
    """Console entry point (``stlplan``). A command on a deadline ends the process as soon as its
    answer is out (:func:`stlplan.runtime.started.end_at_once`)."""
    try:
        app()
    except KeyboardInterrupt as exc:
        console(stderr=True).print("interrupted")
        sys.exit(exc.exit_code if isinstance(exc, signals.Interrupted) else EXIT_INTERRUPTED)
    except SystemExit as done:
        if started.AT_ONCE:
            started.exit_now(done.code)
        raise
