"""Dynamics tables of the test missions, written as a mission file writes them."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

PLANE = ((-5, 5), (-5, 5))
"""The default workspace of the tables below: ``[-5, 5]^2``."""


def single_integrator(
    u_max: float, state_bounds: Sequence[Sequence[float]] = PLANE
) -> dict[str, Any]:
    """``x(k+1) = x(k) + u(k)`` on the plane (the state is the position), ``|u_j| <= u_max``."""
    return {
        "A": [[1, 0], [0, 1]],
        "B": [[1, 0], [0, 1]],
        "state_bounds": [list(b) for b in state_bounds],
        "input_bounds": [[-u_max, u_max], [-u_max, u_max]],
    }


def double_integrator(
    u_max: float, position_bounds: Sequence[Sequence[float]] = PLANE, v_max: float = 2
) -> dict[str, Any]:
    """State ``[p, v]`` on the plane: ``p(k+1) = p + v + u/2``, ``v(k+1) = v + u``;
    ``|v_j| <= v_max``, ``|u_j| <= u_max``."""
    return {
        "A": [[1, 0, 1, 0], [0, 1, 0, 1], [0, 0, 1, 0], [0, 0, 0, 1]],
        "B": [[0.5, 0], [0, 0.5], [1, 0], [0, 1]],
        "state_bounds": [*(list(b) for b in position_bounds), [-v_max, v_max], [-v_max, v_max]],
        "input_bounds": [[-u_max, u_max], [-u_max, u_max]],
    }


SINGLE_INTEGRATOR_U1 = single_integrator(1)
"""Single integrator on ``[-5, 5]^2``, ``|u| <= 1`` per axis."""

SINGLE_INTEGRATOR_U2 = single_integrator(2)
"""Single integrator on ``[-5, 5]^2``, ``|u| <= 2`` per axis."""

DOUBLE_INTEGRATOR_U2 = double_integrator(2)
"""Double integrator on ``[-5, 5]^2``, ``|v| <= 2`` and ``|u| <= 2`` per axis."""

DOUBLE_INTEGRATOR_U1 = double_integrator(1, ((-1, 10), (-1, 10)))
"""Double integrator on ``[-1, 10]^2``, ``|v| <= 2`` and ``|u| <= 1`` per axis."""
