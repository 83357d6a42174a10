"""Reading team trajectories from CSV (:mod:`stlplan.outputs.trajio` writes them).

The reader also takes trajectories from other tools: the step column may be named ``k``, ``t`` or
``step`` (integer values, ``3.0`` included); the inputs may be left out (the monitor then checks
the dynamics on the states only); and when every task and constraint reads positions only, the
state columns may be the position components alone (``x0``, ``x1`` for ``position: [0, 1]``, or
``x``, ``y``). A header that would shift cells (spaces after the commas, another separator,
a column named twice), a row with more cells than the header, and text in a state or input cell
that is not read (an input at ``k = H``, a component past the agent's own) are refused with the
line; a number there is ignored.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from stlplan.errors import TrajectoryError
from stlplan.mission.problem import AgentModel, Problem
from stlplan.mission.yamldoc import decode_utf8
from stlplan.monitor.verdicts import non_position_reads
from stlplan.outputs.trajio import columns
from stlplan.result import Known, Trajectory

TIME_COLUMNS = ("k", "t", "step")
"""Accepted names of the step column."""


@dataclass(frozen=True)
class Layout:
    """Which columns of a trajectory CSV hold what.

    ``state[agent]`` lists ``(component, column)`` pairs read for the agent's state (every
    component, or its two position components only), ``inputs`` tells whether ``u0..`` are read.
    """

    time: str
    known: Known
    state: dict[str, list[tuple[int, str]]]
    inputs: bool


def _header_mistake(fields: list[str]) -> str | None:
    """What is wrong with a header that would shift cells, or None."""
    if len(fields) == 1 and any(sep in fields[0] for sep in ";\t|"):
        sep = next(sep for sep in ";\t|" if sep in fields[0])
        return f"the header is separated by {sep!r}, expected commas (agent,k,x0,...)"
    spaced = [f for f in fields if f != f.strip()]
    if spaced:
        return (
            f"column name {spaced[0]!r} has spaces around it; write the header without spaces "
            "after the commas (agent,k,x0,...)"
        )
    twice = [f for f in dict.fromkeys(fields) if fields.count(f) > 1]
    if twice:
        places = [str(i + 1) for i, f in enumerate(fields) if f == twice[0]]
        return f"column {twice[0]!r} appears more than once (columns {', '.join(places)})"
    return None


def _time_column(fields: list[str]) -> str | None:
    found = [c for c in TIME_COLUMNS if c in fields]
    return found[0] if len(found) == 1 else None


def _known(problem: Problem, fields: list[str]) -> tuple[Known, bool] | str:
    """What the header gives (and whether positions come as ``x``, ``y``), or what is missing."""
    n = max(a.n for a in problem.agents)
    m = max(a.m for a in problem.agents)
    present = {i for i in range(n) if f"x{i}" in fields}
    inputs = [f"u{i}" for i in range(m)]
    if len(present) == n:
        given = [u for u in inputs if u in fields]
        if 0 < len(given) < m:
            return f"missing column(s) {', '.join(u for u in inputs if u not in fields)}"
        return ("inputs" if given else "states"), False
    positions = {i for a in problem.agents for i in a.position}
    if present == positions or (not present and "x" in fields and "y" in fields):
        return "positions", not present
    missing = ", ".join(f"x{i}" for i in range(n) if i not in present)
    return f"missing column(s) {missing}"


def header_layout(problem: Problem, fields: list[str]) -> Layout | str:
    """The layout a header describes, or what is wrong with it (a message)."""
    wanted = ", ".join(columns(problem))
    mistake = _header_mistake(fields)
    if mistake:
        return mistake
    time = _time_column(fields)
    if time is None:
        given = [c for c in TIME_COLUMNS if c in fields]
        what = "two step columns " + " and ".join(given) if given else "no step column"
        return f"{what}; expected exactly one of k, t or step (the columns {wanted})"
    if "agent" not in fields:
        return f"missing column(s) agent; expected the columns {wanted}"
    known = _known(problem, fields)
    if isinstance(known, str):
        return f"{known}; expected the columns {wanted} (inputs u.. may be left out)"
    kind, xy = known
    if kind == "positions":
        reads = non_position_reads(problem)
        if reads:
            return (
                f"only the position columns are given, but {reads[0]} reads another state "
                f"component; expected the columns {wanted}"
            )
    state = {
        a.name: [(i, ("x", "y")[j] if xy else f"x{i}") for j, i in enumerate(a.position)]
        if kind == "positions"
        else [(i, f"x{i}") for i in range(a.n)]
        for a in problem.agents
    }
    return Layout(time, kind, state, kind == "inputs")


class _Reader:
    """Collects the cells of one trajectory file, failing with the file and line."""

    def __init__(self, problem: Problem, path: Path, through: int | None = None):
        self.problem = problem
        self.path = path
        self.H = problem.horizon
        self.through = self.H if through is None else through
        """The last step read: later rows are ignored, and inputs are optional when it is set."""
        self.optional_inputs = through is not None
        self.states = {a.name: np.full((self.H + 1, a.n), np.nan) for a in problem.agents}
        self.inputs = {a.name: np.full((self.H, a.m), np.nan) for a in problem.agents}
        self.seen: dict[tuple[str, int], int] = {}
        self.layout = Layout("k", "inputs", {}, True)
        self.width = 0

    def fail(self, line: int, message: str) -> TrajectoryError:
        return TrajectoryError(message, source=str(self.path), where=f"line {line}")

    def header(self, fields: list[str] | None) -> None:
        if not fields:
            raise self.fail(
                1, "empty file: expected a header line " + ", ".join(columns(self.problem))
            )
        layout = header_layout(self.problem, fields)
        if isinstance(layout, str):
            raise self.fail(1, layout)
        self.layout, self.width = layout, len(fields)

    def row(self, line: int, row: dict[str | None, Any]) -> None:
        extra = row.get(None)
        if extra:
            raise self.fail(
                line,
                f"{self.width + len(extra)} cells, but the header has {self.width} columns; "
                "expected one cell per column (a decimal comma, or a ',' inside a cell?)",
            )
        name = (row.get("agent") or "").strip()
        if not name:
            raise self.fail(line, "column agent: expected an agent name, found an empty cell")
        if name not in self.states:
            known = ", ".join(a.name for a in self.problem.agents)
            raise self.fail(line, f"unknown agent {_cell(name)}; agents of the mission: {known}")
        k = self._step(line, row.get(self.layout.time))
        if (name, k) in self.seen:
            raise self.fail(
                line,
                f"duplicate row for agent '{name}' at step {k} (first at line "
                f"{self.seen[name, k]}); expected one row per agent and step",
            )
        self.seen[name, k] = line
        if k > self.through:
            return
        agent = self.problem.agent(name)
        for i, column in self.layout.state[name]:
            self.states[name][k, i] = self._number(line, row, column, agent, k)
        if k < self.H and self.layout.inputs:
            for i in range(agent.m):
                self.inputs[name][k, i] = self._number(line, row, f"u{i}", agent, k)
        self._unread(line, row, agent, k)

    def _unread(self, line: int, row: dict[str | None, Any], agent: AgentModel, k: int) -> None:
        """The x and u cells a row has but its agent and step do not use must be empty (or
        numbers, ignored): no input at ``k = H``, none past the agent's own dimensions."""
        read = {column for _, column in self.layout.state[agent.name]}
        if k < self.H and self.layout.inputs:
            read |= {f"u{i}" for i in range(agent.m)}
        for column in [c for c in row if isinstance(c, str) and c not in read]:
            text = (row[column] or "").strip()
            if not _is_state_or_input(column) or not text or _finite(text):
                continue
            why = (
                f"agent '{agent.name}' has no input at step {k} = H (inputs end at step {k - 1})"
                if column.startswith("u") and k == self.H
                else f"agent '{agent.name}' has no component {column}"
            )
            raise self.fail(
                line, f"column {column}: {why}; expected an empty cell, found {_cell(text)}"
            )

    def _step(self, line: int, text: str | None) -> int:
        text = (text or "").strip()
        try:
            value = float(text)
        except ValueError:
            value = -1.0
        if not (value.is_integer() and 0 <= value <= self.H):
            shown = _cell(text) if text else "an empty cell"
            raise self.fail(
                line,
                f"column {self.layout.time}: expected an integer step in 0..{self.H}, "
                f"found {shown}",
            )
        return int(value)

    def _number(
        self, line: int, row: dict[str | None, Any], column: str, agent: AgentModel, k: int
    ) -> float:
        text = (row.get(column) or "").strip()
        if not text and self.optional_inputs and column.startswith("u"):
            return math.nan
        if not text:
            need = (
                f"an input at step {k} (one per step before H = {self.H})"
                if column.startswith("u")
                else f"a state value at step {k}"
            )
            raise self.fail(
                line, f"column {column}: agent '{agent.name}' needs {need}, found an empty cell"
            )
        try:
            value = float(text)
        except ValueError:
            raise self.fail(
                line, f"column {column}: expected a finite number, found {_cell(text)}"
            ) from None
        if not math.isfinite(value):
            raise self.fail(line, f"column {column}: expected a finite number, found {_cell(text)}")
        return value

    def finish(self, last_line: int) -> Trajectory:
        last = self.through
        for agent in self.problem.agents:
            steps = [k for k in range(last + 1) if (agent.name, k) not in self.seen]
            if len(steps) == last + 1:
                raise self.fail(
                    last_line,
                    f"end of file: agent '{agent.name}' has no rows; expected one row per "
                    f"step 0..{last}",
                )
            if steps:
                shown = ", ".join(map(str, steps[:5])) + (", ..." if len(steps) > 5 else "")
                raise self.fail(
                    last_line,
                    f"end of file: agent '{agent.name}' has no row for step(s) {shown}; "
                    f"expected one row per step 0..{last}",
                )
        return Trajectory(self.H, self.states, self.inputs, known=self.layout.known)


