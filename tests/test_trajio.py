"""Trajectory CSV: exact round trip, atomic writes, and one clear error per mistake."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from stlplan.errors import TrajectoryError
from stlplan.mission.problem import Problem, build_problem
from stlplan.mission.schema import Mission
from stlplan.outputs.trajio import write_trajectory_csv
from stlplan.outputs.trajread import read_trajectory_csv
from stlplan.result import Trajectory
from tests.helpers.dynamics import double_integrator

H = 3


def make_problem(constraints: dict[str, object] | None = None) -> Problem:
    """A double integrator ``ground`` (n = 4, m = 2) and a planar point ``dot`` (n = 2, m = 1)."""
    ground = double_integrator(2, ((0, 7), (0, 5)))
    dot = {
        "A": [[1, 0], [0, 1]],
        "B": [[1], [1]],
        "state_bounds": [[0, 7], [0, 5]],
        "input_bounds": [[-1, 1]],
    }
    mission = Mission.model_validate(
        {
            "name": "io",
            "horizon": H,
            "dynamics": {"ground": ground, "dot": dot},
            "agents": [
                {"name": "uv1", "dynamics": "ground", "initial_state": [0.2, 4.8, 0, 0]},
                {"name": "d", "dynamics": "dot", "initial_state": [1.0, 1.0]},
            ],
            "constraints": constraints or {},
        }
    )
    return build_problem(mission)


def make_trajectory(seed: int = 0) -> Trajectory:
    rng = np.random.default_rng(seed)
    states = {"uv1": rng.uniform(-2, 5, (H + 1, 4)), "d": rng.uniform(0, 1, (H + 1, 2))}
    states["d"][0, 0] = 0.1 + 0.2  # 0.30000000000000004 must survive
    inputs = {"uv1": rng.uniform(-2, 2, (H, 2)), "d": rng.normal(size=(H, 1)) * 1e-17}
    return Trajectory(H, states, inputs)


@pytest.fixture
def problem() -> Problem:
    return make_problem()


@pytest.fixture
def written(problem: Problem, tmp_path: Path) -> Path:
    path = tmp_path / "trajectory.csv"
    write_trajectory_csv(problem, make_trajectory(), path)
    return path


def test_round_trip_is_exact(problem: Problem, written: Path) -> None:
    original = make_trajectory()
    back = read_trajectory_csv(problem, written)
    assert back.horizon == H
    for name in ("uv1", "d"):
        assert np.array_equal(back.states[name], original.states[name])
        assert np.array_equal(back.inputs[name], original.inputs[name])


def test_layout(written: Path) -> None:
    lines = written.read_text().splitlines()
    assert lines[0] == "agent,k,x0,x1,x2,x3,u0,u1"
    assert len(lines) == 1 + 2 * (H + 1)
    uv_last = lines[1 + H].split(",")
    assert uv_last[:2] == ["uv1", str(H)] and uv_last[6:] == ["", ""]  # no u(H)
    d_first = lines[2 + H].split(",")
    assert d_first[:4] == ["d", "0", "0.30000000000000004", d_first[3]]
    assert d_first[4:6] == ["", ""] and d_first[6] != "" and d_first[7] == ""


def test_negative_zero_is_written_as_zero(problem: Problem, tmp_path: Path) -> None:
    """A solver's ``-0.0`` (a velocity at rest, an input of zero) is written ``0.0``."""
    traj = make_trajectory()
    traj.states["uv1"][1, 2:] = [-0.0, -0.0]
    traj.inputs["d"][0, 0] = -0.0
    path = tmp_path / "trajectory.csv"
    write_trajectory_csv(problem, traj, path)
    cells = [c for line in path.read_text().splitlines() for c in line.split(",")]
    assert not [c for c in cells if c.startswith("-") and float(c) == 0.0]
    assert path.read_text().splitlines()[2].split(",")[4:6] == ["0.0", "0.0"]
    back = read_trajectory_csv(problem, path)
    assert np.array_equal(back.states["uv1"], traj.states["uv1"])
    assert not np.signbit(back.inputs["d"][0, 0])


def test_write_replaces_atomically(problem: Problem, written: Path) -> None:
    write_trajectory_csv(problem, make_trajectory(seed=1), written)
    assert np.array_equal(
        read_trajectory_csv(problem, written).states["uv1"], make_trajectory(seed=1).states["uv1"]
    )
    assert sorted(p.name for p in written.parent.iterdir()) == ["trajectory.csv"]


