"""Every status and gap rule of step 1 (stlplan.planner.run.outcome), without a solver."""

from __future__ import annotations

import dataclasses

import pytest

from stlplan.planner.run import outcome
from stlplan.planner.run.outcome import Outcome
from stlplan.result import PlanStatus as S


def _part(status: S, objective: float | None, bound: float | None, added: int = 1) -> Outcome:
    return Outcome(status, objective, bound, None, 1.0, 1, added, "convergenceCriteriaSatisfied")


def test_parts_are_optimal_together_only_within_the_gap() -> None:
    a, b = _part(S.OPTIMAL, 4.0, 4.0002), _part(S.OPTIMAL, -0.3, -0.29999)
    assert outcome.combined([a, b], 1e-5, False, 2.0, 3).status is S.FEASIBLE  # 2.1e-4 / 3.7
    together = outcome.combined([a, b], 1e-4, False, 2.0, 3)
    assert together.status is S.OPTIMAL and together.objective == pytest.approx(3.7)
    assert together.bound == pytest.approx(3.70021) and together.added == 2
    assert outcome.combined([a, b], 1e-5, True, 2.0, 3).status is S.INTERRUPTED


def test_a_part_without_a_plan_leaves_the_whole_without_one() -> None:
    a, b = _part(S.OPTIMAL, 1.0, 1.0, 2), _part(S.NO_PLAN, None, 5.0, 3)
    whole = outcome.combined([a, b], 1e-4, False, 2.0, 3)
    assert whole.status is S.NO_PLAN and whole.objective is None and whole.added == 5
    assert outcome.combined([a, None], 1e-4, False, 2.0, 3).status is S.ERROR
    assert outcome.combined([a, b], 1e-5, True, 2.0, 3).status is S.INTERRUPTED_NO_PLAN


def test_a_ceiling_tightens_the_bound_and_may_prove_the_plan() -> None:
    found = _part(S.FEASIBLE, 1.0, 2.0)
    assert outcome.capped(found, 3.0, closed=False) is found  # not tighter
    tight = outcome.capped(found, 1.00001, closed=True)
    assert tight.status is S.OPTIMAL and tight.bound == 1.00001
    assert tight.gap == pytest.approx(1e-5)
    assert outcome.proven(found, 1.5, 1e-4) is None
    assert outcome.proven(found, 1.00001, 1e-4).status is S.OPTIMAL  # type: ignore[union-attr]
    assert outcome.proven(None, 1.0, 1e-4) is None


def test_a_repaired_plan_gets_its_parts_bound_and_its_gap_to_it() -> None:
    repaired = _part(S.FEASIBLE, -7.1, None)
    bounded = outcome.bounded(repaired, -6.9)
    assert bounded.status is S.FEASIBLE and bounded.bound == -6.9
    assert bounded.gap == pytest.approx(0.2 / 7.1)
    assert outcome.bounded(repaired, None) is repaired
    known = _part(S.FEASIBLE, -7.1, -7.0)
    assert outcome.bounded(known, -6.9) is known


def test_a_loop_cut_short_keeps_a_plan_or_says_why_it_has_none() -> None:
    ended = _part(S.FEASIBLE, 1.0, 2.0)
    assert outcome.cut_short(ended, True, True, False).status is S.INTERRUPTED_NO_PLAN  # type: ignore[union-attr]
    assert outcome.cut_short(ended, False, False, False) is ended
    assert outcome.cut_short(ended, False, True, True).status is S.NO_PLAN  # type: ignore[union-attr]
    assert outcome.cut_short(ended, False, True, False) is None  # to be completed
    assert outcome.kept_status(True) is S.INTERRUPTED and outcome.kept_status(False) is S.FEASIBLE


def test_a_completed_plan_is_feasible_at_best_and_keeps_the_rounds_bound() -> None:
    base = _part(S.NO_PLAN, None, 2.0)
    done = outcome.completed(1.5, 2.0, False, base)
    assert done.status is S.FEASIBLE and done.gap == pytest.approx(1 / 3)
    assert outcome.completed(None, 2.0, False, base).status is S.NO_PLAN
    assert outcome.completed(None, 2.0, True, base).status is S.INTERRUPTED_NO_PLAN


