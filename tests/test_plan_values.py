"""Plans as values: keys stable across models, a run's plan handed on, a start taken."""

from __future__ import annotations

import math

import pytest

from stlplan.planner.backend.values import load_values, model_values, plan_of, trajectory_values
from stlplan.planner.config import PlannerConfig
from stlplan.planner.encoding.model import build_model
from stlplan.planner.run.outcome import Plan
from stlplan.planner.solve import plan
from stlplan.result import PlanStatus
from tests.helpers.missions import detour_for_free, swap_problem

FIRST_PLAN = {"solver.highs_options": {"mip_max_improving_sols": 1, "mip_heuristic_effort": 0.0}}
"""HiGHS stops at its first improving plan (without a start, a poor one for these missions)."""


def test_a_plan_read_from_one_model_loads_into_another_of_the_same_problem() -> None:
    problem = swap_problem(0.5, horizon=3, inter_sample=True)
    result = plan(problem, PlannerConfig().with_overrides({"lazy.enabled": False}))
    assert result.status is PlanStatus.OPTIMAL and result.values
    other = build_model(problem, PlannerConfig().with_overrides({"lazy.enabled": False}))
    load_values(other.model, result.values)
    loaded = model_values(other.model)
    shared = set(loaded) & set(result.values)
    assert {key[0] for key in shared} >= {"x", "u", "s"}
    assert all(loaded[k] == pytest.approx(result.values[k]) for k in shared)
    assert plan_of(other.model, other.model.step1).objective == pytest.approx(result.objective)


def test_a_run_started_from_the_optimum_returns_it_at_its_first_plan() -> None:
    problem = detour_for_free()
    config = PlannerConfig().with_overrides({"lazy.enabled": False})
    optimum = plan(problem, config)
    assert optimum.status is PlanStatus.OPTIMAL and optimum.objective is not None
    first = config.with_overrides(FIRST_PLAN)
    alone = plan(problem, first)
    started = plan(problem, first, start=Plan(optimum.objective, optimum.values))
    assert alone.objective is not None and alone.objective < optimum.objective - 1.0
    assert started.objective == pytest.approx(optimum.objective, rel=1e-4)


def test_a_start_of_states_and_inputs_only_is_completed() -> None:
    problem = detour_for_free()
    config = PlannerConfig().with_overrides({"lazy.enabled": False})
    optimum = plan(problem, config)
    assert optimum.objective is not None
    trajectory = {k: v for k, v in optimum.values.items() if k[0] in ("x", "u")}
    start = Plan(math.nan, trajectory, meets_all=False)
    started = plan(problem, config.with_overrides(FIRST_PLAN), start=start)
    assert started.objective == pytest.approx(optimum.objective, rel=1e-4)


def test_a_start_of_a_plan_for_the_whole_team_starts_each_part() -> None:
    problem = detour_for_free()
    optimum = plan(problem)
    assert optimum.objective is not None
    first = PlannerConfig().with_overrides(FIRST_PLAN)
    started = plan(problem, first, start=Plan(optimum.objective, optimum.values))
    assert started.objective == pytest.approx(optimum.objective, rel=1e-4)
    assert any(r["agents"] < 3 for r in started.round_log)  # e is still a part of its own


def test_first_plan_stops_at_a_plan_meeting_every_requirement() -> None:
    from stlplan.pipeline import plan as verified_plan
    from stlplan.planner.overrides import Overrides

    problem = swap_problem(0.5, horizon=3, inter_sample=True)
    _, full = verified_plan(problem, Overrides(time_limit=60))
    _, first = verified_plan(problem, Overrides(time_limit=60, first_plan=True))
    assert first.report is not None and first.report.satisfied
    assert first.status in (PlanStatus.FEASIBLE, PlanStatus.OPTIMAL)
    assert first.rounds <= full.rounds
    assert full.objective is not None and first.objective is not None
    assert first.objective <= full.objective + 1e-6
    last = first.round_log[-1]
    assert last["best"] is not None  # the run ended on the round that found the plan


@pytest.mark.parametrize("dotted", [{}, {"parts.enabled": False}, {"lazy.enabled": False}])
def test_the_time_to_the_first_plan_is_recorded(dotted: dict[str, bool]) -> None:
    result = plan(detour_for_free(), PlannerConfig().with_overrides(dotted))
    assert result.status is PlanStatus.OPTIMAL
    seconds = result.first_plan_seconds
    assert seconds is not None and 0 < seconds <= result.build_seconds + result.solve_seconds


def test_trajectory_values_keep_states_and_inputs_of_the_agents_asked() -> None:
    values = {
        ("x", ("a", 0, 0)): 1.0,
        ("u", ("a", 0, 1)): 2.0,
        ("x", ("b", 3, 0)): 3.0,
        ("spec.binaries", ("a", 0, 0)): 1.0,  # a numbered component: left out
        ("rho_s", ("task",)): 4.0,
    }
    assert trajectory_values(values) == {k: v for k, v in values.items() if k[0] in ("x", "u")}
    assert trajectory_values(values, {"a"}) == {
        ("x", ("a", 0, 0)): 1.0,
        ("u", ("a", 0, 1)): 2.0,
    }