def test_failed_write_leaves_the_old_file(
    problem: Problem, written: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    before = written.read_text()

    def broken(src: str, dst: str) -> None:
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", broken)
    with pytest.raises(TrajectoryError, match="disk full"):
        write_trajectory_csv(problem, make_trajectory(seed=2), written)
    assert written.read_text() == before
    assert sorted(p.name for p in written.parent.iterdir()) == ["trajectory.csv"]


def test_extra_columns_are_ignored(problem: Problem, written: Path) -> None:
    lines = written.read_text().splitlines()
    written.write_text("\n".join(line + ",note" for line in lines) + "\n")
    back = read_trajectory_csv(problem, written)
    assert np.array_equal(back.states["uv1"], make_trajectory().states["uv1"])


def edit(path: Path, line: int, old: str, new: str) -> None:
    """Replace ``old`` by ``new`` on 1-based ``line`` of ``path``."""
    lines = path.read_text().splitlines()
    assert old in lines[line - 1]
    lines[line - 1] = lines[line - 1].replace(old, new, 1)
    path.write_text("\n".join(lines) + "\n")


def drop(path: Path, line: int) -> None:
    lines = path.read_text().splitlines()
    del lines[line - 1]
    path.write_text("\n".join(lines) + "\n")


def cell(path: Path, line: int, column: int, value: str) -> None:
    lines = path.read_text().splitlines()
    cells = lines[line - 1].split(",")
    cells[column] = value
    lines[line - 1] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")


def read_error(problem: Problem, path: Path) -> str:
    with pytest.raises(TrajectoryError) as info:
        read_trajectory_csv(problem, path)
    return str(info.value)


def test_missing_file(problem: Problem, tmp_path: Path) -> None:
    message = read_error(problem, tmp_path / "none.csv")
    assert message == f"{tmp_path / 'none.csv'}: no such file"


def test_empty_file(problem: Problem, tmp_path: Path) -> None:
    (tmp_path / "empty.csv").write_text("")
    assert "line 1: empty file: expected a header" in read_error(problem, tmp_path / "empty.csv")


def test_missing_column(problem: Problem, written: Path) -> None:
    edit(written, 1, ",u1", ",v1")
    message = read_error(problem, written)
    assert message.startswith(f"{written}: line 1: missing column(s) u1; expected the columns")


def test_unknown_agent(problem: Problem, written: Path) -> None:
    edit(written, 3, "uv1", "uv9")
    assert "line 3: unknown agent 'uv9'; agents of the mission: uv1, d" in read_error(
        problem, written
    )


def test_missing_agent(problem: Problem, written: Path) -> None:
    for _ in range(H + 1):
        drop(written, 2 + H + 1)  # the rows of d
    message = read_error(problem, written)
    assert (
        f"line {H + 2}: end of file: agent 'd' has no rows; expected one row per step 0..{H}"
        in message
    )


def test_missing_step(problem: Problem, written: Path) -> None:
    drop(written, 3)  # uv1 at k = 1
    assert "agent 'uv1' has no row for step(s) 1; expected" in read_error(problem, written)


def test_duplicate_step(problem: Problem, written: Path) -> None:
    cell(written, 3, 1, "0")
    message = read_error(problem, written)
    assert "line 3: duplicate row for agent 'uv1' at step 0 (first at line 2)" in message


@pytest.mark.parametrize("step", ["-1", "1.5", "", str(H + 1)])
def test_bad_step(problem: Problem, written: Path, step: str) -> None:
    cell(written, 2, 1, step)
    assert f"line 2: column k: expected an integer step in 0..{H}" in read_error(problem, written)


@pytest.mark.parametrize("value", ["abc", "nan", "inf", "-Infinity"])
def test_non_numeric_or_non_finite(problem: Problem, written: Path, value: str) -> None:
    cell(written, 4, 3, value)
    message = read_error(problem, written)
    assert f"line 4: column x1: expected a finite number, found '{value}'" in message


def test_missing_state_value(problem: Problem, written: Path) -> None:
    cell(written, 7, 3, "")  # d at k = 1, x1
    assert "line 7: column x1: agent 'd' needs a state value at step 1" in read_error(
        problem, written
    )


def test_missing_input_before_the_horizon(problem: Problem, written: Path) -> None:
    cell(written, 2 + H - 1, 7, "")  # uv1 at k = H - 1, u1
    message = read_error(problem, written)
    expected = f"line {H + 1}: column u1: agent 'uv1' needs an input at step {H - 1} (one per step"
    assert expected in message


@pytest.mark.parametrize("value", ["abc", "nan", "1,5"])
def test_garbage_in_an_input_at_the_horizon_is_refused(
    problem: Problem, written: Path, value: str
) -> None:
    cell(written, 2 + H - 1 + 1, 6, f'"{value}"' if "," in value else value)  # uv1, k = H, u0
    message = read_error(problem, written)
    expected = f"line {H + 2}: column u0: agent 'uv1' has no input at step {H} = H"
    assert expected in message and f"expected an empty cell, found '{value}'" in message


def test_garbage_past_an_agents_dimensions_is_refused(problem: Problem, written: Path) -> None:
    cell(written, 3 + H, 5, "abc")  # d (n = 2) at k = 0, x3
    message = read_error(problem, written)
    assert f"line {H + 3}: column x3: agent 'd' has no component x3" in message


def test_a_number_where_no_input_is_read_is_ignored(problem: Problem, written: Path) -> None:
    cell(written, 2 + H, 6, "0.0")  # uv1, k = H, u0: another tool's last input
    back = read_trajectory_csv(problem, written)
    assert np.array_equal(back.inputs["uv1"], make_trajectory().inputs["uv1"])


# --- trajectories from other tools ---------------------------------------------------------


def _rewrite(path: Path, change: Callable[[list[list[str]]], list[list[str]]]) -> Path:
    rows = [line.split(",") for line in path.read_text().splitlines()]
    out = path.with_name("other.csv")
    out.write_text("\n".join(",".join(r) for r in change(rows)) + "\n")
    return out


def _keep(rows: list[list[str]], names: list[str]) -> list[list[str]]:
    index = [rows[0].index(n) for n in names]
    return [[r[i] for i in index] for r in rows]


@pytest.mark.parametrize("name", ["t", "step"])
def test_the_step_column_may_be_t_or_step(problem: Problem, written: Path, name: str) -> None:
    renamed = _rewrite(
        written, lambda rows: [[name if c == "k" else c for c in rows[0]], *rows[1:]]
    )
    back = read_trajectory_csv(problem, renamed)
    assert np.array_equal(back.states["uv1"], make_trajectory().states["uv1"])
    assert back.known == "inputs"


def test_integral_times_written_as_decimals_are_steps(problem: Problem, written: Path) -> None:
    decimal = _rewrite(
        written, lambda rows: [rows[0], *([r[0], r[1] + ".0", *r[2:]] for r in rows[1:])]
    )
    assert np.array_equal(
        read_trajectory_csv(problem, decimal).states["d"], make_trajectory().states["d"]
    )


def test_without_inputs_the_states_are_read(problem: Problem, written: Path) -> None:
    states = _rewrite(written, lambda rows: _keep(rows, ["agent", "k", "x0", "x1", "x2", "x3"]))
    back = read_trajectory_csv(problem, states)
    assert back.known == "states"
    assert np.array_equal(back.states["uv1"], make_trajectory().states["uv1"])
    assert np.isnan(back.inputs["uv1"]).all()


@pytest.mark.parametrize("names", [["x0", "x1"], ["x", "y"]])
def test_positions_only(problem: Problem, written: Path, names: list[str]) -> None:
    def positions(rows: list[list[str]]) -> list[list[str]]:
        kept = _keep(rows, ["agent", "k", "x0", "x1"])
        return [["agent", "k", *names], *kept[1:]]

    back = read_trajectory_csv(problem, _rewrite(written, positions))
    assert back.known == "positions"
    original = make_trajectory()
    assert np.array_equal(back.states["uv1"][:, :2], original.states["uv1"][:, :2])
    assert np.isnan(back.states["uv1"][:, 2:]).all()


def test_positions_only_are_refused_when_a_task_reads_a_velocity(tmp_path: Path) -> None:
    slow = {"formula": "G[0,3] p.x[2] <= 1", "for_each": "p", "agents": ["uv1"]}
    problem = make_problem({"slow": slow})
    path = tmp_path / "pos.csv"
    path.write_text("agent,k,x0,x1\n" + "".join(f"uv1,{k},1,1\nd,{k},1,1\n" for k in range(H + 1)))
    message = read_error(problem, path)
    assert "line 1: only the position columns are given, but slow: p.x[2] of uv1" in message


def test_a_partial_set_of_state_columns_is_refused(problem: Problem, written: Path) -> None:
    partial = _rewrite(written, lambda rows: _keep(rows, ["agent", "k", "x0", "x1", "x2"]))
    assert "line 1: missing column(s) x3; expected the columns" in read_error(problem, partial)


@pytest.mark.parametrize(
    ("header", "says"),
    [
        ("agent, k, x0, x1, x2, x3, u0, u1", "column name ' k' has spaces around it"),
        ("agent;k;x0;x1;x2;x3;u0;u1", "the header is separated by ';', expected commas"),
        ("agent,k,x0,x1,x2,x2,u0,u1", "column 'x2' appears more than once (columns 5, 6)"),
        ("agent,time,x0,x1,x2,x3,u0,u1", "no step column; expected exactly one of k, t or step"),
        ("agent,k,t,x0,x1,x2,x3,u0", "two step columns k and t"),
    ],
)
def test_header_mistakes_are_refused_with_a_hint(
    problem: Problem, written: Path, header: str, says: str
) -> None:
    lines = written.read_text().splitlines()
    written.write_text("\n".join([header, *lines[1:]]) + "\n")
    assert f"{written}: line 1: {says}" in read_error(problem, written)


def test_a_row_longer_than_the_header_is_refused(problem: Problem, written: Path) -> None:
    edit(written, 4, "uv1,2,", "uv1,2,0,")  # a decimal comma shifts every later cell
    message = read_error(problem, written)
    assert "line 4: 9 cells, but the header has 8 columns; expected one cell per column" in message
