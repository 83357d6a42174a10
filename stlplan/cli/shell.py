"""What every command shares: exit codes, where output goes, and errors rendered at the edge.

A command prints for people (rich tables and lines), one line (``--quiet``) or one JSON document
on stdout (``--json``); an error is one message on stderr, or one JSON object there with
``--json``. Consoles never wrap a line when the output is not a terminal, so a piped path stays
whole.
"""

from __future__ import annotations

import contextlib
import functools
import json
import os
import sys
from collections.abc import Callable
from typing import Annotated, Any

import typer
from rich.console import Console
from rich.markup import escape

from stlplan.errors import StlplanError, UsageError
from stlplan.native_output import fd1_redirected
from stlplan.outputs.directory import strict_json
from stlplan.runtime import signals

EXIT_OK, EXIT_VIOLATED, EXIT_USAGE, EXIT_BAD_INPUT = 0, 1, 2, 3
EXIT_INFEASIBLE, EXIT_NO_PLAN, EXIT_SOLVER = 4, 5, 6
EXIT_DEGRADED, EXIT_INTERNAL, EXIT_INTERRUPTED = 7, 70, 130

EXITS_COMMON = (
    "2 usage error (an option, or a file the system refuses to read or write), 3 bad input "
    "(mission, formula or trajectory file), 70 internal error, 130 / 143 stopped by Ctrl-C / "
    "SIGTERM."
)

JsonOption = Annotated[
    bool,
    typer.Option(
        "--json",
        help="Print one JSON document on stdout and nothing else there; an error is one JSON "
        "object on stderr (exit_code, error: its kind, message, file, location).",
    ),
]
QuietOption = Annotated[bool, typer.Option("--quiet", "-q", help="Print one line: the result.")]
VerboseOption = Annotated[
    bool,
    typer.Option(
        "--verbose",
        "-v",
        help="Also print what happened on the way: lazy rounds, confirmations of HiGHS's "
        "verdicts, retries (always in summary.json).",
    ),
]


def console(stderr: bool = False) -> Console:
    """A rich console on stdout or stderr that wraps lines only on a terminal."""
    made = Console(stderr=stderr, highlight=False)
    if not made.is_terminal:
        made.soft_wrap = True
        made.width = 100_000  # tables take the width they need, never a terminal's 80 columns
    return made


def dumps(data: object) -> str:
    """``data`` as strict, indented JSON (an infinite or undefined number is null)."""
    return json.dumps(strict_json(data), indent=2, allow_nan=False, default=str)


class Output:
    """Where one command's results go: for people, one line (``--quiet``) or JSON (``--json``)."""

    def __init__(self, as_json: bool = False, quiet: bool = False) -> None:
        self.as_json = as_json
        self.quiet = quiet and not as_json
        self.out = console()
        self.err = console(stderr=True)

    @property
    def full(self) -> bool:
        """Whether the full human-readable output is wanted."""
        return not (self.as_json or self.quiet)

    def document(self, data: object) -> None:
        """The one JSON document of a ``--json`` run, on stdout."""
        sys.stdout.write(dumps(data) + "\n")
        sys.stdout.flush()

    def line(self, text: str, error: bool = False, markup: bool = False) -> None:
        """One line on stdout, or stderr for a failure; none with --json. ``markup``: ``text``
        holds rich markup (what it quotes is escaped)."""
        if not self.as_json:
            (self.err if error else self.out).print(text, markup=markup)


def solver_output(discard: bool) -> contextlib.AbstractContextManager[None]:
    """Point file descriptor 1 at stderr (or, with ``discard``, nowhere) while the solver runs,
    so what native code prints never mixes with stlplan's own output on stdout; ``--json`` and
    ``--quiet`` runs discard it."""
    return fd1_redirected(discard)


def print_json_error(
    code: int, message: str, kind: str, source: str | None = None, where: str | None = None
) -> None:
    """One JSON object on stderr: the exit code, the kind of error, the message and its place."""
    error = {"exit_code": code, "error": kind, "message": message, "file": source}
    error["location"] = where
    sys.stderr.write(json.dumps(error) + "\n")
    sys.stderr.flush()


def _report(as_json: bool, code: int, kind: str, exc: BaseException | str) -> None:
    """An error on stderr: one line for people, one JSON object with ``--json``."""
    if as_json:
        if isinstance(exc, StlplanError):
            print_json_error(code, exc.message, kind, exc.source, exc.where)
        else:
            print_json_error(code, str(exc), kind)
        return
    label = "internal error" if kind == "internal" else "error"
    shown = "interrupted" if kind == "interrupted" else f"[red]{label}[/]: {escape(str(exc))}"
    console(stderr=True).print(shown, soft_wrap=True)


def error_kind(exc: StlplanError) -> str:
    """``mission``, ``formula``, ``trajectory``, ``usage``, ``infeasible`` or ``solver``."""
    return type(exc).__name__.removesuffix("Error").lower()


def _os_error(exc: OSError) -> UsageError:
    where = str(exc.filename) if exc.filename else None
    return UsageError(exc.strerror or str(exc), source=where)


def handled(command: Callable[..., None]) -> Callable[..., None]:
    """Turn errors into one message on stderr (JSON with ``--json``) and their exit code."""

    @functools.wraps(command)
    def run(*args: Any, **kwargs: Any) -> None:
        as_json = bool(kwargs.get("as_json"))
        try:
            command(*args, **kwargs)
        except typer.Exit:
            raise
        except StlplanError as exc:
            _report(as_json, exc.exit_code, error_kind(exc), exc)
            raise typer.Exit(exc.exit_code) from None
        except KeyboardInterrupt as exc:  # a signal outside a solve, or a second one
            code = exc.exit_code if isinstance(exc, signals.Interrupted) else EXIT_INTERRUPTED
            _report(as_json, code, "interrupted", "interrupted")
            raise typer.Exit(code) from None
        except OSError as exc:  # a file the operating system refused (disk full, permissions)
            error = _os_error(exc)
            _report(as_json, EXIT_USAGE, "usage", error)
            raise typer.Exit(EXIT_USAGE) from None
        except Exception as exc:  # noqa: BLE001 - the edge of the program
            if os.environ.get("STLPLAN_DEBUG"):
                raise
            text = f"{type(exc).__name__}: {exc} (set STLPLAN_DEBUG=1 for a traceback)"
            _report(as_json, EXIT_INTERNAL, "internal", text)
            raise typer.Exit(EXIT_INTERNAL) from None

    return run
