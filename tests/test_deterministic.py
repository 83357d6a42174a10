"""A deterministic run (solver.deterministic) takes its decisions on the solver's work, not the
clock: a slower machine changes no decision."""

from __future__ import annotations

import dataclasses
from typing import Any

import pytest

from stlplan import api
from stlplan.planner.backend import session
from stlplan.planner.backend.session import WORK_RATE, Solved
from stlplan.planner.config import PlannerConfig
from stlplan.result import PlanResult
from tests.helpers.paths import MISSIONS

QUICK_REPAIRS = {"repair.after_round_seconds": 1.0, "parts.enabled": False}
"""A round of 1 s (wall or work) is repaired in turn before the next one."""


def _solve(deterministic: bool, slow: bool, monkeypatch: pytest.MonkeyPatch) -> PlanResult:
    solve = session.HighsSession.solve

    def slower(self: Any, *args: Any, **kwargs: Any) -> Solved:
        solved = solve(self, *args, **kwargs)  # a loaded machine: every solve 10 s longer
        return dataclasses.replace(solved, seconds=solved.seconds + 10.0)

    with monkeypatch.context() as patch:
        if slow:
            patch.setattr(session.HighsSession, "solve", slower)
        config = {**QUICK_REPAIRS, "solver.deterministic": deterministic}
        _, result = api.plan(MISSIONS / "warehouse.yaml", api.Overrides(config=config))
    return result


def _decisions(result: PlanResult) -> list[tuple[Any, ...]]:
    keys = ("part", "stage", "ended", "nodes", "held")
    return [tuple(str(r[k]) for k in keys) for r in result.round_log]


@pytest.mark.heavy
def test_a_loaded_machine_changes_no_decision_of_a_deterministic_run(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    quick = _solve(True, False, monkeypatch)
    slow = _solve(True, True, monkeypatch)
    assert quick.status.has_plan and slow.status.has_plan
    assert _decisions(slow) == _decisions(quick)
    assert slow.objective == quick.objective
    assert [i["stage"] for i in slow.trace["incumbents"]] == [
        i["stage"] for i in quick.trace["incumbents"]
    ]
    # the same slowness moves the decisions of a run on the clock (so the above can fail)
    clocked = _solve(False, True, monkeypatch)
    assert clocked.status.has_plan and "repair in turn" in clocked.trace["stages"]
    assert _decisions(clocked) != _decisions(slow)


def test_a_deterministic_length_is_the_solves_work() -> None:
    solved = Solved(results=None, seconds=9.0, gap=None, iterations=5_000)  # type: ignore[arg-type]
    assert solved.length(False) == 9.0
    assert solved.length(True) == pytest.approx(5_000 / WORK_RATE)
    assert Solved(None, 2.0, None).length(True) == 2.0  # type: ignore[arg-type]


def test_a_deterministic_run_uses_one_thread() -> None:
    config = PlannerConfig().with_overrides({"solver.threads": 2})
    assert config.solver.used_threads() == 2
    assert config.with_overrides({"solver.deterministic": True}).solver.used_threads() == 1
