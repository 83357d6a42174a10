"""The continuous stage holds the kept sides of the lazy requirements step 1 left out lazily."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from stlplan.mission.loader import load_problem
from stlplan.pipeline import plan
from stlplan.planner.core import kept_sides
from stlplan.planner.overrides import Overrides
from tests.helpers.paths import MISSIONS


def _first_plan(monkeypatch: pytest.MonkeyPatch, near: float | None) -> tuple[Any, list[int]]:
    """crowd-16's first plan with ``continuous.near_sides`` at ``near``, and how many sides
    each check after a continuous solve added."""
    added: list[int] = []
    broken = kept_sides.KeptSides.broken

    def spy(self: kept_sides.KeptSides, *args: Any) -> Any:
        more = broken(self, *args)
        added.append(len(more))
        return more

    monkeypatch.setattr(kept_sides.KeptSides, "broken", spy)
    problem = load_problem(MISSIONS / "crowd/crowd-16.yaml")
    overrides = Overrides(
        threads=1, time_limit=120, first_plan=True, config={"continuous.near_sides": near}
    )
    _, result = plan(problem, overrides)
    return result, added


def _effort(result: Any) -> float:
    return sum(float(np.abs(u).sum()) for u in result.trajectory.inputs.values())


@pytest.mark.heavy
def test_sides_broken_by_a_continuous_plan_are_added_until_none_is(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    none_near, added = _first_plan(monkeypatch, 0.0)
    assert added[0] > 0 and added[-1] == 0  # the first polish broke sides left out; the last none
    assert none_near.fallback is None and none_near.report.satisfied
    every, added = _first_plan(monkeypatch, None)
    assert added == [0]  # every side held from the start
    assert every.report.satisfied
    # the same step-1 plan (one thread) polished to the same optimum of the same LP
    assert none_near.objective == pytest.approx(every.objective, rel=1e-9)
    assert _effort(none_near) == pytest.approx(_effort(every), rel=1e-7)
