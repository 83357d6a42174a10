"""Whether a polytope region ``{z : G z <= h}`` of the plane has an interior.

The Chebyshev centre LP ``max t  s.t.  g_i . z + ||g_i|| t <= h_i,  t <= 1`` has an optimum
``t* > 0`` exactly when some point satisfies every inequality strictly; ``t* <= 0`` (or an
infeasible LP) means the region is empty or flat. The LP has three variables and is solved
with HiGHS directly (its plain solver object, which prints nothing).
"""

from __future__ import annotations

import highspy
import numpy as np

INTERIOR_TOLERANCE = 1e-9
"""Radius below which a region counts as having no interior."""


def has_interior(G: list[tuple[float, float]], h: list[float]) -> bool:
    """True when some point ``z`` satisfies ``G z < h`` row by row."""
    rows = np.asarray(G, dtype=float).reshape(-1, 2)
    rhs = np.asarray(h, dtype=float)
    norms = np.hypot(rows[:, 0], rows[:, 1])
    lp = highspy._Highs()  # type: ignore[attr-defined]  # plain solver: no banner on stdout
    lp.setOptionValue("output_flag", False)
    inf = highspy.kHighsInf
    lp.addVars(3, np.array([-inf, -inf, -inf]), np.array([inf, inf, 1.0]))
    lp.changeColCost(2, -1.0)  # maximize t
    for g, norm, b in zip(rows, norms, rhs, strict=True):
        lp.addRow(-inf, float(b), 3, np.arange(3, dtype=np.int32), np.array([*g, norm]))
    lp.run()
    status = lp.getModelStatus()
    if status == highspy.HighsModelStatus.kInfeasible:
        return False
    if status != highspy.HighsModelStatus.kOptimal:  # undecided: leave it to the planner
        return True
    return bool(lp.getInfo().objective_function_value < -INTERIOR_TOLERANCE)
