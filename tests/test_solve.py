"""Tiny missions with optima derived by hand, status mapping, options, the farm (slow)."""

from __future__ import annotations

import dataclasses
import itertools
import math
import time

import numpy as np
import pytest

from stlplan.formula.boundary import EPSILON
from stlplan.mission.loader import load_problem
from stlplan.mission.problem import Problem
from stlplan.planner.config import ConfigError, PlannerConfig
from stlplan.planner.overrides import Overrides
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.clock import Progress
from stlplan.planner.solve import plan
from stlplan.result import PlanStatus
from tests.helpers.configs import paper_model
from tests.helpers.dynamics import DOUBLE_INTEGRATOR_U2, single_integrator
from tests.helpers.missions import mission
from tests.helpers.paths import FARM
from tests.helpers.solving import ENCODINGS


def reach_problem(effort: str = "l1", goal_x: tuple[float, float] = (1, 2)) -> Problem:
    # double integrator from rest at 0: px(1) = 0.5 u0, px(2) = 1.5 u0 + 0.5 u1
    return mission(
        horizon=2,
        dynamics={"di": DOUBLE_INTEGRATOR_U2},
        agents=[{"name": "a", "dynamics": "di", "initial_state": [0, 0, 0, 0]}],
        regions={"Goal": {"box": [list(goal_x), [-1, 1]]}},
        tasks={"reach": {"formula": "F[0,2] in(p, Goal)", "roles": {"p": {"agent": "a"}}}},
        objective={"beta": 1.0, "effort": effort},
    )


def sync_problem(gamma: float = 8) -> Problem:
    # Vis agents reach C (x >= 1.5 + EPSILON) at the earliest at k = 2 (v1), 3 (v2), 5 (v3)
    starts = {"v1": [0, 0], "v2": [-1, 0.5], "v3": [-3, 1]}
    return mission(
        horizon=6,
        dynamics={"si": single_integrator(1.0)},
        agents=[
            {"name": n, "dynamics": "si", "capabilities": ["Vis"], "initial_state": s}
            for n, s in starts.items()
        ],
        regions={"C": {"box": [[1.5, 3], [-1, 2]]}},
        tasks={
            "watch": {
                "formula": "in(p, C)",
                "count": 2,
                "roles": {"p": "Vis"},
                "synchronous": {"within": [0, 4], "hold": 1, "gamma": gamma},
            }
        },
        separation=0.1,
        objective={"beta": 0.05, "effort": "l1"},
    )


@pytest.mark.parametrize("encoding", ENCODINGS)
def test_reach_minimal_l1_effort(encoding: str) -> None:
    # reach at k=1 costs |u0| = 2; at k=2: min |u0| + |u1| s.t. 1.5 u0 + 0.5 u1 >= 1 is 2/3
    result = plan(
        reach_problem(),
        PlannerConfig().with_overrides({"model.encoding": encoding, "solver.time_limit": 30.0}),
    )
    assert result.status is PlanStatus.OPTIMAL
    assert result.objective == pytest.approx(-2 / 3, abs=1e-6)
    assert result.effort == pytest.approx(2 / 3, abs=1e-6)
    assert result.steps == 2
    assert result.trajectory is not None
    assert result.trajectory.states["a"][2, 0] >= 1 - 1e-7


def test_step2_minimizes_l2_effort_with_step1_decisions() -> None:
    # step 1 picks k=2; step 2: min u0^2 + u1^2 s.t. 1.5 u0 + 0.5 u1 >= 1 -> u = (0.6, 0.2)
    result = plan(
        reach_problem(effort="l2"), PlannerConfig().with_overrides({"solver.time_limit": 30.0})
    )
    assert result.status is PlanStatus.OPTIMAL and result.steps == 2
    assert result.effort == pytest.approx(math.sqrt(0.4), abs=1e-5)
    assert result.trajectory is not None
    np.testing.assert_allclose(result.trajectory.inputs["a"][:, 0], [0.6, 0.2], atol=1e-5)
    one_step = plan(
        reach_problem(effort="l2"),
        PlannerConfig().with_overrides({"solver.time_limit": 30.0, "continuous.two_step": False}),
    )
    assert one_step.steps == 1
    assert one_step.effort == pytest.approx(2 / 3, abs=1e-6)  # l2 of (2/3, 0)
    assert one_step.effort > result.effort


