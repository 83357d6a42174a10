"""How step 1 ended: one :class:`Outcome` type, and every rule that decides its status and gap.

A solve ends with HiGHS's termination and, maybe, a plan; the lazy loop, the parts and the
repairs turn those into an outcome of the full problem. The rules, all here:

* a HiGHS result: its termination and whether it has a plan (:func:`of_solve`); a stop request
  turns a plan cut short into ``interrupted`` and no plan into ``interrupted_no_plan``;
* a known bound of the full problem (a ceiling) tightens an outcome's bound, and proves it
  optimal when the plan is within the gap (:func:`capped`, :func:`proven`);
* the loop cut short keeps its best plan (feasible, or interrupted), else has none
  (:func:`cut_short`); a completed plan (its decisions fixed, every requirement added) is
  feasible at best (:func:`completed`);
* parts: optimal together only when each is and their sum is within the gap; a part without a
  plan leaves the whole without one (:func:`combined`); the assembled plan keeps the parts'
  status only within the gap of their bound (:func:`assembled`); a part is solved again to an
  absolute gap until their sum meets the gap (:func:`tightening`).

Gaps are relative, as HiGHS's: ``(bound - objective) / |objective|`` for a maximization.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Hashable, Mapping, Sequence
from dataclasses import dataclass

from stlplan.planner.tolerances import ROUND_OFF
from stlplan.result import PlanStatus

ASSEMBLY_FAILED = "assembly failed"
"""The ``stop`` of an outcome whose parts' plans did not assemble into a plan of the whole."""


@dataclass(frozen=True)
class Outcome:
    """How step 1 ended.

    Attributes
    ----------
    status
        Optimal, feasible (time limit), infeasible, no plan or error.
    objective, bound, gap
        Best plan's objective, the bound proven for the full problem, their relative gap.
    seconds
        Wall time of every round (and of a completion).
    rounds
        Lazy rounds: solves of the loop (1 without lazy requirements), each recorded in the
        clock's ``round_log``.
    added
        Lazy requirements the rounds and the repairs between them added to the model (a
        completion's apart).
    stop
        HiGHS's termination condition of the last round, by name.
    completed
        Whether the plan's decisions were completed by a last small solve.
    completion_added
        Lazy requirements that completion added (every one still left out, or those added
        before the time ran out).
    """

    status: PlanStatus
    objective: float | None
    bound: float | None
    gap: float | None
    seconds: float
    rounds: int
    added: int
    stop: str
    completed: bool = False
    completion_added: int = 0


VarKey = tuple[str, Hashable]
"""A variable of a model, by its component's name and its index (``("x", ("vis1", 3, 0))``)."""


@dataclass(frozen=True, eq=False)
class Plan:
    """A plan as a value (:mod:`stlplan.planner.backend.values` reads and loads it).

    Attributes
    ----------
    objective
        The plan's step-1 objective (nan when not known: a start made of a trajectory).
    values
        The value of each variable, by key; a start may give some variables only.
    added
        The lazy requirements the model held when the plan was found (those added later get
        the side the plan meets best when it is loaded).
    meets_all
        Whether the plan meets every requirement of the full problem, those left out of the
        model included.
    """

    objective: float
    values: Mapping[VarKey, float]
    added: frozenset[int] = frozenset()
    meets_all: bool = True

    def better_than(self, other: Plan | None) -> bool:
        """Whether this plan's objective exceeds ``other``'s (any plan beats none)."""
        return other is None or self.objective > other.objective


def relative_gap(objective: float | None, bound: float | None) -> float | None:
    """``(bound - objective) / |objective|`` (HiGHS's relative gap, for a maximization)."""
    if objective is None or bound is None:
        return None
    return max(0.0, bound - objective) / max(abs(objective), ROUND_OFF)


def lowest(bound: float | None, ceiling: float | None) -> float | None:
    """The tighter of two upper bounds (either may be unknown)."""
    if bound is None or ceiling is None:
        return ceiling if bound is None else bound
    return min(bound, ceiling)


def of_solve(
    has_plan: bool, stopped: bool, with_plan: PlanStatus, without: PlanStatus
) -> PlanStatus:
    """The status of one solve, given what its termination means with and without a plan;
    a stop request makes a solve cut short ``interrupted`` (or ``interrupted_no_plan``)."""
    status = with_plan if has_plan else without
    if stopped and status not in (PlanStatus.OPTIMAL, PlanStatus.INFEASIBLE):
        return PlanStatus.INTERRUPTED if has_plan else PlanStatus.INTERRUPTED_NO_PLAN
    return status


