"""Team trajectories as CSV: one row per agent and step.

Columns: ``agent``, ``k``, ``x0 .. x{n-1}`` (state), ``u0 .. u{m-1}`` (input), where ``n`` and
``m`` are the largest state and input dimensions of the team. Agents with fewer components leave
the extra cells empty, and every ``u`` cell is empty at ``k = H`` (there is no input ``u(H)``).
Numbers are written with ``repr`` precision, so a written trajectory reads back bit for bit.
Further columns may follow; the reader ignores them.
"""

from __future__ import annotations

import csv
import io
import math
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from stlplan.errors import TrajectoryError
from stlplan.mission.problem import AgentModel, Problem
from stlplan.mission.yamldoc import decode_utf8
from stlplan.result import Trajectory


def columns(problem: Problem) -> list[str]:
    """The header: ``agent``, ``k``, ``x0..x{n-1}``, ``u0..u{m-1}`` for the widest agent."""
    n = max(a.n for a in problem.agents)
    m = max(a.m for a in problem.agents)
    return ["agent", "k", *(f"x{i}" for i in range(n)), *(f"u{i}" for i in range(m))]


def _rows(problem: Problem, trajectory: Trajectory, width: int) -> Iterator[list[str]]:
    H = trajectory.horizon
    n_max = max(a.n for a in problem.agents)
    for agent in problem.agents:
        x = np.asarray(trajectory.states[agent.name], dtype=float)
        u = np.asarray(trajectory.inputs[agent.name], dtype=float)
        for k in range(H + 1):
            row = [agent.name, str(k), *(repr(float(v)) for v in x[k])]
            row += [""] * (n_max - agent.n)
            if k < H:
                row += [repr(float(v)) for v in u[k]]
            yield row + [""] * (width - len(row))


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_trajectory_csv(problem: Problem, trajectory: Trajectory, path: str | Path) -> None:
    """Write ``trajectory`` to ``path`` atomically (a temporary file, then ``os.replace``).

    Raises
    ------
    TrajectoryError
        If the file cannot be written; ``path`` is then left as it was.
    """
    path = Path(path)
    header = columns(problem)
    try:
        fd, temp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as exc:
        raise TrajectoryError(f"cannot write the file: {exc}", source=str(path)) from None
    try:
        with os.fdopen(fd, "w", newline="", encoding="utf-8") as handle:
            writer = csv.writer(handle, lineterminator="\n")
            writer.writerow(header)
            writer.writerows(_rows(problem, trajectory, len(header)))
        os.chmod(temp, 0o666 & ~_umask())
        os.replace(temp, path)
    except BaseException as exc:
        Path(temp).unlink(missing_ok=True)
        if isinstance(exc, OSError):
            raise TrajectoryError(f"cannot write the file: {exc}", source=str(path)) from None
        raise


class _Reader:
    """Collects the cells of one trajectory file, failing with the file and line."""

    def __init__(self, problem: Problem, path: Path):
        self.problem = problem
        self.path = path
        self.H = problem.horizon
        self.states = {a.name: np.full((self.H + 1, a.n), np.nan) for a in problem.agents}
        self.inputs = {a.name: np.full((self.H, a.m), np.nan) for a in problem.agents}
        self.seen: dict[tuple[str, int], int] = {}

    def fail(self, line: int, message: str) -> TrajectoryError:
        return TrajectoryError(message, source=str(self.path), where=f"line {line}")

    def header(self, fields: list[str] | None) -> None:
        if not fields:
            raise self.fail(1, "empty file: expected a header line " + ", ".join(self._wanted()))
        missing = [c for c in self._wanted() if c not in fields]
        if missing:
            raise self.fail(
                1,
                f"missing column(s) {', '.join(missing)}; expected the columns "
                f"{', '.join(self._wanted())}",
            )

    def _wanted(self) -> list[str]:
        return columns(self.problem)

    def row(self, line: int, row: dict[str, str | None]) -> None:
        name = (row.get("agent") or "").strip()
        if not name:
            raise self.fail(line, "column agent: expected an agent name, found an empty cell")
        if name not in self.states:
            known = ", ".join(a.name for a in self.problem.agents)
            raise self.fail(line, f"unknown agent {_cell(name)}; agents of the mission: {known}")
        k = self._step(line, row.get("k"))
        if (name, k) in self.seen:
            raise self.fail(
                line,
                f"duplicate row for agent '{name}' at step {k} (first at line "
                f"{self.seen[name, k]}); expected one row per agent and step",
            )
        self.seen[name, k] = line
        agent = self.problem.agent(name)
        for i in range(agent.n):
            self.states[name][k, i] = self._number(line, row, f"x{i}", agent, k)
        if k < self.H:
            for i in range(agent.m):
                self.inputs[name][k, i] = self._number(line, row, f"u{i}", agent, k)

    def _step(self, line: int, text: str | None) -> int:
        text = (text or "").strip()
        if not (text.isascii() and text.isdigit()) or int(text) > self.H:
            shown = _cell(text) if text else "an empty cell"
            raise self.fail(
                line, f"column k: expected an integer step in 0..{self.H}, found {shown}"
            )
        return int(text)

    def _number(
        self, line: int, row: dict[str, str | None], column: str, agent: AgentModel, k: int
    ) -> float:
        text = (row.get(column) or "").strip()
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
        for agent in self.problem.agents:
            steps = [k for k in range(self.H + 1) if (agent.name, k) not in self.seen]
            if len(steps) == self.H + 1:
                raise self.fail(
                    last_line,
                    f"end of file: agent '{agent.name}' has no rows; expected one row per "
                    f"step 0..{self.H}",
                )
            if steps:
                shown = ", ".join(map(str, steps[:5])) + (", ..." if len(steps) > 5 else "")
                raise self.fail(
                    last_line,
                    f"end of file: agent '{agent.name}' has no row for step(s) {shown}; "
                    f"expected one row per step 0..{self.H}",
                )
        return Trajectory(self.H, self.states, self.inputs)


def _cell(text: str, limit: int = 40) -> str:
    """A cell quoted for a message: shortened, with a hint when it spans lines."""
    shown = repr(text if len(text) <= limit else text[:limit] + "...")
    return shown + (" (a '\"' left open on an earlier line?)" if "\n" in text else "")


def read_trajectory_csv(problem: Problem, path: str | Path) -> Trajectory:
    """Read a trajectory of ``problem`` written by :func:`write_trajectory_csv` (or by hand).

    Raises
    ------
    TrajectoryError
        Naming the file, the line and what was expected: missing file or columns, unknown or
        missing agent, missing or duplicate step, a non-numeric or non-finite value, or a missing
        input before step ``H``.
    """
    path = Path(path)
    reader = _Reader(problem, path)
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