@pytest.mark.parametrize("encoding", ENCODINGS)
def test_maximized_margin(encoding: str) -> None:
    # single integrator, one step: px = u0 <= 2, margin = min(px - 1, 4 - px, 3 - |py|)
    # objective max r - 0.1 |u0|  ->  px = 2, r = 1, objective 0.8
    problem = mission(
        horizon=1,
        dynamics={"si": single_integrator(2.0)},
        agents=[{"name": "a", "dynamics": "si", "initial_state": [0, 0]}],
        regions={"Goal": {"box": [[1, 4], [-3, 3]]}},
        tasks={"reach": {"formula": "G[1,1] in(p, Goal)", "roles": {"p": {"agent": "a"}}}},
        objective={"beta": 0.1, "effort": "l1", "margin": {"maximize": True}},
    )
    result = plan(
        problem,
        PlannerConfig().with_overrides({"model.encoding": encoding, "solver.time_limit": 30.0}),
    )
    assert result.status is PlanStatus.OPTIMAL
    assert result.objective == pytest.approx(0.8, abs=1e-6)
    assert result.margin == pytest.approx(1.0, abs=1e-6)
    assert result.gap == 0.0  # no binaries: an LP, solved to optimality


@pytest.mark.parametrize("encoding", ENCODINGS)
def test_synchronous_robustness_by_hand(encoding: str) -> None:
    # best pair (v1, v2): both in C on steps 3..6, run 4, rho_s = 4 - 1 - d = 2;
    # effort: v1 moves 1.5 + e, v2 moves 2.5 + e -> objective 2 - 0.05 * (4 + 2e)
    result = plan(
        sync_problem(),
        PlannerConfig().with_overrides({"model.encoding": encoding, "solver.time_limit": 60.0}),
    )
    assert result.status is PlanStatus.OPTIMAL
    assert result.objective == pytest.approx(2 - 0.05 * (4 + 2 * EPSILON), abs=5e-8)
    assert result.rho_s == {"watch": pytest.approx(2.0)}
    (assignment,) = result.assignments
    assert assignment.group == (("v1",), ("v2",))
    assert (assignment.run_start, assignment.run_length) == (3, 4)
    assert result.effort == pytest.approx(4 + 2 * EPSILON, abs=5e-7)


def test_gamma_caps_synchronous_robustness() -> None:
    # rho_s <= gamma = 1 needs a run of 3 (v1, v2 from step 3): effort still 4 + 2e
    result = plan(
        sync_problem(gamma=1), PlannerConfig().with_overrides({"solver.time_limit": 60.0})
    )
    assert result.status is PlanStatus.OPTIMAL
    assert result.objective == pytest.approx(1 - 0.05 * (4 + 2 * EPSILON), abs=5e-8)


def test_solver_robustness_equals_monitor() -> None:
    from stlplan.monitor.verdicts import check

    problem = sync_problem()
    result = plan(
        problem,
        PlannerConfig().with_overrides({"solver.time_limit": 60.0, "continuous.two_step": False}),
    )
    assert result.trajectory is not None
    report = check(problem, result.trajectory)
    assert report.satisfied
    assert report.rho_s == pytest.approx(result.rho_s["watch"])
    verdict = report.verdict("watch")
    assert (verdict.run_start, verdict.run_length) == (3, 4)


