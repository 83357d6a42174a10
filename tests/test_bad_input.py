"""Mistakes made on the command line and with files, through ``stlplan.cli.app``.

Each mistake gets a non-zero exit code of its category (2 usage, including click/typer's own
 #   mistake                      exit  the message says
===  ===========================  ====  ==================================================
 1   missing_mission              3     file, "no such file"
 2   mission_is_directory         3     file, "is a directory", expected a mission file
 3   unreadable_mission           3     file, "cannot read the file" (chmod 000, or a path
                                        under a regular file when running as root)
 4   binary_mission               3     file, line/column of the first non-UTF-8 byte
 5   empty_mission                3     file, "empty file", expected a mapping
 6   list_mission                 3     file, "found [...]", expected a mapping
 7   scalar_mission               3     file, expected a mapping of mission fields
 8   deep_yaml                    3     file, line/column, nesting limit
 9   alias_bomb                   3     file, line/column, expansion limit ("*name")
 10  alias_cycle                  3     file, line/column, "cycles"
 11  two_documents                3     file, line/column, "single document"
 12  tab_indent                   3     file, line/column, YAML syntax error
 13  json_style_typo              3     file, line/column, YAML syntax error
 14  formula_too_deep             3     file, field path, nesting limit of formulas
 15  formula_nul_byte             3     file, field path, line and column in the formula
 16  empty_polytope               3     file, field path regions.Goal.G
 17  horizon_too_large            3     file, field path horizon, the limit
 18  too_many_groups              3     file, field path tasks.meet.count
 19  role_name_with_space         3     file, field path ...for_each, a role name
 20  missing_trajectory           3     file, "no such file"
 21  trajectory_is_directory      3     file, "is a directory", expected a CSV file
 22  empty_trajectory             3     file, line 1, the expected header
 23  binary_trajectory            3     file, line/column, not UTF-8
 24  trajectory_bad_header        3     file, line 1, no step column, expected k, t or step
 25  trajectory_unknown_agent     3     file, line, unknown agent, the mission's agents
 26  trajectory_non_numeric       3     file, line, column x1, expected a finite number
 27  trajectory_missing_step      3     file, line, agent and step, one row per step
 28  trajectory_duplicate_row     3     file, line, duplicate row, first line
 29  trajectory_step_range        3     file, line, column k, expected 0..H
 30  trajectory_open_quote        3     file, line, shortened cell, the open quote hint
 31  out_under_a_file             2     path, cannot create the output directory
 32  out_is_a_file                2     path, cannot create the output directory
 33  time_limit_zero              2     --time-limit, seconds from 0.001 to 1e6
 34  gap_negative                 2     --gap, 0 <= G < 1
 35  threads_zero                 2     --threads, >= 1
 36  encoding_unknown             2     --encoding, 'log' or 'standard'
 37  unknown_command              2     "No such command"
 38  missing_argument             2     "Missing argument"
 39  unknown_option               2     "No such option"
 40  gap_one                      2     --gap, 0 <= G < 1
 41  seed_too_large               2     --seed, at most 2147483647 (HiGHS's range)
 42  swapped_check_arguments      3     file, a trajectory CSV, the mission comes first,
                                        the text shortened (never the whole file)
 43  schema_as_mission            3     file, a JSON Schema, not a mission
 44  control_character            3     file, line/column, the code point
 45  colon_in_value               3     file, line/column, put the value in quotes
 46  bad_indentation              3     file, line/column, the indentation
 47  unknown_yaml_tag             3     file, line/column, the tag, no negation hint
 48  horizon_cannot_fit           3     file, horizon, the estimated memory or time
 49  apostrophe_in_diagnosis      4     the task's whole name, by kind, in the diagnosis
 50  duplicate_through_alias      3     file, the alias's line and column, the anchor's
 51  trajectory_long_cell         3     file, the line of the cell, the size limit
 52  role_names_agent             3     file, line, tasks.meet.roles.p, the agent, how to
                                        bind it ({agent: NAME})
 53  trajectory_input_at_horizon  3     file, line, column u0, no input at step H, expected
                                        an empty cell
===  ===========================  ====  ==================================================
=======
usage errors; 3 bad input; 4 infeasible, diagnosed before solving), one message that names the
file (with line/column or field path where one applies) and says what was expected, and never a
traceback. ``CASES`` below is the catalogue: each mistake with its exit code and the fragments its
message must contain. ``tests/broken/`` (``tests/test_checks.py``) catalogues mistakes inside a
mission.

The last tests check that a failed ``solve`` leaves nothing behind in the output directory (no
staging folder, no partial file): for a bad mission, and for a write that fails half-way.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from stlplan.cli import app
from stlplan.mission.loader import load_problem
from stlplan.outputs.trajio import write_trajectory_csv
from stlplan.result import Trajectory
from tests.helpers.paths import PAIR, ROOT

runner = CliRunner()
EXIT_USAGE, EXIT_BAD_INPUT = 2, 3


def run_cli(*args: str) -> tuple[int, str]:
    """Exit code and the output (stdout and stderr, interleaved) with whitespace and box lines
    collapsed."""
    result = runner.invoke(app, list(args), env={"COLUMNS": "400", "STLPLAN_DEBUG": ""})
    text = result.output
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        text += f"\nTraceback: {result.exception!r}"
    return result.exit_code, re.sub(r"[\s│╭╮╰╯─]+", " ", text)


def _mission_doc() -> dict[str, Any]:
    return yaml.safe_load(PAIR.read_text(encoding="utf-8"))


def _mission_file(tmp: Path, change: Callable[[dict[str, Any]], None]) -> Path:
    doc = _mission_doc()
    change(doc)
    path = tmp / "mission.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False), encoding="utf-8")
    return path


def _text_file(tmp: Path, name: str, text: str | bytes) -> Path:
    path = tmp / name
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text, encoding="utf-8")
    return path


def _frozen_csv(tmp: Path) -> list[str]:
    """Lines of a valid trajectory CSV for PAIR: every agent held at its initial state."""
    problem = load_problem(PAIR)
    H = problem.horizon
    states = {
        a.name: np.tile(np.asarray(a.initial_state, float), (H + 1, 1)) for a in problem.agents
    }
    inputs = {a.name: np.zeros((H, a.m)) for a in problem.agents}
    path = tmp / "frozen.csv"
    write_trajectory_csv(problem, Trajectory(H, states, inputs), path)
    return path.read_text(encoding="utf-8").splitlines()


def _trajectory(tmp: Path, edit: Callable[[list[str]], list[str]]) -> list[str]:
    path = tmp / "trajectory.csv"
    path.write_text("\n".join(edit(_frozen_csv(tmp))) + "\n", encoding="utf-8")
    return ["check", str(PAIR), str(path)]


def _unreadable(tmp: Path) -> list[str]:
    if os.geteuid() == 0:  # root reads a chmod 000 file; a path under a file fails for anyone
        return ["validate", str(_text_file(tmp, "file.yaml", "name: x\n") / "sub.yaml")]
    path = _text_file(tmp, "locked.yaml", PAIR.read_text(encoding="utf-8"))
    path.chmod(0)
    return ["validate", str(path)]


def _solve_with(*options: str) -> Callable[[Path], list[str]]:
    """The arguments of a solve of PAIR with ``options``."""
    return lambda tmp: ["solve", str(PAIR), "--out", str(tmp / "o"), *options]


def _alias_bomb() -> str:
    lines = ["l0: &l0 [x, x, x, x, x, x, x, x, x]"]
    lines += [f"l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * 9)}]" for i in range(1, 9)]
    return "\n".join(lines) + "\n"


def _first_step_row(lines: list[str], agent: str, k: int) -> int:
    return next(i for i, line in enumerate(lines) if line.startswith(f"{agent},{k},"))


def _drop(lines: list[str], agent: str, k: int) -> list[str]:
    i = _first_step_row(lines, agent, k)
    return lines[:i] + lines[i + 1 :]


def _set(lines: list[str], agent: str, k: int, old: str, new: str) -> list[str]:
    i = _first_step_row(lines, agent, k)
    return [*lines[:i], lines[i].replace(old, new, 1), *lines[i + 1 :]]


Case = Callable[[Path], list[str]]
ROW = 1 + 9 + 2 + 1  # line of north's step 2: header, south's 9 rows, north's steps 0 and 1

CASES: dict[str, tuple[Case, int, tuple[str, ...]]] = {
    "missing_mission": (
        lambda t: ["validate", str(t / "nope.yaml")],
        3,
        ("nope.yaml", "no such file"),
    ),
    "mission_is_directory": (
        lambda t: ["validate", str(t)],
        3,
        ("is a directory", "expected a mission file"),
    ),
    "unreadable_mission": (_unreadable, 3, ("cannot read the file", "expected a readable")),
    "binary_mission": (
        lambda t: ["validate", str(_text_file(t, "bin.yaml", b"name: x\nhor\xffizon: 3\n"))],
        3,
        ("bin.yaml", "line 2, column 4", "not UTF-8", "expected a YAML mission file"),
    ),
    "empty_mission": (
        lambda t: ["validate", str(_text_file(t, "empty.yaml", ""))],
        3,
        ("empty.yaml", "line 1, column 1", "expected a mapping", "empty file"),
    ),
    "list_mission": (
        lambda t: ["validate", str(_text_file(t, "list.yaml", "- name: x\n- horizon: 3\n"))],
        3,
        ("list.yaml", "line 1, column 1", "expected a mapping of mission fields", "a list"),
    ),
    "scalar_mission": (
        lambda t: ["validate", str(_text_file(t, "scalar.yaml", "just some words\n"))],
        3,
        ("scalar.yaml", "expected a mapping of mission fields", "'just some words'"),
    ),
    "deep_yaml": (
        lambda t: ["validate", str(_text_file(t, "deep.yaml", "name: " + "[" * 3000 + "]" * 3000))],
        3,
        ("deep.yaml", "line 1, column", "nested more than", "levels deep"),
    ),
    "alias_bomb": (
        lambda t: ["validate", str(_text_file(t, "bomb.yaml", _alias_bomb()))],
        3,
        ("bomb.yaml", "line ", "YAML aliases (*name)", "expected a mission file"),
    ),
    "alias_cycle": (
        lambda t: ["validate", str(_text_file(t, "cycle.yaml", "name: x\nregions: &r {A: *r}\n"))],
        3,
        ("cycle.yaml", "line 2, column", "refers to a value that contains it", "no cycles"),
    ),
    "two_documents": (
        lambda t: ["validate", str(_text_file(t, "two.yaml", "name: a\n---\nname: b\n"))],
        3,
        ("two.yaml", "line 2, column 1", "found another document", "expected a single document"),
    ),
    "tab_indent": (
        lambda t: ["validate", str(_text_file(t, "tab.yaml", "name: x\nregions:\n\tA: 1\n"))],
        3,
        ("tab.yaml", "line 3, column 1", "YAML syntax error"),
    ),
    "json_style_typo": (
        lambda t: ["validate", str(_text_file(t, "json.yaml", '{"name": "x", "horizon": 3,,}\n'))],
        3,
        ("json.yaml", "line 1, column", "YAML syntax error"),
    ),
    "formula_too_deep": (
        lambda t: [
            "validate",
            str(
                _mission_file(
                    t, lambda d: d["tasks"]["meet"].update(formula="!" * 500 + "in(p, Goal)")
                )
            ),
        ],
        3,
        ("mission.yaml", "tasks.meet.formula", "line ", "more than 100 levels", "expected at most"),
    ),
    "formula_nul_byte": (
        lambda t: [
            "validate",
            str(_mission_file(t, lambda d: d["tasks"]["meet"].update(formula="in(p,\x00 Goal)"))),
        ],
        3,
        ("mission.yaml", "tasks.meet.formula", "line 1, column 6", "expected one of"),
    ),
    "empty_polytope": (
        lambda t: [
            "validate",
            str(_mission_file(t, lambda d: d["regions"].update(Goal={"G": [], "h": []}))),
        ],
        3,
        ("mission.yaml", "regions.Goal.G", "line ", "at least one row"),
    ),
    "horizon_too_large": (
        lambda t: ["validate", str(_mission_file(t, lambda d: d.update(horizon=10**30)))],
        3,
        ("mission.yaml", "horizon", "line ", "expected a horizon of at most"),
    ),
    "too_many_groups": (
        lambda t: [
            "solve",
            str(_mission_file(t, _many_agents)),
            "--tasks",
            "groups",
            "--out",
            str(t / "out"),
        ],
        3,
        ("mission.yaml", "tasks.meet.count", "line ", "groups", "expected fewer"),
    ),
    "role_name_with_space": (
        lambda t: [
            "validate",
            str(
                _mission_file(
                    t, lambda d: d["constraints"]["avoid_obstacle"].update(for_each="p q")
                )
            ),
        ],
        3,
        ("mission.yaml", "constraints.avoid_obstacle.for_each", "expected a role name", "'p q'"),
    ),
    "missing_trajectory": (
        lambda t: ["check", str(PAIR), str(t / "none.csv")],
        3,
        ("none.csv", "no such file"),
    ),
    "trajectory_is_directory": (
        lambda t: ["check", str(PAIR), str(t)],
        3,
        ("is a directory", "expected a CSV file"),
    ),
    "empty_trajectory": (
        lambda t: ["check", str(PAIR), str(_text_file(t, "empty.csv", ""))],
        3,
        ("empty.csv", "line 1", "expected a header line agent, k, x0"),
    ),
    "binary_trajectory": (
        lambda t: ["check", str(PAIR), str(_text_file(t, "bin.csv", b"agent,k\n\x00\xfe\xff"))],
        3,
        ("bin.csv", "line 2, column 2", "not UTF-8", "expected a trajectory CSV file"),
    ),
    "trajectory_bad_header": (
        lambda t: _trajectory(t, lambda rows: [rows[0].replace(",k,", ",time,"), *rows[1:]]),
        3,
        ("trajectory.csv", "line 1", "no step column", "expected exactly one of k, t or step"),
    ),
    "trajectory_unknown_agent": (
        lambda t: _trajectory(t, lambda rows: _set(rows, "north", 2, "north", "nort")),
        3,
        ("trajectory.csv", f"line {ROW}", "unknown agent 'nort'", "south, north"),
    ),
    "trajectory_non_numeric": (
        lambda t: _trajectory(t, lambda rows: _set(rows, "north", 2, ",3.5,", ",three,")),
        3,
        ("trajectory.csv", f"line {ROW}", "column x1", "expected a finite number", "'three'"),
    ),
    "trajectory_missing_step": (
        lambda t: _trajectory(t, lambda rows: _drop(rows, "south", 3)),
        3,
        ("trajectory.csv", "line ", "'south' has no row for step(s) 3", "one row per step"),
    ),
    "trajectory_duplicate_row": (
        lambda t: _trajectory(t, lambda rows: [*rows, rows[1]]),
        3,
        ("trajectory.csv", "line 20", "duplicate row for agent 'south' at step 0", "line 2"),
    ),
    "trajectory_step_range": (
        lambda t: _trajectory(t, lambda rows: _set(rows, "north", 2, "north,2,", "north,12,")),
        3,
        ("trajectory.csv", f"line {ROW}", "column k", "integer step in 0..8", "'12'"),
    ),
    "trajectory_open_quote": (
        lambda t: _trajectory(t, lambda rows: _set(rows, "north", 2, ",3.5,", ',"3.5,')),
        3,
        ("trajectory.csv", "line ", "expected a finite number", "...'", "left open"),
    ),
    "out_under_a_file": (
        lambda t: ["solve", str(PAIR), "--out", str(_text_file(t, "f", "x") / "plan")],
        2,
        ("plan", "cannot create the output directory"),
    ),
    "out_is_a_file": (
        lambda t: ["solve", str(PAIR), "--out", str(_text_file(t, "taken", "x"))],
        2,
        ("taken", "cannot create the output directory"),
    ),
    "time_limit_zero": (
        lambda t: ["solve", str(PAIR), "--out", str(t / "o"), "--time-limit", "0"],
        2,
        ("--time-limit", "expected seconds from 0.001 to 1e6, found 0"),
    ),
    "gap_negative": (
        lambda t: ["solve", str(PAIR), "--out", str(t / "o"), "--gap", "-1"],
        2,
        ("--gap", "expected a relative gap 0 <= G < 1, found -1"),
    ),
    "threads_zero": (
        lambda t: ["solve", str(PAIR), "--out", str(t / "o"), "--threads", "0"],
        2,
        ("--threads", "greater than or equal to 1"),
    ),
    "encoding_unknown": (
        lambda t: ["solve", str(PAIR), "--out", str(t / "o"), "--encoding", "foo"],
        2,
        ("--encoding", "'foo' is not one of 'log', 'standard'"),
    ),
    "unknown_command": (
        lambda t: ["frobnicate", str(PAIR)],
        2,
        ("No such command 'frobnicate'",),
    ),
    "missing_argument": (lambda t: ["check", str(PAIR)], 2, ("Missing argument 'TRAJECTORY'",)),
    "unknown_option": (
        lambda t: ["validate", str(PAIR), "--strict"],
        2,
        ("No such option", "--strict"),
    ),
    "gap_one": (_solve_with("--gap", "1"), 2, ("--gap", "0 <= G < 1, found 1")),
    "seed_too_large": (_solve_with("--seed", "2147483648"), 2, ("--seed", "2147483647")),
    "swapped_check_arguments": (
        lambda t: ["check", _trajectory(t, lambda lines: lines)[2], str(PAIR)],
        3,
        (
            "trajectory.csv",
            "line 1, column 1",
            "a trajectory CSV",
            "mission comes first",
            "(text of",
        ),
    ),
    "schema_as_mission": (
        lambda t: ["validate", str(ROOT / "schemas" / "mission.schema.json")],
        3,
        ("mission.schema.json", "a JSON Schema", "not a mission"),
    ),
    "control_character": (
        lambda t: ["validate", str(_text_file(t, "bell.yaml", "name: x\nhorizon: 3\x07\n"))],
        3,
        ("bell.yaml", "line 2, column 11", "U+0007", "remove it"),
    ),
    "colon_in_value": (
        lambda t: [
            "validate",
            str(_text_file(t, "colon.yaml", "name: farm: case I\nhorizon: 3\n")),
        ],
        3,
        ("colon.yaml", "line 1, column 11", "colon and space", "put the value in quotes"),
    ),
    "bad_indentation": (
        lambda t: [
            "validate",
            str(_text_file(t, "indent.yaml", "name: x\nagents:\n  - name: a\n  dynamics: d\n")),
        ],
        3,
        ("indent.yaml", "line 4, column 3", "indentation"),
    ),
    "unknown_yaml_tag": (
        lambda t: ["validate", str(_text_file(t, "tag.yaml", "name: !custom x\nhorizon: 3\n"))],
        3,
        ("tag.yaml", "line 1, column 7", "unknown YAML tag '!custom'", "no tags"),
    ),
    "horizon_cannot_fit": (
        lambda t: ["solve", str(_mission_file(t, _horizon(100_000))), "--out", str(t / "o")],
        3,
        ("mission.yaml", "horizon", "GiB of memory", "shorten the horizon"),
    ),
    "apostrophe_in_diagnosis": (
        lambda t: ["solve", str(_mission_file(t, _goal_off_the_map)), "--out", str(t / "o")],
        4,
        ("task 'south's_goal'", "outside the state bounds"),
    ),
    "duplicate_through_alias": (
        lambda t: ["validate", str(_text_file(t, "alias.yaml", _duplicate_through_alias()))],
        3,
        ("alias.yaml", "line 4, column 5 (an alias", "line 3,", "duplicate agent name 'south'"),
    ),
    "trajectory_long_cell": (
        lambda t: _trajectory(t, lambda rows: [*rows[:3], _long_cell(rows[3]), *rows[4:]]),
        3,
        ("trajectory.csv", "line 4:", "a cell longer than 131072 characters"),
    ),
    "role_names_agent": (
        lambda t: ["validate", str(_mission_file(t, _role_names_agent))],
        3,
        (
            "mission.yaml",
            "line ",
            "tasks.meet.roles.p",
            "role 'p' names agent 'south'",
            "to bind an agent write {agent: south}",
        ),
    ),
    "trajectory_input_at_horizon": (
        lambda t: _trajectory(t, lambda rows: _input_at(rows, "south", 8, "abc")),
        3,
        (
            "trajectory.csv",
            "line 10:",
            "column u0",
            "agent 'south' has no input at step 8 = H",
            "expected an empty cell, found 'abc'",
        ),
    ),
}


def _duplicate_through_alias() -> str:
    """A mission whose second agent is an alias of the first (one name, twice)."""
    doc = _mission_doc()
    agent = yaml.safe_dump(doc["agents"][0], default_flow_style=True).strip()
    rest = {k: v for k, v in doc.items() if k != "agents"}
    return f"agents:\n  - &robot {agent}\n  - *robot\n" + yaml.safe_dump(rest, sort_keys=False)


def _input_at(lines: list[str], agent: str, k: int, text: str) -> list[str]:
    """``lines`` with ``text`` in the u0 cell of the agent's row at step ``k``."""
    i = _first_step_row(lines, agent, k)
    header = lines[0].split(",")
    cells = lines[i].split(",")
    cells[header.index("u0")] = text
    return [*lines[:i], ",".join(cells), *lines[i + 1 :]]


