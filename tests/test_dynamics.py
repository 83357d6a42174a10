"""The physical checks: with inputs, on the states only, on positions only, with a tolerance."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from stlplan.mission.problem import Problem, build_problem
from stlplan.mission.schema import Mission
from stlplan.monitor.dynamics import recovered_inputs
from stlplan.monitor.verdicts import check
from stlplan.result import Trajectory

H = 6
A = np.array([[1, 0, 1, 0], [0, 1, 0, 1], [0, 0, 1, 0], [0, 0, 0, 1]], dtype=float)
B = np.array([[0.5, 0], [0, 0.5], [1, 0], [0, 1]])
START = np.array([0.2, 4.8, 0.0, 0.0])


def make_problem() -> Problem:
    """One double integrator on a 7 x 5 map, inputs in [-2, 2]."""
    ground = {
        "A": A.tolist(),
        "B": B.tolist(),
        "state_bounds": [[0, 7], [0, 5], [-2, 2], [-2, 2]],
        "input_bounds": [[-2, 2], [-2, 2]],
    }
    mission = Mission.model_validate(
        {
            "name": "dyn",
            "horizon": H,
            "dynamics": {"ground": ground},
            "agents": [{"name": "r", "dynamics": "ground", "initial_state": START.tolist()}],
        }
    )
    return build_problem(mission)


def rollout(inputs: np.ndarray) -> Trajectory:
    """The exact trajectory of ``x(k+1) = A x(k) + B u(k)`` from START."""
    x = [START]
    for u in inputs:
        x.append(A @ x[-1] + B @ u)
    return Trajectory(H, {"r": np.array(x)}, {"r": np.asarray(inputs, dtype=float)})


INPUTS = np.array([[2, -2], [-0.37, 1.13], [-1.63, 0.87], [0.3, 0.3], [1 / 3, -1 / 7], [0, 0]])


def verdict(traj: Trajectory, tol: float = 1e-6) -> tuple[bool, str]:
    found = check(make_problem(), traj, tol=tol).verdict("dynamics r")
    return found.satisfied, found.detail


def rounded(traj: Trajectory, decimals: int) -> Trajectory:
    return Trajectory(
        H,
        {"r": np.round(traj.states["r"], decimals)},
        {"r": np.round(traj.inputs["r"], decimals)},
        traj.known,
    )


def test_an_exact_rollout_holds_and_a_rounded_one_needs_the_tolerance() -> None:
    exact = rollout(INPUTS)
    assert verdict(exact)[0]
    coarse = rounded(exact, 3)
    assert not verdict(coarse)[0]  # 3 decimals are far beyond solver round-off
    assert verdict(coarse, tol=1e-3)[0]
    assert not verdict(rounded(exact, 1), tol=1e-3)[0]  # 1 decimal is not


def test_states_only_recover_the_inputs() -> None:
    exact = rollout(INPUTS)
    states = dataclasses.replace(exact, inputs={"r": np.full((H, 2), np.nan)}, known="states")
    assert np.allclose(recovered_inputs(make_problem().agents[0], states.states["r"]), INPUTS)
    held, detail = verdict(states)
    assert held and "x(k+1) - A x(k) = B u(k) with u(k) in bounds" in detail
    assert verdict(dataclasses.replace(rounded(exact, 3), known="states"), tol=1e-3)[0]


def test_states_only_refuse_an_input_beyond_its_bounds() -> None:
    fast = INPUTS.copy()
    fast[3] = [2.5, 0]  # the rollout itself is fine, its input is not
    states = dataclasses.replace(rollout(fast), known="states")
    held, detail = verdict(states)
    assert not held
    assert "step 3: u (recovered)[0] = 2.5, expected within [-2, 2]" in detail


def test_states_only_refuse_a_jump_no_input_explains() -> None:
    states = dataclasses.replace(rollout(INPUTS), known="states")
    states.states["r"][4, 0] += 0.2  # position moves, velocity does not: not in the range of B
    held, detail = verdict(states)
    assert not held and "no input u(k) gives x(k+1) - A x(k)" in detail


def test_positions_only_skip_the_dynamics_but_not_the_start_or_the_map() -> None:
    x = np.full((H + 1, 4), np.nan)
    x[:, :2] = [[0.2, 4.8], [6.0, 0.5], [0.5, 0.5], [3, 3], [3, 3], [3, 3], [3, 3]]  # teleports
    jumps = Trajectory(H, {"r": x}, {"r": np.full((H, 2), np.nan)}, known="positions")
    held, detail = verdict(jumps)
    assert held and "positions only: dynamics not checked" in detail
    x[0, 0] = 0.5
    assert "x[0] = 0.5, expected the initial state 0.2" in verdict(jumps)[1]
    x[0, 0], x[3, 1] = 0.2, 5.5
    held, detail = verdict(jumps)
    assert not held and "x[1] = 5.5, expected within [0, 5]" in detail


@pytest.mark.parametrize(("offset", "held"), [(0.9e-3, True), (1.1e-3, False)])
def test_the_initial_state_may_be_off_by_the_tolerance(offset: float, held: bool) -> None:
    moved = rollout(INPUTS)
    moved.states["r"][0, 0] += offset
    assert verdict(moved, tol=1e-3)[0] is held