def capped(outcome: Outcome, ceiling: float | None, closed: bool) -> Outcome:
    """``outcome`` with ``ceiling`` as its bound when that is tighter; a feasible outcome is
    optimal when ``closed`` (its plan within the gap of that bound)."""
    bound = lowest(outcome.bound, ceiling)
    if bound == outcome.bound:
        return outcome
    status = (
        PlanStatus.OPTIMAL if outcome.status is PlanStatus.FEASIBLE and closed else outcome.status
    )
    gap = relative_gap(outcome.objective, bound)
    return dataclasses.replace(outcome, status=status, bound=bound, gap=gap)


def proven(outcome: Outcome | None, ceiling: float | None, gap: float) -> Outcome | None:
    """``outcome`` proven optimal by a known ``ceiling`` of its problem when its plan is within
    ``gap`` of it (None otherwise)."""
    if outcome is None or outcome.objective is None or ceiling is None:
        return None
    if ceiling - outcome.objective > gap * abs(outcome.objective):
        return None
    found = relative_gap(outcome.objective, ceiling)
    return dataclasses.replace(outcome, status=PlanStatus.OPTIMAL, bound=ceiling, gap=found)


def bounded(outcome: Outcome, ceiling: float | None) -> Outcome:
    """``outcome`` with ``ceiling`` (a bound of its problem) as its bound when it has none, and
    the gap of its plan to it."""
    if outcome.bound is not None or ceiling is None:
        return outcome
    return dataclasses.replace(outcome, bound=ceiling, gap=relative_gap(outcome.objective, ceiling))


def unfinished(step1: Outcome) -> Outcome:
    """Step 1's result when its plan breaks a predicate it enforces and the continuous stage
    that would have mended it ran out of time: no plan (the stop request's, when there was one)."""
    interrupted = step1.status is PlanStatus.INTERRUPTED
    status = PlanStatus.INTERRUPTED_NO_PLAN if interrupted else PlanStatus.NO_PLAN
    return dataclasses.replace(step1, status=status, objective=None, gap=None)


def cut_short(ended: Outcome, stopped: bool, has_plan: bool, trial: bool) -> Outcome | None:
    """The loop ended without a plan meeting every requirement: the outcome when nothing more
    is tried (a stop request, no plan at all, a trial), or None when the last round's plan is
    to be completed."""
    if stopped:
        return dataclasses.replace(
            ended, status=PlanStatus.INTERRUPTED_NO_PLAN, objective=None, gap=None
        )
    if not has_plan:
        return ended
    if trial:
        return dataclasses.replace(ended, status=PlanStatus.NO_PLAN, objective=None, gap=None)
    return None


def kept_status(stopped: bool) -> PlanStatus:
    """The status of the best plan kept when the loop is cut short."""
    return PlanStatus.INTERRUPTED if stopped else PlanStatus.FEASIBLE


def completed(
    objective: float | None, bound: float | None, stopped: bool, base: Outcome
) -> Outcome:
    """The outcome of completing the last round's plan (``objective`` None: no plan), with
    ``base``'s figures; the bound stays the last round's."""
    if objective is None:
        status = PlanStatus.INTERRUPTED_NO_PLAN if stopped else PlanStatus.NO_PLAN
        return dataclasses.replace(base, status=status, objective=None, bound=bound, gap=None)
    status = kept_status(stopped)
    gap = relative_gap(objective, bound)
    return dataclasses.replace(base, status=status, objective=objective, bound=bound, gap=gap)


def combined(
    steps: Sequence[Outcome | None], gap: float, stopped: bool, seconds: float, rounds: int
) -> Outcome:
    """The parts' outcomes as one outcome of the full problem: the sums of their objectives
    and bounds, optimal only when every part is and the sum is within ``gap`` (without a plan,
    the sum of the parts' bounds still bounds the whole when each part has one)."""
    done = [s for s in steps if s is not None]
    failed = [s for s in done if not s.status.has_plan]
    if failed or len(done) < len(steps):
        first = failed[0] if failed else None
        status = first.status if first else PlanStatus.ERROR
        if stopped:
            status = PlanStatus.INTERRUPTED_NO_PLAN
        added, completion = _added(done)
        bounds = [s.bound for s in done]
        whole = len(done) == len(steps) and None not in bounds
        bound = sum(b for b in bounds if b is not None) if whole else None  # bounds the whole
        return Outcome(
            status, None, bound, None, seconds, rounds, added, first.stop if first else "",
            first is not None and first.completed, completion,
        )  # fmt: skip
    objective, bound = totals(done)
    found = relative_gap(objective, bound)
    optimal = all(s.status is PlanStatus.OPTIMAL for s in done)
    optimal = optimal and found is not None and found <= gap * (1 + ROUND_OFF)
    status = PlanStatus.OPTIMAL if optimal else PlanStatus.FEASIBLE
    if stopped and not optimal:
        status = PlanStatus.INTERRUPTED
    added, completion = _added(done)
    return Outcome(
        status, objective, bound, found, seconds, rounds, added, done[-1].stop,
        any(s.completed for s in done), completion,
    )  # fmt: skip


