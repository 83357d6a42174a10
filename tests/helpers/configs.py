"""Planner configurations the tests name."""

from __future__ import annotations

from typing import Any

from stlplan.planner.config import PlannerConfig

UP_FRONT = PlannerConfig().with_overrides(
    {"solver.time_limit": 60.0, "solver.gap": 1e-6, "lazy.enabled": False, "model.floors": False}
)
"""The reference solve: every requirement encoded up front, no floors, proven to 1e-6."""


def paper_model(**dotted: Any) -> PlannerConfig:
    """The paper's formulation (groups, every requirement up front, no floors or symmetry
    rows), with ``dotted`` overrides given as ``section__knob=value``."""
    base = {
        "lazy.enabled": False,
        "model.floors": False,
        "model.tasks": "groups",
        "model.symmetry": False,
    }
    return PlannerConfig().with_overrides(
        base | {key.replace("__", "."): value for key, value in dotted.items()}
    )
