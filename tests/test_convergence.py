"""The whole problem's incumbent and bound over step 1 (stlplan.planner.run.convergence): the
record's thinning, and on solved missions that every point is the whole problem's own figure."""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

import stlplan.planner.core.components as components_module
from stlplan import api
from stlplan.planner.backend.session import HighsSession
from stlplan.planner.config import PlannerConfig
from stlplan.planner.core.lazy import LazySolver
from stlplan.planner.run.clock import Clock
from stlplan.planner.run.convergence import THIN_SECONDS, Convergence, known
from stlplan.planner.solve import plan
from stlplan.result import ConvergencePoint, PlanResult, PlanStatus
from tests.helpers.missions import crossing_problem, sync_and_errand
from tests.helpers.paths import PAIR
from tests.helpers.solving import up_front_optimum

EXACT = PlannerConfig().with_overrides({"solver.time_limit": 60.0, "solver.gap": 1e-6})
TOL = 1e-6
"""Round-off allowed between an incumbent and a bound of the same optimum."""


# ------------------------------------------------------------------------------------ the record
def test_a_tighter_bound_alone_is_thinned_to_one_point_per_interval() -> None:
    record = Convergence()
    for n in range(40):  # a tighter bound every 0.05 s for 2 s
        record.bounded(0.05 * n, 10.0 - n)
    times = [p.at for p in record.points]
    assert len(times) <= 2.0 / THIN_SECONDS + 1
    assert all(b - a >= THIN_SECONDS - 1e-12 for a, b in zip(times, times[1:], strict=False))
    record.ended(2.5, None, None)
    assert record.points[-1] == ConvergencePoint(2.5, None, 10.0 - 39)


def test_every_point_holds_figures_known_by_its_time() -> None:
    record = Convergence()
    reported: list[tuple[float, str, float]] = []
    events = [(0.1, "b", 9.0), (0.2, "b", 8.0), (0.3, "i", 1.0), (0.35, "b", 7.5), (0.4, "i", 2.0)]
    events += [(0.5, "b", 7.0), (1.2, "b", 6.0), (1.3, "b", 5.0), (2.0, "i", 1.5)]
    for at, kind, value in events:
        reported.append((at, kind, value))
        if kind == "b":
            record.bounded(at, value)
        else:
            record.found(at, value)
    record.ended(3.0, 2.0, 5.5)
    times = [p.at for p in record.points]
    assert times == sorted(times)
    for point in record.points:  # the best of what was reported by then, never later
        bounds = [v for at, kind, v in reported if kind == "b" and at <= point.at]
        plans = [v for at, kind, v in reported if kind == "i" and at <= point.at]
        assert point.bound == min(bounds, default=None)
        assert point.incumbent == max(plans, default=None)
    incumbents = [p.incumbent for p in record.points if p.incumbent is not None]
    assert incumbents == sorted(incumbents)  # a worse plan (1.5) adds no point
    assert {1.0, 2.0} <= set(incumbents)  # every new incumbent is a point
    assert record.points[-1] == ConvergencePoint(3.0, 2.0, 5.0)  # the least bound stays


def test_a_forced_point_and_the_end_write_the_thinned_bound_first() -> None:
    record = Convergence()
    record.bounded(0.0, 5.0)
    record.bounded(0.1, 4.0)  # thinned: pending
    record.found(0.2, 1.0)
    assert [(p.at, p.bound) for p in record.points] == [(0.0, 5.0), (0.1, 4.0), (0.2, 4.0)]
    record.bounded(0.3, 4.0, force=True)  # a round's end: a point, though not tighter
    assert record.points[-1] == ConvergencePoint(0.3, 1.0, 4.0)


@pytest.mark.parametrize("value", [None, math.inf, -math.inf, math.nan, 1e30, -1e31])
def test_unknown_figures_are_never_recorded(value: float | None) -> None:
    record = Convergence()
    record.bounded(0.0, value)
    record.found(0.0, value)
    record.ended(1.0, value, value)
    assert not known(value) and record.points == []


