"""Team trajectories as CSV: one row per agent and step (the writer; the reader, which also
takes trajectories from other tools, is :mod:`stlplan.outputs.trajread`).

Columns: ``agent``, ``k``, ``x0 .. x{n-1}`` (state), ``u0 .. u{m-1}`` (input), where ``n`` and
``m`` are the largest state and input dimensions of the team. Agents with fewer components leave
the extra cells empty, and every ``u`` cell is empty at ``k = H`` (there is no input ``u(H)``).
Numbers are written with ``repr`` precision, so a written trajectory reads back bit for bit,
except that a negative zero (a solver's ``-0.0``) is written ``0.0``.
Further columns may follow; the reader ignores them.
"""

from __future__ import annotations

import csv
import math
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from stlplan.errors import TrajectoryError
from stlplan.mission.problem import Problem
from stlplan.result import Trajectory


def columns(problem: Problem) -> list[str]:
    """The header: ``agent``, ``k``, ``x0..x{n-1}``, ``u0..u{m-1}`` for the widest agent."""
    n = max(a.n for a in problem.agents)
    m = max(a.m for a in problem.agents)
    return ["agent", "k", *(f"x{i}" for i in range(n)), *(f"u{i}" for i in range(m))]


def csv_number(value: float) -> str:
    """``value`` as a CSV cell: ``repr`` precision, and ``0.0`` for a negative zero."""
    return repr(float(value) + 0.0)  # -0.0 + 0.0 is +0.0; every other value is unchanged


def _rows(problem: Problem, trajectory: Trajectory, width: int) -> Iterator[list[str]]:
    H = trajectory.horizon
    n_max = max(a.n for a in problem.agents)
    for agent in problem.agents:
        x = np.asarray(trajectory.states[agent.name], dtype=float)
        u = np.asarray(trajectory.inputs[agent.name], dtype=float)
        for k in range(H + 1):
            row = [agent.name, str(k), *(csv_number(v) for v in x[k])]
            row += [""] * (n_max - agent.n)
            if k < H:  # an input not known (a replan's executed past) is an empty cell
                row += [csv_number(v) if math.isfinite(v) else "" for v in u[k]]
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