def test_unreachable_goal_is_infeasible() -> None:
    # px(2) <= 1.5 * 2 + 0.5 * 2 = 4 < 4.5
    result = plan(
        reach_problem(goal_x=(4.5, 5)), PlannerConfig().with_overrides({"solver.time_limit": 30.0})
    )
    assert result.status is PlanStatus.INFEASIBLE
    assert result.trajectory is None and not result.status.has_plan


def test_progress_reports_phases_in_order() -> None:
    seen: list[Progress] = []
    plan(
        reach_problem(),
        PlannerConfig().with_overrides({"solver.time_limit": 30.0}),
        progress=seen.append,
    )
    phases = [p.phase for p in seen]
    assert phases[0] == "build" and phases[-1] == "done"
    assert phases.index("step1") < phases.index("step2")
    assert all(a.elapsed <= b.elapsed for a, b in itertools.pairwise(seen))


def test_progress_errors_are_raised() -> None:
    def broken(_: Progress) -> None:
        raise RuntimeError("bar broke")

    with pytest.raises(RuntimeError, match="bar broke"):
        plan(
            reach_problem(),
            PlannerConfig().with_overrides({"solver.time_limit": 30.0}),
            progress=broken,
        )


def test_config_from_mission_with_overrides() -> None:
    problem = load_problem(FARM)
    overrides = Overrides(time_limit=12.5, threads=None, seed=3, config={"lazy.enabled": False})
    config = PlannerConfig.from_mission(problem.mission, overrides.dotted())
    assert config.solver.time_limit == 12.5 and config.solver.seed == 3
    assert config.lazy.enabled is False
    assert config.solver.threads == problem.mission.solver.threads
    assert config.solver.gap == problem.mission.solver.gap
    assert config.continuous.two_step is problem.mission.objective.two_step
    assert overrides.given() == {"time_limit": 12.5, "seed": 3, "lazy.enabled": False}
    with pytest.raises(ConfigError, match="colour"):
        PlannerConfig.from_mission(problem.mission, {"model.colour": "red"})


@pytest.mark.slow
@pytest.mark.timeout(600)  # a time limit of 300 s, and the build before it
@pytest.mark.parametrize("encoding", ENCODINGS)
def test_farm_case_one(encoding: str) -> None:
    from stlplan.monitor.verdicts import check

    problem = load_problem(FARM)
    result = plan(
        problem,
        PlannerConfig.from_mission(
            problem.mission, Overrides(encoding=encoding, time_limit=300, threads=2).dotted()
        ),
    )
    assert result.status.has_plan
    assert result.trajectory is not None
    assert check(problem, result.trajectory).satisfied
    if result.status is PlanStatus.OPTIMAL:  # safety between steps: run 6 from step 4
        assert result.rho_s == {"crop_C": pytest.approx(4.0)}


def swap_problem(effort: str) -> Problem:
    # two agents swap sides around an obstacle while keeping apart; "a" cannot also reach
    # West on steps 6..8 after East on 5..8, so "west" must be served by "b"
    return mission(
        horizon=8,
        dynamics={"si": single_integrator(1.0)},
        agents=[
            {"name": "a", "dynamics": "si", "capabilities": ["X"], "initial_state": [0, 0]},
            {"name": "b", "dynamics": "si", "capabilities": ["X"], "initial_state": [5, 0]},
        ],
        regions={
            "East": {"box": [[4, 5], [-0.5, 0.5]]},
            "West": {"box": [[0, 0.5], [-0.5, 0.5]]},
            "Obs": {"box": [[1.5, 3.5], [-1, 1]]},
        },
        tasks={
            "east": {"formula": "F[5,8] in(p, East)", "roles": {"p": {"agent": "a"}}},
            "west": {"formula": "F[6,8] G[0,0] in(p, West)", "roles": {"p": "X"}},
        },
        constraints={"avoid": {"formula": "G[0,8] !in(p, Obs)", "for_each": "p"}},
        separation=0.5,
        objective={"effort": effort},
    )