def test_a_restart_forgets_the_incumbent_but_not_the_bound() -> None:
    record = Convergence()
    record.found(0.0, 2.0)
    record.bounded(0.0, 3.0, force=True)
    record.restart(1.0)
    assert record.points[-1] == ConvergencePoint(1.0, None, 3.0)
    record.found(1.5, 1.0)  # the strict retry's first plan, worse than the first run's
    assert record.points[-1] == ConvergencePoint(1.5, 1.0, 3.0)


def test_the_clock_records_only_a_tighter_bound_unless_forced() -> None:
    clock = Clock.started(None)
    clock.bound_found(2.0)
    clock.bound_found(3.0)
    clock.plan_found(1.0)
    assert [(p.incumbent, p.bound) for p in clock.convergence.points] == [(None, 2.0), (1.0, 2.0)]
    assert clock.first_plan is not None and clock.first_plan <= clock.convergence.points[-1].at


# ------------------------------------------------------------------------- solved missions


@pytest.fixture
def guarded(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[str]]:
    """Every bound the clock is given while a trial solve (of HiGHS or of a lazy loop) or the
    assembly of the parts runs (none may be)."""
    running: list[str] = []
    leaks: list[str] = []
    solve, assemble, rounds = HighsSession.solve_once, components_module.assemble, LazySolver.run

    def spy_run(self: HighsSession, *args: Any, **kwargs: Any) -> Any:
        running.append("trial" if self.trial else "")
        try:
            return solve(self, *args, **kwargs)
        finally:
            running.pop()

    def spy_rounds(self: LazySolver, *args: Any, trial: bool = False, **kwargs: Any) -> Any:
        running.append("trial" if trial else "")
        try:
            return rounds(self, *args, trial=trial, **kwargs)
        finally:
            running.pop()

    def spy_assemble(*args: Any, **kwargs: Any) -> Any:
        running.append("assembly")
        try:
            return assemble(*args, **kwargs)
        finally:
            running.pop()

    bound_found = Clock.bound_found

    def spy_bound(self: Clock, bound: float | None, force: bool = False) -> None:
        if any(running):
            leaks.append(f"bound {bound} in a {[r for r in running if r][-1]}")
        bound_found(self, bound, force)

    monkeypatch.setattr(HighsSession, "solve_once", spy_run)
    monkeypatch.setattr(LazySolver, "run", spy_rounds)
    monkeypatch.setattr(components_module, "assemble", spy_assemble)
    monkeypatch.setattr(Clock, "bound_found", spy_bound)
    yield leaks


def assert_honest(result: PlanResult, optimum: float) -> None:
    """Every point of ``result``'s record is a figure of the whole problem of ``optimum``."""
    points = result.convergence
    assert points, "no point recorded"
    times = [p.at for p in points]
    assert times == sorted(times) and times[0] >= 0.0
    for n, point in enumerate(points):
        if point.incumbent is not None:
            assert point.incumbent <= optimum + TOL
            later = [p.bound for p in points[n:] if p.bound is not None]
            assert all(point.incumbent <= b + TOL for b in later)
        if point.bound is not None:
            assert point.bound >= optimum - TOL
    assert points[-1].incumbent == result.objective  # the plan step 1 ends with
    assert result.bound is not None and points[-1].bound is not None
    assert points[-1].bound <= result.bound + TOL
    first = result.first_plan_seconds
    assert first is not None and first <= points[-1].at
    assert all(p.incumbent is None for p in points if p.at < first - 1e-9)