def _role_names_agent(doc: dict[str, Any]) -> None:
    """An agent's name where the role's capability is expected."""
    doc["tasks"]["meet"]["roles"] = {"p": "south"}


def _long_cell(row: str) -> str:
    cells = row.split(",")
    cells[2] = "1" * 200_000
    return ",".join(cells)


def _horizon(steps: int) -> Callable[[dict[str, Any]], None]:
    def change(doc: dict[str, Any]) -> None:
        doc["horizon"] = steps

    return change


def _goal_off_the_map(doc: dict[str, Any]) -> None:
    """The task, renamed with an apostrophe, needs a region beyond the state bounds."""
    doc["tasks"] = {"south's_goal": doc["tasks"]["meet"]}
    doc["regions"]["Goal"] = {"box": [[7, 8], [1, 3]]}


def _many_agents(doc: dict[str, Any]) -> None:
    """30 ground robots and count 15: C(30, 15) = 155 million groups to enumerate (valid for the
    selection encoding, refused for the group encoding)."""
    robot = doc["agents"][0]
    doc["agents"] = [{**robot, "name": f"r{i}"} for i in range(30)]
    doc["tasks"]["meet"]["count"] = 15
    doc.pop("separation")


def test_the_catalogue_counts_at_least_40_distinct_mistakes() -> None:
    # distinct: no two cases expect the same exit code and message fragments
    expected = {(code, fragments) for _, code, fragments in CASES.values()}
    assert len(expected) == len(CASES)
    assert len(expected) >= 40


