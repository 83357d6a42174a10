"""A lazy round's plan repaired with its task decisions kept (stlplan.planner.core.repairs): every
binary but the lazy requirements' held at the round's value during the repair, released after
it; the repaired plan meets every requirement; a full run with the repair reaches the
up-front optimum."""

from __future__ import annotations

from typing import Any

from pyomo.environ import Var

from stlplan.mission.loader import load_problem
from stlplan.planner.backend.values import load_values
from stlplan.planner.config import PlannerConfig
from stlplan.planner.core.lazy import LazySolver
from stlplan.planner.core.repairs import Broken, TasksKeptRepair
from stlplan.planner.core.watch import pending_violations
from stlplan.planner.encoding.model import PlanModel, build_model
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.clock import Clock
from stlplan.planner.run.outcome import Outcome
from tests.helpers.missions import swap_problem
from tests.helpers.paths import MISSIONS
from tests.helpers.solving import accepted, solve, up_front_optimum

CONFIG = PlannerConfig().with_overrides({"solver.gap": 1e-6})


def _binaries(pm: PlanModel) -> list[Any]:
    return [v for v in pm.model.component_data_objects(Var) if v.is_binary() and not v.fixed]


def _swap_after_its_first_round() -> tuple[LazySolver, list[int]]:
    """a may reach East at step 2, 3 or 4 (a task decision); the first round (no separation)
    lets a and b pass through each other."""
    problem = swap_problem(0.5, horizon=4, inter_sample=True, east_from=2)
    solver = LazySolver(build_model(problem, CONFIG), CONFIG, Clock.started(None))
    solver.session.solve(Budget.of_seconds(20.0))
    bad = pending_violations(solver.pm)
    assert bad  # the round's plan breaks the separation
    return solver, bad


def test_the_task_decisions_are_held_during_the_repair_and_released_after_it() -> None:
    solver, bad = _swap_after_its_first_round()
    tasks = {id(v): round(v.value) for v in _binaries(solver.pm)}  # no requirement added yet
    assert tasks
    seen: dict[str, Any] = {}
    run = solver.run

    def watched(budget: Budget, abs_gap: float | None = None, trial: bool = False) -> Outcome:
        found = _binaries(solver.pm)
        seen["held"] = {id(v): (v.lb, v.ub) for v in found if id(v) in tasks}
        seen["free"] = [(v.lb, v.ub) for v in found if id(v) not in tasks]
        seen["trial"], seen["gap"] = trial, solver.watch.gap
        return run(budget, abs_gap, trial)

    solver.run = watched  # type: ignore[method-assign]
    solver.session.solver.config.rel_gap = 3e-6  # (the session's gap, as a caller left it)
    plan = TasksKeptRepair().repair(Broken(solver, bad), CONFIG, Budget.of_seconds(20.0))
    assert seen["held"] == {key: (value, value) for key, value in tasks.items()}
    assert seen["free"] and all(bounds == (0, 1) for bounds in seen["free"])
    assert seen["trial"] and seen["gap"] == CONFIG.repair.tasks_kept_gap
    # after it: every bound back, the loop's gap back, no trial
    assert all((v.lb, v.ub) == (0, 1) for v in _binaries(solver.pm))
    assert solver.watch.gap == CONFIG.solver.gap
    assert solver.session.solver.config.rel_gap == 3e-6
    assert not solver.trial and not solver.session.trial
    # its plan meets every requirement, with the round's task decisions
    assert plan is not None and plan is solver.watch.best
    load_values(solver.pm.model, plan.values)
    assert pending_violations(solver.pm) == []
    assert {key: round(v.value) for v in _binaries(solver.pm) if (key := id(v)) in tasks} == tasks


def test_a_run_that_repairs_every_round_with_the_tasks_kept_reaches_the_optimum() -> None:
    problem = load_problem(MISSIONS / "stl/formation-trio.yaml")
    reference = up_front_optimum(problem)
    config = {"solver.gap": 1e-6, "repair.tasks_kept_seconds": 0.0}
    result, _ = solve(problem, config)
    assert result.objective is not None and reference.objective is not None
    assert abs(result.objective - reference.objective) <= 1e-5 * abs(reference.objective)
    assert accepted(problem, result)
    assert "tasks kept" in [record["stage"] for record in result.round_log]