@pytest.mark.parametrize(
    ("problem", "config"),
    [
        (sync_and_errand, {}),  # parts: a part's own figures are not the whole's
        (crossing_problem, {}),  # parts merged into the whole team, repaired held first
        (crossing_problem, {"parts.enabled": False, "repair.after_round_seconds": 0.0}),
        (crossing_problem, {"lazy.enabled": False}),  # every requirement up front: HiGHS's plans
    ],
    ids=["parts", "merged", "in-turn", "direct"],
)
def test_every_point_is_the_whole_problems_own(
    problem: Any, config: dict[str, Any], guarded: list[str]
) -> None:
    mission_ = problem()
    optimum = up_front_optimum(mission_)
    assert optimum.status is PlanStatus.OPTIMAL and optimum.objective is not None
    guarded.clear()  # (the reference solve is not under test)
    result = plan(mission_, EXACT.with_overrides(config))
    assert result.status is PlanStatus.OPTIMAL
    assert guarded == []
    assert_honest(result, optimum.objective)


def test_the_trials_ran_and_would_have_leaked(guarded: list[str]) -> None:
    # the guard sees trial solves and the assembly run here (so the test above can fail)
    import stlplan.planner.backend.progress as progress

    follow = progress.follow

    def careless(highs: Any, trial: Any, recorder: Any, plans: bool) -> None:
        follow(highs, lambda: False, recorder, plans)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr("stlplan.planner.backend.session.follow", careless)
        plan(crossing_problem(), EXACT.with_overrides({"repair.after_round_seconds": 0.0}))
    assert any("trial" in leak for leak in guarded)


def test_a_strict_retry_out_of_time_ends_with_the_first_plan(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import stlplan.planner.solve as solve_module
    from stlplan.planner.core.finish import Finish
    from stlplan.planner.strategy import build_strategy

    real, calls = build_strategy(EXACT), []

    class Once:
        def solve(self, *args: object) -> object:
            pm, found = real.solve(*args)  # type: ignore[arg-type]
            calls.append(found.objective)
            if len(calls) > 1:  # the strict retry finds nothing
                found = dataclasses.replace(found, status=PlanStatus.NO_PLAN, objective=None)
            return pm, found

    monkeypatch.setattr(solve_module, "build_strategy", lambda config: Once())
    infeasible = Finish("the continuous solve ended provenInfeasible", infeasible=True)
    monkeypatch.setattr(solve_module, "finish", lambda *args: infeasible)
    result = plan(sync_and_errand(), EXACT)
    assert len(calls) == 2 and result.status.has_plan
    assert result.convergence[-1].incumbent == calls[0] == result.objective
    assert None in [p.incumbent for p in result.convergence]  # the retry started over


# ------------------------------------------------------------------------------ the outputs
def test_summary_records_the_convergence_and_the_folder_draws_it(tmp_path: Path) -> None:
    out = tmp_path / "plan"
    api.solve(PAIR, out, animation=False, viewer=False)
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    points = summary["convergence"]
    assert points and all(set(p) == {"at", "incumbent", "bound"} for p in points)
    assert points[-1]["incumbent"] == summary["solver"]["objective"]
    assert points[-1]["bound"] <= summary["bound"] + TOL
    assert (out / "convergence.png").exists()


@pytest.mark.parametrize(
    ("status", "points", "written"),
    [
        (PlanStatus.NO_PLAN, (ConvergencePoint(1.0, None, 2.0),), True),
        (PlanStatus.NO_PLAN, (), False),
        (PlanStatus.INFEASIBLE, (ConvergencePoint(1.0, None, 2.0),), False),
    ],
)
def test_without_a_plan_the_figure_needs_a_point_and_a_run_out_of_time(
    status: PlanStatus, points: tuple[ConvergencePoint, ...], written: bool, tmp_path: Path
) -> None:
    from stlplan.mission.loader import load_problem

    result = PlanResult(status, "no plan", bound=2.0, convergence=points)
    api.write_plan(load_problem(PAIR), result, tmp_path, animation=False, viewer=False)
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == (["convergence.png", "summary.json"] if written else ["summary.json"])