def test_the_assembled_plan_keeps_optimality_only_within_the_gap() -> None:
    done = _part(S.OPTIMAL, 3.0, 3.0)
    assert outcome.assembled(done, 3.0, 1e-4, False, 1.0).status is S.OPTIMAL
    assert outcome.assembled(done, 2.9, 1e-4, False, 1.0).status is S.FEASIBLE
    assert outcome.assembled(done, 2.9, 1e-4, True, 1.0).status is S.INTERRUPTED
    failed = outcome.assembled(done, None, 1e-4, False, 1.0)
    assert failed.status is S.ERROR and failed.stop == "assembly failed"


@pytest.mark.parametrize(
    ("has_plan", "stopped", "expected"),
    [(True, False, S.FEASIBLE), (False, False, S.NO_PLAN), (True, True, S.INTERRUPTED),
     (False, True, S.INTERRUPTED_NO_PLAN)],
)  # fmt: skip
def test_a_stop_request_marks_a_solve_cut_short(has_plan: bool, stopped: bool, expected: S) -> None:
    assert outcome.of_solve(has_plan, stopped, S.FEASIBLE, S.NO_PLAN) is expected
    assert outcome.of_solve(has_plan, stopped, S.OPTIMAL, S.INFEASIBLE) in (S.OPTIMAL, S.INFEASIBLE)


def test_the_loosest_part_is_tightened_to_what_the_others_leave() -> None:
    # sum F = 4 - 0.3 = 3.7; U - F = 4e-4 + 1e-5 > 1e-4 * 3.7: the first part, to the rest
    parts = [_part(S.OPTIMAL, 4.0, 4.0004), _part(S.OPTIMAL, -0.3, -0.29999)]
    worst, allowed = outcome.tightening(parts, 1e-4)  # type: ignore[misc]
    assert worst == 0 and allowed == pytest.approx(1e-4 * 3.7 - 1e-5)
    assert outcome.tightening(parts, 1e-3) is None  # within the gap already
    assert outcome.tightening([parts[0], None], 1e-4) is None  # a part without a result


def test_tightening_towards_a_plan_below_the_parts_sum() -> None:
    # F = 3.7, a merged plan P = 3.6999: the slacks must fit in 1e-4 * 3.6999 - 1e-4
    parts = [_part(S.OPTIMAL, 4.0, 4.0004), _part(S.OPTIMAL, -0.3, -0.29999)]
    worst, allowed = outcome.tightening(parts, 1e-4, plan=3.6999)  # type: ignore[misc]
    assert worst == 0 and allowed == pytest.approx(1e-4 * 3.6999 - 1e-4 - 1e-5)
    # a plan that lost more than the gap cannot be helped by tighter parts
    assert outcome.tightening(parts, 1e-4, plan=3.6) is None


def test_parts_without_a_plan_still_bound_the_whole() -> None:
    a = Outcome(S.OPTIMAL, 1.0, 1.0, 0.0, 1.0, 1, 0, "optimal")
    b = Outcome(S.NO_PLAN, None, 2.5, None, 1.0, 2, 0, "maxTimeLimit")
    whole = outcome.combined([a, b], 1e-4, False, 2.0, 3)
    assert whole.status is S.NO_PLAN and whole.objective is None
    assert whole.bound == pytest.approx(3.5)
    unknown = Outcome(S.NO_PLAN, None, None, None, 1.0, 2, 0, "maxTimeLimit")
    assert outcome.combined([a, unknown], 1e-4, False, 2.0, 3).bound is None


def test_the_parts_count_their_rounds_requirements_and_completions_apart() -> None:
    first = Outcome(S.OPTIMAL, -1.0, -1.0, 0.0, 1.0, 2, 5, "optimal")
    completed = Outcome(S.FEASIBLE, -2.0, -1.5, 0.25, 1.0, 3, 7, "maxTimeLimit", True, 40)
    both = outcome.combined([first, completed], 1e-4, False, 2.0, 5)
    assert (both.rounds, both.added, both.completion_added, both.completed) == (5, 12, 40, True)
    failed = dataclasses.replace(completed, status=S.NO_PLAN, objective=None)
    none = outcome.combined([first, failed], 1e-4, False, 2.0, 5)
    assert none.status is S.NO_PLAN
    assert (none.added, none.completion_added, none.completed) == (12, 40, True)