@pytest.mark.parametrize("name", list(CASES))
def test_mistake_gets_its_exit_code_and_one_clear_message(name: str, tmp_path: Path) -> None:
    make_args, code, fragments = CASES[name]
    args = make_args(tmp_path)
    exit_code, output = run_cli(*args)
    assert exit_code == code, output
    for fragment in fragments:
        assert fragment in output, f"{fragment!r} not in {output!r}"
    assert "Traceback" not in output
    assert "internal error" not in output
    if code == EXIT_BAD_INPUT:  # "error: <file>: ..." - the message starts with the file
        assert re.search(r"error: \S+: ", output), output
        assert output.count("error: ") - output.count("syntax error: ") == 1, output


def test_bad_input_never_creates_the_output_directory_contents(tmp_path: Path) -> None:
    """A failed solve leaves the output directory as it was: no staging folder, no new file."""
    out = tmp_path / "plan"
    out.mkdir()
    (out / "keep.txt").write_text("from an earlier run")
    bad = _text_file(tmp_path, "bad.yaml", "name: x\nhorizon: eight\n")
    code, output = run_cli("solve", str(bad), "--out", str(out), "-q")
    assert code == EXIT_BAD_INPUT, output
    assert sorted(p.name for p in out.iterdir()) == ["keep.txt"]
    assert (out / "keep.txt").read_text() == "from an earlier run"


def test_a_write_failing_half_way_leaves_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An output (timeline.png) cannot be written: no file of the plan is left behind."""
    import stlplan.outputs.plots

    def disk_full(*args: object, **kwargs: object) -> None:
        raise OSError(28, "No space left on device", str(args[3]))

    monkeypatch.setattr(stlplan.outputs.plots, "plot_timeline", disk_full)
    out = tmp_path / "plan"
    code, output = run_cli("solve", str(PAIR), "--out", str(out), "-q")
    assert code == EXIT_USAGE, output
    assert "No space left on device" in output and "timeline.png" in output
    assert "Traceback" not in output and "internal error" not in output
    assert list(out.iterdir()) == []