@pytest.mark.parametrize("encoding", ENCODINGS)
@pytest.mark.parametrize(("effort", "two_step"), [("l2", True), ("linf", True), ("l1", False)])
def test_plans_pass_the_monitor(encoding: str, effort: str, two_step: bool) -> None:
    from stlplan.monitor.verdicts import check

    problem = swap_problem(effort)
    result = plan(
        problem,
        PlannerConfig().with_overrides(
            {"model.encoding": encoding, "continuous.two_step": two_step, "solver.time_limit": 60.0}
        ),
    )
    assert result.status is PlanStatus.OPTIMAL
    assert result.steps == (2 if two_step else 1)
    assert result.trajectory is not None
    report = check(problem, result.trajectory)
    assert report.satisfied, [v.detail for v in report.verdicts if not v.satisfied]
    groups = {a.task: a.group for a in result.assignments}
    assert groups == {"east": (("a",),), "west": (("b",),)}


def test_fixed_decisions_enforce_exactly_the_chosen_disjunct() -> None:
    # reach at k=2 is the optimal decision: the Goal's half-planes at k=2 are the ones enforced
    from stlplan.planner.backend.session import solve_once
    from stlplan.planner.core.finish import enforced_predicates, fix_decisions
    from stlplan.planner.encoding.model import build_model
    from stlplan.planner.run.clock import Clock

    pm = build_model(
        reach_problem(),
        paper_model(model__encoding="log"),
    )
    options = PlannerConfig().with_overrides({"solver.time_limit": 30.0})
    clock = Clock(0.0, None)
    solve_once(pm.model, options, clock, "step1", Budget.of_seconds(30))
    fix_decisions(pm)
    enforced, _, _ = enforced_predicates(pm, options, clock, "step2", Budget.of_seconds(30))
    assert enforced is not None
    assert {k for _, k, _ in enforced} == {2}
    assert len(enforced) == 4


def test_thread_count_can_change_between_plans() -> None:
    # HiGHS keeps one thread pool per process; a new count must not fail the next solve, nor
    # change its plan: the optimum by hand (test_reach_minimal_l1_effort), accepted by the monitor
    from stlplan.monitor.verdicts import check

    problem = reach_problem()
    for threads in (None, 2, 1):
        result = plan(
            problem,
            PlannerConfig().with_overrides({"solver.time_limit": 30.0, "solver.threads": threads}),
        )
        assert result.status is PlanStatus.OPTIMAL, (threads, result.message)
        assert result.objective == pytest.approx(-2 / 3, abs=1e-6), threads
        assert result.trajectory is not None
        assert check(problem, result.trajectory).satisfied, threads


@pytest.mark.parametrize(
    ("op", "status"), [("U*", PlanStatus.OPTIMAL), ("U", PlanStatus.INFEASIBLE)]
)
def test_the_strict_until_needs_no_left_where_right_holds(op: str, status: PlanStatus) -> None:
    # the agent starts in B, outside A (|u| <= 1 keeps it out of A at step 0): A U*[0,2] B holds
    # at once with no effort; the paper's U needs A at step 0 as well, which nothing can give
    problem = mission(
        horizon=2,
        dynamics={"si": single_integrator(1.0)},
        agents=[{"name": "a", "dynamics": "si", "initial_state": [0, 0]}],
        regions={"A": {"box": [[2, 3], [-1, 1]]}, "B": {"box": [[-0.5, 0.5], [-1, 1]]}},
        tasks={"t": {"formula": f"in(p, A) {op}[0,2] in(p, B)", "roles": {"p": {"agent": "a"}}}},
        objective={"beta": 1.0, "effort": "l1"},
    )
    result = plan(
        problem, PlannerConfig().with_overrides({"solver.time_limit": 30.0, "solver.threads": 1})
    )
    assert result.status is status
    if status is PlanStatus.OPTIMAL:
        assert result.effort == pytest.approx(0.0, abs=1e-9)


