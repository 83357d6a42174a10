"""A hand-built plan of the farm (paper Case I) and the monitor's verdicts on it, for figures."""

from __future__ import annotations

import numpy as np

from stlplan.mission.problem import Problem
from stlplan.result import MonitorReport, Trajectory, Verdict

# Waypoints (x, y) per step 0..9, shaped like the paper's Case I plan: two UV+IR formations
# traverse B from B_start to B_end, uv3 visits A1 (steps 3-5) then A2 (steps 7-9), vis1 and vis2
# reach C below the obstacle and stay there together from step 3 to step 9.
_B_X = [None, 1.0, 1.75, 2.65, 3.55, 4.45, 5.35, 6.1, 6.25, 6.25]
WAYPOINTS = {
    "uv1": [(0.2, 4.8)] + [(x, 4.5) for x in _B_X[1:]],
    "ir1": [(0.2, 4.5)] + [(x, 4.35) for x in _B_X[1:]],
    "uv2": [(0.5, 4.8)] + [(x, 4.2) for x in _B_X[1:]],
    "ir2": [(0.5, 4.5)] + [(x, 4.05) for x in _B_X[1:]],
    "uv3": [
        (0.8, 4.8),
        (0.9, 3.8),
        (1.0, 2.5),
        (1.0, 1.2),
        (1.0, 1.0),
        (1.1, 0.9),
        (1.8, 0.8),
        (2.5, 0.8),
        (2.5, 0.8),
        (2.5, 0.8),
    ],
    "vis1": [(0.8, 4.5), (1.8, 3.4), (3.3, 1.3), (4.8, 1.2)] + [(5.0, 1.3)] * 6,
    "vis2": [(0.2, 4.2), (1.3, 3.3), (3.0, 1.1), (4.7, 1.0)] + [(5.2, 1.0)] * 6,
    "vis3": [(0.5, 4.2), (0.6, 3.8), (0.7, 3.5)] + [(0.7, 3.5)] * 7,
}


def make_trajectory(problem: Problem) -> Trajectory:
    """States [z, v] with v(k) = z(k+1) - z(k) and inputs v(k+1) - v(k), from the waypoints."""
    states, inputs = {}, {}
    for agent in problem.agents:
        z = np.array(WAYPOINTS[agent.name], dtype=float)
        v = np.vstack([np.diff(z, axis=0), np.zeros((1, 2))])
        states[agent.name] = np.hstack([z, v])
        inputs[agent.name] = np.diff(v, axis=0)
    return Trajectory(problem.horizon, states, inputs)


def make_report() -> MonitorReport:
    """Verdicts as the monitor would give them for the waypoints above."""
    return MonitorReport(
        (
            Verdict("crop_A1", "task", True, 0.3, group=(("uv3",),)),
            Verdict("crop_A2", "task", True, 0.3, group=(("uv3",),)),
            Verdict("crop_B", "task", True, 0.05, group=(("uv1", "ir1"), ("uv2", "ir2"))),
            Verdict(
                "crop_C",
                "synchronous",
                True,
                0.2,
                group=(("vis1",), ("vis2",)),
                rho_s=5.0,
                run_start=3,
                run_length=7,
            ),
            Verdict("avoid_obstacle", "constraint", True, 0.2),
            Verdict("separation", "separation", True, 0.1),
        )
    )


def make_replan(
    problem: Problem, step: int, lost: tuple[str, ...] = (), closed: tuple[str, ...] = ()
) -> tuple[Problem, Trajectory]:
    """The hand-built plan replanned from ``step``, without a solve: the problem
    :func:`~stlplan.mission.past.replanned` makes of it (its velocities clipped to their bounds,
    the waypoints unchanged) and a new plan that is the rest of the waypoints, each lost agent
    staying where it was at ``step``."""
    from stlplan.mission.past import replanned

    executed = make_trajectory(problem)
    for agent in problem.agents:
        x = executed.states[agent.name]
        x[:, 2:] = np.clip(x[:, 2:], agent.state_lo[2:], agent.state_hi[2:])
    again = replanned(problem, executed, step, lost, closed)
    states = {name: x.copy() for name, x in executed.states.items()}
    inputs = {name: u.copy() for name, u in executed.inputs.items()}
    for name in lost:
        states[name][step:] = states[name][step]
        inputs[name][step:] = 0.0
    return again, Trajectory(problem.horizon, states, inputs)
