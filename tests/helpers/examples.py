"""How many examples a property test draws: few in the default profile, many when exploring.

``STLPLAN_HYPOTHESIS`` names the Hypothesis profile (tests/conftest.py registers both):
``deterministic`` (the default) draws the same examples on every run, ``explore`` draws fresh ones.
"""

from __future__ import annotations

import os

PROFILE = os.environ.get("STLPLAN_HYPOTHESIS", "deterministic")
"""The Hypothesis profile of this run."""


def examples(default: int, explore: int) -> int:
    """``default`` examples in the deterministic profile, ``explore`` in the explore profile: for
    property tests whose every example solves MILPs, which keep the default suite short."""
    return explore if PROFILE == "explore" else default
