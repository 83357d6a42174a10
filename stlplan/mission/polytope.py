"""How far inside a polytope region ``{z : G z <= h}`` of the plane a point can lie.

The Chebyshev centre LP ``max t  s.t.  g_i . z + ||g_i|| t <= h_i,  t <= T`` gives the radius of
the largest disc inside the region (capped at ``T`` for an unbounded region): the largest
spatial margin an ``in`` requirement on the region can have. A radius of 0 or less (or an
infeasible LP) means the region is empty or flat. The LP has three variables and is solved with
HiGHS directly (its plain solver object, which prints nothing), imported only when a polytope
region is checked.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

INTERIOR_TOLERANCE = 1e-9
"""Radius below which a region counts as having no interior."""
RADIUS_CAP = 1e7
"""``T``: the radius reported for an unbounded region (ten times the largest coordinate)."""


def inscribed_radius(G: Sequence[Sequence[float]], h: Sequence[float]) -> float:
    """Radius of the largest disc inside ``{z : G z <= h}`` (-inf when the region is empty,
    ``RADIUS_CAP`` when it is unbounded, +inf when HiGHS cannot decide)."""
    import highspy  # here, so that reading a mission (and the monitor) loads no solver

    rows = np.asarray(G, dtype=float).reshape(-1, 2)
    rhs = np.asarray(h, dtype=float)
    norms = np.hypot(rows[:, 0], rows[:, 1])
    lp = highspy._Highs()  # type: ignore[attr-defined]  # plain solver: no banner on stdout
    lp.setOptionValue("output_flag", False)
    inf = highspy.kHighsInf
    lp.addVars(3, np.array([-inf, -inf, -inf]), np.array([inf, inf, RADIUS_CAP]))
    lp.changeColCost(2, -1.0)  # maximize t
    for g, norm, b in zip(rows, norms, rhs, strict=True):
        lp.addRow(-inf, float(b), 3, np.arange(3, dtype=np.int32), np.array([*g, norm]))
    lp.run()
    status = lp.getModelStatus()
    # the solve started HiGHS's process-wide thread pool with its default size; stop it, so that
    # a later solve in this process may ask for any number of threads
    highspy.Highs.resetGlobalScheduler(True)
    if status == highspy.HighsModelStatus.kInfeasible:
        return -np.inf
    if status != highspy.HighsModelStatus.kOptimal:  # undecided: leave it to the planner
        return np.inf
    return float(-lp.getInfo().objective_function_value)


def has_interior(G: Sequence[Sequence[float]], h: Sequence[float]) -> bool:
    """True when some point ``z`` satisfies ``G z < h`` row by row."""
    return inscribed_radius(G, h) > INTERIOR_TOLERANCE
