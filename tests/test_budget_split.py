"""The run's time shared out (stlplan.planner.run.budget.Budget), on a clock the tests move."""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest

from stlplan import api
from stlplan.planner.config import PlannerConfig
from stlplan.planner.run.budget import Budget
from tests.helpers.paths import MISSIONS


@pytest.fixture
def now(monkeypatch: pytest.MonkeyPatch) -> list[float]:
    """A clock at 0 s that the test moves by setting ``now[0]``."""
    clock = [0.0]
    monkeypatch.setattr(time, "perf_counter", lambda: clock[0])
    return clock


def test_a_run_budget_has_the_limit_and_its_grace(now: list[float]) -> None:
    config = PlannerConfig().with_overrides({"solver.time_limit": 50.0})
    run = Budget.for_run(config)
    assert (run.deadline, run.grace_end) == (50.0, 55.0)  # a tenth of the limit
    long = Budget.for_run(config.with_overrides({"solver.time_limit": 600.0}))
    assert long.grace_end - long.deadline == 10.0  # at most ten seconds
    assert Budget.for_run(config, deadline=20.0).deadline == 20.0


def test_shares_and_seconds_never_end_after_their_parent(now: list[float]) -> None:
    run = Budget(100.0, 110.0)
    now[0] = 20.0
    assert run.share(0.25).deadline == pytest.approx(40.0)
    assert run.seconds(30).deadline == 50.0
    assert run.seconds(1000).deadline == 100.0
    assert run.share(0.5).finishing().deadline == 110.0  # the run's grace, not the share's
    assert run.finishing().seconds(60).deadline == 80.0


def test_split_carries_unspent_time_to_the_next_piece_and_keeps_the_reserve(
    now: list[float],
) -> None:
    pieces = Budget(100.0, 100.0).split(3, reserve=0.1)
    first = next(pieces)
    assert first.remaining() == pytest.approx(30.0)  # (100 - 10) / 3
    now[0] = 10.0  # the first piece used 10 of its 30 s
    second = next(pieces)
    assert second.remaining() == pytest.approx(40.0)  # (90 - 10) / 2
    now[0] = 50.0
    assert next(pieces).deadline == pytest.approx(90.0)  # the reserve is kept


def test_a_spent_budget_expires_but_still_allows_one_least_solve(now: list[float]) -> None:
    budget = Budget(10.0, 10.0, min_solve=1.0)
    now[0] = 9.5
    assert budget.expired() and budget.limit() == 1.0
    now[0] = 5.0
    assert not budget.expired() and budget.limit() == 5.0


def test_every_budget_of_a_run_writes_one_ledger(now: list[float]) -> None:
    run = Budget(100.0, 100.0)
    with run.share(0.5).stage("step 1"):
        now[0] = 3.0
    with run.finishing().stage("continuous"):
        now[0] = 4.5
    assert run.ledger == {"step 1": 3.0, "continuous": 1.5}


def test_the_summary_records_the_time_of_each_stage(tmp_path: Path) -> None:
    api.solve(MISSIONS / "sync-pair.yaml", tmp_path, api.Overrides(time_limit=60), animation=False)
    summary = json.loads((tmp_path / "summary.json").read_text())
    stages = summary["stage_seconds"]
    assert {"step 1", "continuous", "verify"} <= set(stages)
    assert all(seconds >= 0 for seconds in stages.values())
    assert sum(stages.values()) <= summary["build_seconds"] + summary["solve_seconds"] + 1.0
