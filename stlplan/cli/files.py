"""Commands that read and write files without planning: validate, check, schema."""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.markup import escape

from stlplan import api
from stlplan.cli.shell import EXIT_VIOLATED, EXITS_COMMON, JsonOption, Output, QuietOption, handled
from stlplan.errors import UsageError
from stlplan.formula.boundary import HOLDS_AT
from stlplan.mission.groups import count_groups
from stlplan.mission.problem import Problem, TaskModel
from stlplan.words import counted

MissionArg = Annotated[
    Path, typer.Argument(help="Mission file (YAML).", metavar="MISSION", show_default=False)
]
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
SCHEMA_PATH = Path("schemas") / "mission.schema.json"

VALIDATE_EPILOG = f"Exit codes: 0 valid, {EXITS_COMMON}"
CHECK_EPILOG = (
    f"Exit codes: 0 every task, constraint and physical check holds, 1 the trajectory violates "
    f"the mission, {EXITS_COMMON}"
)
SCHEMA_EPILOG = "Exit codes: 0 written, 2 the file cannot be written."


GROUPS_SHOWN = 10**6
"""`validate` counts each task's groups up to this many (the selection encoding needs none)."""


def group_count(task: TaskModel) -> int | None:
    """The task's number of groups, or None when there are more than :data:`GROUPS_SHOWN`."""
    n = count_groups(task.elements, task.count, task.reuse_agents, limit=GROUPS_SHOWN + 1)
    return None if n > GROUPS_SHOWN else n


def _groups_text(task: TaskModel) -> str:
    n = group_count(task)
    shown = f"more than {GROUPS_SHOWN}" if n is None else str(n)
    groups = "groups" if n != 1 else "group"
    return f"{task.name}: {counted(len(task.elements), 'element')}, {shown} {groups}"


def problem_counts(problem: Problem, mission: Path) -> dict[str, object]:
    """What ``validate --json`` prints: the mission's size and each task's number of elements
    and groups (null: more than :data:`GROUPS_SHOWN`)."""
    return {
        "valid": True,
        "file": str(mission),
        "mission": problem.mission.name,
        "horizon": problem.horizon,
        "agents": len(problem.agents),
        "regions": len(problem.regions),
        "tasks": len(problem.tasks),
        "synchronous_tasks": sum(1 for t in problem.tasks if t.sync is not None),
        "constraints": len(problem.constraints),
        "groups": {t.name: group_count(t) for t in problem.tasks},
        "elements": {t.name: len(t.elements) for t in problem.tasks},
    }


@handled
def validate(mission: MissionArg, as_json: JsonOption = False, quiet: QuietOption = False) -> None:
    """Check a mission file: schema, names, shapes, horizons and Patterns."""
    output = Output(as_json, quiet)
    problem = api.validate(mission)
    if as_json:
        output.document(problem_counts(problem, mission))
        return
    sizes = (
        f"{counted(len(problem.agents), 'agent')}, {counted(len(problem.tasks), 'task')}, "
        f"{counted(len(problem.constraints), 'constraint')}"
    )
    if output.quiet:  # one short line, whatever the team's size
        output.line(f"[green]valid[/]: {escape(str(mission))} ({sizes})", markup=True)
        return
    groups = "; ".join(_groups_text(t) for t in problem.tasks)
    text = f"[green]valid[/]: {escape(str(mission))} ({sizes}; {groups or 'no tasks'})"
    output.line(text, markup=True)


TrajectoryArg = Annotated[
    Path,
    typer.Argument(
        help="Trajectory CSV: agent, k (or t, step), x0.., u0.. (optional).",
        metavar="TRAJECTORY",
        show_default=False,
    ),
]


def _png_file(value: Path | None) -> Path | None:
    """The map's file must be a file name whose folder is a folder (or does not exist yet)."""
    if value is None:
        return None
    if value.is_dir():
        raise typer.BadParameter(f"{value} is a folder; expected a PNG file name")
    folder = next((p for p in value.parents if p.exists()), None)
    if folder is not None and not folder.is_dir():
        raise typer.BadParameter(f"{folder} is a file, so {value} cannot be created")
    return value


PlotOption = Annotated[
    Path | None,
    typer.Option(
        help="Also draw the map of the trajectory to this PNG (crossings in red).",
        metavar="PNG",
        callback=_png_file,
    ),
]
ToleranceOption = Annotated[
    float,
    typer.Option(
        help="How far each number of the trajectory may be off: T max(1, |v|) in the dynamics "
        f"and bounds, and a requirement holds at robustness >= {HOLDS_AT:g} - T (1e-3 accepts a "
        "CSV rounded to 3 decimals).",
        min=0.0,
        metavar="T",
    ),
]


@handled
def check(
    mission: MissionArg,
    trajectory: TrajectoryArg,
    inter_sample: InterSampleOption = None,
    plot: PlotOption = None,
    tolerance: ToleranceOption = api.DEFAULT_TOLERANCE,
    as_json: JsonOption = False,
    quiet: QuietOption = False,
) -> None:
    """Judge a team trajectory with the independent monitor; exit 1 when anything fails.

    The trajectory may come from any tool: the step column may be k, t or step; without the
    inputs u0.. the dynamics are checked on the states only; when every task and constraint
    reads positions only, the position columns alone (x0, x1 or x, y) are enough and the
    dynamics are not checked. The report says which.
    """
    from stlplan.outputs.render import print_report, report_line
    from stlplan.outputs.summary import report_dict

    output = Output(as_json, quiet)
    problem, report = api.check(mission, trajectory, inter_sample, tolerance)
    if plot is not None:
        api.plot_trajectory(problem, trajectory, report, plot)
    if as_json:
        doc: dict[str, object] = {"mission": problem.mission.name, "file": str(mission)}
        doc |= {"trajectory": str(trajectory), "inter_sample": problem.inter_sample}
        output.document(doc | report_dict(report))
    elif quiet:
        output.line(report_line(report), markup=True)
    else:
        print_report(output.out, report)
        if plot is not None:
            output.line(f"map in {plot}")
    if not report.satisfied:
        raise typer.Exit(EXIT_VIOLATED)


