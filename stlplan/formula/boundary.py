"""Boundaries of regions: when a predicate holds (DESIGN 2.10).

A predicate ``alpha(x) >= 0`` and its negation ``-alpha(x) >= 0`` both hold on the boundary
``alpha(x) = 0``, so "in R and not in R" would be satisfiable on the edge of ``R``, and a plan that
sits exactly on an edge is scored a rounding error below 0 by an outside monitor. stlplan closes
the boundary with one margin:

* the planner enforces every predicate it relies on with ``alpha(x) - r >= 0`` where the spatial
  margin ``r`` is at least :data:`EPSILON` (see :func:`required_margin`), in step 1, step 2, the
  lazy requirements and the requirements on segments between steps;
* the monitor counts a predicate, and hence a formula, as satisfied iff its robustness is at least
  :data:`HOLDS_AT` ``= EPSILON / 2``: below what the planner enforces by more than HiGHS's
  feasibility tolerance (``1e-7``), so round-off never flips the verdict of a plan, and above 0, so
  ``mu`` and ``!mu`` never both hold (their robustness values are opposite).

Robustness values are reported as computed; only the verdict reads the threshold.
"""

from __future__ import annotations

from typing import Any

import numpy as np

EPSILON = 1e-6
"""Smallest margin with which the planner enforces a predicate (above HiGHS's ``1e-7`` tolerance)."""

HOLDS_AT = EPSILON / 2
"""A predicate (or formula) holds iff its robustness is at least this value."""


def required_margin(minimum: float) -> float:
    """The margin ``r`` the planner enforces: the mission's ``minimum``, at least :data:`EPSILON`."""
    return max(float(minimum), EPSILON)


def holds(robustness: Any, slack: float = 0.0) -> Any:
    """Whether a robustness value (or each of an array's values) means satisfied:
    ``>= HOLDS_AT - slack``.

    ``slack`` is 0 for plans; a user who checks a rounded trajectory may allow some (then a point
    on a region's edge can count as inside and outside). NaN never holds.
    """
    if isinstance(robustness, np.ndarray):
        return robustness >= HOLDS_AT - slack
    return bool(robustness >= HOLDS_AT - slack)