def test_a_failed_completion_is_not_called_completed() -> None:
    from stlplan.planner.core.finish import Finish
    from stlplan.planner.run.clock import Clock
    from stlplan.planner.run.outcome import Outcome
    from stlplan.planner.solve import run_events, step1_message

    config, clock = PlannerConfig(), Clock(0.0, None)
    done = Outcome(PlanStatus.FEASIBLE, 1.0, 2.0, 0.5, 1.0, 3, 4, "maxTimeLimit", completed=True)
    failed = dataclasses.replace(done, status=PlanStatus.NO_PLAN, objective=None, gap=None)
    completion = "the last round's plan completed with its step-1 decisions fixed"
    assert completion in run_events(done, Finish(), config, clock, False)
    assert any("cannot meet" in e for e in run_events(failed, Finish(), config, clock, False))
    assert "cannot meet" not in step1_message(failed, config, clock)  # (an event, not the status)
    assert not any("completed" in e for e in run_events(failed, Finish(), config, clock, False))
    assert "cannot meet" not in step1_message(done, config, clock)
    plain = dataclasses.replace(done, completed=False)
    for _ in range(3):
        clock.record_round(["a"], 1.0, "maxTimeLimit", None, None, {"separation step": 4})
    assert run_events(plain, Finish(), config, clock, False) == (
        "3 lazy rounds, 4 requirements added",
    )
    more = dataclasses.replace(done, completion_added=5)
    assert run_events(more, Finish(), config, clock, False)[0] == (
        "3 lazy rounds, 4 requirements added; the completion added 5 more"
    )


def test_a_continuous_stage_out_of_time_keeps_the_step_1_plan_without_its_solve(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # a large team's continuous model takes seconds to build: past the grace, no solve follows
    from stlplan.planner.backend.session import solve_once
    from stlplan.planner.backend.values import model_values
    from stlplan.planner.core import finish as finishing
    from stlplan.planner.encoding.model import build_model
    from stlplan.planner.run.clock import Clock

    pm = build_model(reach_problem(), paper_model())
    options, clock = PlannerConfig().with_overrides({"solver.time_limit": 30.0}), Clock(0.0, None)
    solve_once(pm.model, options, clock, "step1", Budget.of_seconds(30))
    before = model_values(pm.model)

    def build(*_: object) -> None:
        raise RuntimeError("the continuous model was built")

    monkeypatch.setattr(finishing, "continuous_model", build)
    ended = finishing.finish(pm, options, clock, Budget.of_seconds(0.0))
    assert ended.failed == finishing.OUT_OF_TIME and not ended.infeasible
    assert model_values(pm.model) == before
    with pytest.raises(RuntimeError, match="was built"):  # with the time, it is
        finishing.finish(pm, options, clock, Budget.of_seconds(30.0))
    # its first LP took 0.5 s: less left than that and a least solve, the model is not built
    enforced_predicates = finishing.enforced_predicates

    def slow(*args: object) -> object:
        time.sleep(0.5)
        return enforced_predicates(*args)  # type: ignore[arg-type]

    monkeypatch.setattr(finishing, "enforced_predicates", slow)
    ended = finishing.finish(pm, options, clock, Budget.of_seconds(2.0))
    assert ended.failed == finishing.OUT_OF_TIME
    with pytest.raises(RuntimeError, match="was built"):
        finishing.finish(pm, options, clock, Budget.of_seconds(4.0))


def test_no_plan_suggests_a_first_plan_only_when_not_already_asked_for() -> None:
    from stlplan.planner.run.clock import Clock
    from stlplan.planner.run.outcome import Outcome
    from stlplan.planner.solve import step1_message

    none = Outcome(PlanStatus.NO_PLAN, None, 2.0, None, 1.0, 3, 4, "maxTimeLimit")
    proving, first = PlannerConfig(), PlannerConfig().with_overrides({"solver.first_plan": True})
    assert "(--first-plan)" in step1_message(none, proving, Clock(0.0, None))
    assert "--first-plan" not in step1_message(none, first, Clock(0.0, None))
