"""Plain help and usage errors for the command line.

Help is plain text that reads the same in a terminal, a pipe or a man page: arguments in the usage
line as ``MISSION`` (not ``{mission}``), options with the value they take (``--time-limit
SECONDS``) and no type annotations for flags. A usage mistake (an unknown option, a missing
argument, a value out of range) exits 2 with click's message, or, when the command line asks for
``--json``, with one JSON object on stderr.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from typing import Any

from typer import Abort
from typer.core import TyperCommand, TyperGroup

try:  # recent typer carries its own copy of click
    from typer._click.exceptions import ClickException
except ImportError:  # pragma: no cover - typer over the click package
    from click.exceptions import ClickException  # type: ignore[no-redef,assignment]

from stlplan.cli.shell import EXIT_INTERRUPTED, print_json_error


def _argument_name(param: Any) -> str:
    name = param.metavar or param.name.upper()
    return f"{name}..." if param.nargs == -1 else name


def _option_names(param: Any) -> str:
    names = sorted(param.opts, key=lambda o: (o.startswith("--"), o))
    text = ", ".join(names)
    if param.secondary_opts:
        text += " / " + ", ".join(param.secondary_opts)
    if not param.is_flag:
        text += " " + (param.metavar or param.name.upper())
    return text


def _default(param: Any) -> str:
    """``  [default: X]`` for an option with a plain default worth showing."""
    value = param.default
    if param.is_flag or value is None or not param.show_default or callable(value):
        return ""
    return f"  [default: {getattr(value, 'value', value)}]"


def help_record(param: Any) -> tuple[str, str] | None:
    """The (names, help) pair of one parameter, or None for a hidden one."""
    if getattr(param, "hidden", False):
        return None
    if param.param_type_name == "argument":
        return _argument_name(param), param.help or ""
    return _option_names(param), (param.help or "") + _default(param)


def _location(exc: ClickException) -> str | None:
    """The option or argument a usage error is about (``--time-limit``, ``MISSION``)."""
    param = getattr(exc, "param", None)
    if param is None:
        return None
    if param.param_type_name == "argument":
        return _argument_name(param)
    return max(param.opts, key=len)


class Command(TyperCommand):
    """A command whose help names arguments and values plainly."""

    def collect_usage_pieces(self, ctx: Any) -> list[str]:
        pieces = [self.options_metavar] if self.options_metavar else []
        for param in self.get_params(ctx):
            if param.param_type_name == "argument":
                pieces.append(_argument_name(param))
        return pieces

    def format_options(self, ctx: Any, formatter: Any) -> None:
        sections: dict[str, list[tuple[str, str]]] = {"Arguments": [], "Options": []}
        for param in self.get_params(ctx):
            record = help_record(param)
            if record is not None:
                kind = "Arguments" if param.param_type_name == "argument" else "Options"
                sections[kind].append(record)
        for title, records in sections.items():
            if records:
                with formatter.section(title):
                    formatter.write_dl(records)


class Group(TyperGroup):
    """The ``stlplan`` group: usage errors as click prints them, or as JSON with ``--json``."""

    def main(  # type: ignore[override]
        self,
        args: Sequence[str] | None = None,
        prog_name: str | None = None,
        complete_var: str | None = None,
        standalone_mode: bool = True,
        **extra: Any,
    ) -> Any:
        argv = list(sys.argv[1:] if args is None else args)
        try:
            code = super().main(argv, prog_name, complete_var, standalone_mode=False, **extra)
        except ClickException as exc:
            code = exc.exit_code
            if "--json" in argv:
                print_json_error(code, exc.format_message(), "usage", where=_location(exc))
            else:
                exc.show()
        except Abort:
            code = EXIT_INTERRUPTED
            print("interrupted", file=sys.stderr)
        if not standalone_mode:
            return code
        sys.exit(code if isinstance(code, int) else 0)