def _schema_file(value: str) -> str:
    """The schema's file must be named, and not be a folder."""
    if not value.strip():
        raise typer.BadParameter("expected a file name, found an empty string")
    if value != "-" and Path(value).is_dir():
        raise typer.BadParameter(f"{value} is a folder; expected a file name, e.g. "
                                 f"{Path(value) / SCHEMA_PATH.name}")  # fmt: skip
    return value


@handled
def schema(
    out: Annotated[
        str,
        typer.Option(
            help="Where to write the JSON Schema ('-': stdout).",
            metavar="PATH",
            callback=_schema_file,
        ),
    ] = str(SCHEMA_PATH),
    as_json: JsonOption = False,
    quiet: QuietOption = False,
) -> None:
    """Write the mission file JSON Schema (for editors and validation).

    With --json the document printed names the file written (with --out -, it is the schema).
    """
    from stlplan.mission.schema import json_schema

    text = json_schema()
    if out == "-":
        sys.stdout.write(text)
        return
    target = Path(out)
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text(text, encoding="utf-8")
    output = Output(as_json, quiet)
    if as_json:
        output.document({"file": str(target)})
    else:
        output.line(f"wrote {target}")


EXAMPLE_EPILOG = (
    "Exit codes: 0 written (or listed), 2 no such example, the file exists (without --force) or "
    "cannot be written."
)


@handled
def example(
    name: Annotated[
        str | None,
        typer.Argument(
            help="A shipped mission (NAME, or FOLDER/NAME as under missions/); without it, "
            "list them.",
            metavar="[NAME]",
        ),
    ] = None,
    out: Annotated[
        str | None,
        typer.Option(
            help="Where to write it (default: NAME.yaml here; '-': stdout).", metavar="FILE"
        ),
    ] = None,
    force: Annotated[bool, typer.Option("--force", help="Replace an existing file.")] = False,
    as_json: JsonOption = False,
    quiet: QuietOption = False,
) -> None:
    """Write one of the shipped missions (paper Cases I-III, small ones, the scaled farms of
    missions/scale, the crowds of missions/crowd and the STL suite of missions/stl) to start
    from.

    Its schema line points at the schema installed with stlplan, from where it is written.
    """
    from stlplan import examples

    output = Output(as_json, quiet)
    if name is None:
        shipped = examples.examples()
        if as_json:
            output.document(
                [{"name": e.name, "file": e.file, "description": e.description} for e in shipped]
            )
        elif quiet:
            output.line(" ".join(e.name for e in shipped))
        else:
            width = max(len(e.name) for e in shipped)
            for item in shipped:
                name = f"{item.name:<{width}}"
                output.line(f"[bold]{name}[/]  {escape(item.summary)}".rstrip(), markup=True)
        return
    if out == "-" and as_json:  # the mission itself, as a JSON document
        import yaml

        mission = yaml.safe_load(examples.example_text(name))
        output.document({"example": examples.example(name).name, "mission": mission})
        return
    if out == "-":
        sys.stdout.write(examples.example_text(name))
        return
    target = Path(out or f"{examples.example(name).name}.yaml")
    if target.exists() and not force:
        raise UsageError("the file exists; choose another --out or add --force", source=str(target))
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text(examples.example_text(name, target), encoding="utf-8")
    if as_json:
        output.document({"example": examples.example(name).name, "file": str(target)})
    else:
        output.line(f"wrote {target}")


EXPORT_EPILOG = f"Exit codes: 0 written, {EXITS_COMMON}"


@handled
def export_rtamt(
    mission: MissionArg,
    out: Annotated[
        Path | None,
        typer.Option(help="Write to this file instead of standard output.", metavar="FILE"),
    ] = None,
    as_json: JsonOption = False,
    quiet: QuietOption = False,
) -> None:
    """Write each single-agent task and constraint as an RTAMT specification, to cross-check.

    With --json the document printed holds the specifications (name, kind, role, agents,
    variables, text) and the tasks and constraints not exported, each with why.
    """
    specs, text = api.export_rtamt(mission, out)
    output = Output(as_json, quiet)
    if as_json:
        output.document(_rtamt_document(mission, out, specs))
    elif out is None:
        sys.stdout.write(text)
    else:
        output.line(f"wrote {counted(len(specs), 'specification')} to {out}")


def _rtamt_document(mission: Path, out: Path | None, specs: list[Any]) -> dict[str, object]:
    """What ``export-rtamt --json`` prints."""
    from stlplan.mission.loader import load_problem
    from stlplan.outputs.rtamt import skipped

    problem = load_problem(mission)
    return {
        "mission": problem.mission.name,
        "file": str(mission),
        "out": None if out is None else str(out),
        "specifications": [dataclasses.asdict(spec) for spec in specs],
        "not_exported": skipped(problem),
    }