def _is_state_or_input(column: str) -> bool:
    """Whether ``column`` is a state or input column (``x0``, ``u1``)."""
    return column[:1] in ("x", "u") and column[1:].isdigit()


def _finite(text: str) -> bool:
    try:
        return math.isfinite(float(text))
    except ValueError:
        return False


def _cell(text: str, limit: int = 40) -> str:
    """A cell quoted for a message: shortened, with a hint when it spans lines."""
    shown = repr(text if len(text) <= limit else text[:limit] + "...")
    return shown + (" (a '\"' left open on an earlier line?)" if "\n" in text else "")


def read_trajectory_csv(
    problem: Problem, path: str | Path, through: int | None = None
) -> Trajectory:
    """Read a trajectory of ``problem`` written by :func:`write_trajectory_csv`, by hand or by
    another tool; its ``known`` says whether it gave the inputs, the states or the positions only.

    With ``through``, only steps ``0..through`` are read (an executed past): later rows are
    ignored, their states and inputs left NaN, and inputs may be left empty.

    Raises
    ------
    TrajectoryError
        Naming the file, the line and what was expected: missing file or columns, a header that
        would shift cells, a row longer than the header, unknown or missing agent, missing or
        duplicate step, a non-numeric or non-finite value, a missing input before step ``H``, or
        text in a cell that is not read (an input at step ``H``).
    """
    path = Path(path)
    reader = _Reader(problem, path, through)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise TrajectoryError("no such file", source=str(path)) from None
    except IsADirectoryError:
        raise TrajectoryError("is a directory, expected a CSV file", source=str(path)) from None
    except OSError as exc:
        reason = (exc.strerror or str(exc)).lower()
        raise TrajectoryError(
            f"cannot read the file ({reason}); expected a readable trajectory CSV file",
            source=str(path),
        ) from None
    text = decode_utf8(raw, str(path), TrajectoryError, "a trajectory CSV file")
    table = csv.DictReader(io.StringIO(text, newline=""))
    try:
        reader.header(list(table.fieldnames) if table.fieldnames else None)
        for row in table:
            reader.row(table.line_num, row)
    except csv.Error as exc:
        if "field larger than field limit" in str(exc):
            raise _long_cell(reader, text, table.line_num) from None
        raise reader.fail(table.line_num, f"not a readable CSV file: {exc}") from None
    return reader.finish(table.line_num)


def _long_cell(reader: _Reader, text: str, after: int) -> TrajectoryError:
    """The error for a cell longer than the csv module reads, at the line that holds it (the
    reader's count stops at the line before)."""
    limit = csv.field_size_limit()
    lines = text.splitlines()
    line = next((i for i, t in enumerate(lines[after:], after + 1) if len(t) > limit), after + 1)
    return reader.fail(
        line,
        f"a cell longer than {limit} characters; expected one number per cell "
        "(agent, k, then the state and input components)",
    )