def _added(steps: Sequence[Outcome]) -> tuple[int, int]:
    """The requirements the parts' rounds and repairs added, and those their completions
    added."""
    return sum(s.added for s in steps), sum(s.completion_added for s in steps)


def totals(steps: Sequence[Outcome | None]) -> tuple[float | None, float | None]:
    """The sums of the parts' objectives and bounds (None while any is unknown)."""
    objectives = [s.objective for s in steps if s is not None]
    bounds = [s.bound for s in steps if s is not None]
    if len(objectives) < len(steps) or None in objectives or None in bounds:
        return None, None
    return sum(objectives), sum(bounds)  # type: ignore[arg-type]


def tightening(
    steps: Sequence[Outcome | None], gap: float, plan: float | None = None
) -> tuple[int, float] | None:
    """Which part to solve again, and to what absolute gap, so that the parts together meet
    the relative ``gap`` (None: they do, or no part can help).

    ``(U - P) / |P|`` must meet the gap, with ``U`` the sum of the parts' bounds and ``P`` either
    ``plan`` (a plan of the parts together) or ``F``, the sum of their objectives: the parts'
    slacks must fit in ``gap |P| - (F - P)``. The part furthest from its bound gets what the
    others leave of that.
    """
    objective, bound = totals(steps)
    if objective is None or bound is None:
        return None
    reached = objective if plan is None else plan
    found = relative_gap(reached, bound)
    if found is None or found <= gap:
        return None
    slacks = [(s.bound or 0.0) - (s.objective or 0.0) for s in steps if s is not None]
    worst = max(range(len(slacks)), key=slacks.__getitem__)
    allowed = gap * abs(reached) - (objective - reached) - (sum(slacks) - slacks[worst])
    if plan is not None and allowed <= ROUND_OFF:
        return None
    return worst, max(allowed, ROUND_OFF)


def assembled(
    done: Outcome, objective: float | None, gap: float, stopped: bool, seconds: float
) -> Outcome:
    """The outcome of the parts' plans assembled in one model (``objective`` None: the
    assembly failed, an error); optimal only within ``gap`` of the parts' bound."""
    if objective is None:
        return dataclasses.replace(done, status=PlanStatus.ERROR, stop=ASSEMBLY_FAILED)
    found = relative_gap(objective, done.bound)
    status = done.status
    if status is PlanStatus.OPTIMAL and (found is None or found > gap * (1 + ROUND_OFF)):
        status = PlanStatus.INTERRUPTED if stopped else PlanStatus.FEASIBLE
    return dataclasses.replace(done, status=status, objective=objective, gap=found, seconds=seconds)


def gap_words(gap: float | None, bound: float | None) -> str:
    """A plan's gap and bound in the words of a run's message."""
    if gap is None or bound is None or not math.isfinite(bound):
        return "no bound yet"
    return f"gap {gap:.2%}, bound {bound:.6g}"


def better(
    first: Outcome | None, second: Outcome, gap: float, stopped: bool
) -> tuple[bool, Outcome]:
    """Of a first plan's solve and a second solve of the same problem: whether the second is
    kept (its plan at least as good as the first's, or no first), and the kept one's outcome
    with the tighter bound of the two (optimal when its plan is within ``gap`` of it; when the
    first is kept, feasible or interrupted by ``stopped``)."""
    if first is None:
        return True, second
    bound = lowest(second.bound, first.bound)
    kept = second.status.has_plan and second.objective is not None
    if kept and first.objective is not None and second.objective < first.objective:  # type: ignore[operator]
        kept = False
    chosen = second if kept else first
    found = relative_gap(chosen.objective, bound)
    status = chosen.status
    if found is not None and found <= gap * (1 + ROUND_OFF):
        status = PlanStatus.OPTIMAL
    elif not kept:
        status = kept_status(stopped)
    return kept, dataclasses.replace(chosen, status=status, bound=bound, gap=found)


def within(done: Outcome, gap: float) -> Outcome:
    """``done``, feasible rather than optimal when its plan is not within ``gap`` of its bound
    (a round solved to a looser gap)."""
    found = relative_gap(done.objective, done.bound)
    if done.status is PlanStatus.OPTIMAL and (found is None or found > gap * (1 + ROUND_OFF)):
        return dataclasses.replace(done, status=PlanStatus.FEASIBLE)
    return done


def taken(done: Outcome, objective: float, seconds: float, gap: float) -> Outcome:
    """``done`` with another plan of ``objective`` taken after ``seconds`` more: its bound stays,
    and proves the plan optimal when within ``gap`` of it."""
    found = dataclasses.replace(
        done,
        status=PlanStatus.FEASIBLE,
        objective=objective,
        gap=relative_gap(objective, done.bound),
        seconds=done.seconds + seconds,
    )
    return proven(found, done.bound, gap) or found
