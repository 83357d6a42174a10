"""Replans on a deadline: the best plan found within so many seconds of wall time.

A replan given a deadline (``stlplan replan --deadline S``, the online planner's ``deadline``)
comes back by it with one of three answers:

* **a new plan** that keeps every task (optimal, or the best found when the time ran out);
* **a degraded plan**: the best plan of the tasks that can still be met, the others dropped;
* **the shifted plan**: the current plan, shifted on from the measured states of the replan's
  step ``K`` (:mod:`stlplan.shifted`). It is built and judged by the monitor before the search
  starts, so it is ready at any moment.

The best comes back: a new plan; else the shifted plan when the monitor finds it meets every
task, and every constraint from ``K`` on; else a degraded plan when it keeps a task the shifted
plan fails, or the shifted plan breaks a constraint or the separation (a degraded plan found in
a short time may drop a task that a longer search keeps: the shifted plan keeps trying for it);
else the shifted plan all the same, flagged with what it fails (a robot loop needs inputs). Without a current plan (an
executed file without later rows) and without a plan from the search, nothing comes back.

The search runs in a thread of its own, in two phases, each with a time limit that ends it
before the deadline (:func:`search_seconds`): the first stops at the first plan that meets every
requirement (:func:`first_plan_settings`), the second, when the first found a plan (of every
task, or degraded) not proven optimal and time is left, searches for the best plan from it with
the run's own settings. The
caller waits until the deadline less the time its own writing needs and takes the search's best
answer so far (the second phase's plan when it is better, else the first's). A search left behind has its solves stopped and ends as at a time limit; the next replan on a deadline
waits for it first.
"""

from __future__ import annotations

import contextlib
import dataclasses
import gc
import math
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

from stlplan.errors import UsageError
from stlplan.mission.past import replanned
from stlplan.mission.problem import Problem
from stlplan.monitor.verdicts import check as monitor_check
from stlplan.planner.config import PlannerConfig
from stlplan.planner.overrides import Overrides
from stlplan.planner.run.outcome import Plan
from stlplan.result import PlanResult, PlanStatus, Replan, Trajectory
from stlplan.runtime import signals
from stlplan.shifted import shifted_plan
from stlplan.words import counted

SEARCH_SHARE = 0.8
"""The share of the time left after the shifted plan that the search's time limit (and its
grace) may take; the rest covers what follows a time limit: the last model's build, the
monitor's verdict and the answer's writing. Measured: 0.7, 0.8 and 0.9 gave 46, 46-47 and 43
new plans of 80 replans on a 1 s deadline, 8 of 10 runs satisfied each (with the shifted plan of
the fewest steps; docs/simulation.md#replanning-at-a-1-s-deadline)."""

WAKING_SECONDS = 0.05
"""What a replan on a deadline keeps of it for waking up: a pause of the garbage collector in the
search's thread holds the caller back (measured up to 0.07 s on Case I)."""

WRITING_SECONDS = 0.1
"""What ``stlplan replan --deadline`` keeps of its deadline for writing ``trajectory.csv`` and
``summary.json`` besides the search left behind (measured up to 0.08 s on Case I)."""

PROVEN = 1e-4
"""The gap at which a first search's plan counts as proven (the default ``solver.gap``): no
second search for a better one."""


class DeadlineError(UsageError):
    """A deadline that cannot be kept: not a number, not above zero, or shorter than loading the
    mission took."""

    exit_code = 3


def deadline_seconds(text: str | float, option: str = "--deadline") -> float:
    """The seconds of a deadline given as text or a number.

    Raises
    ------
    DeadlineError
        Not a number, not finite, or not above zero.
    """
    try:
        seconds = float(text)
    except ValueError:
        seconds = math.nan
    if not (math.isfinite(seconds) and seconds > 0):
        raise DeadlineError(
            f"{option} {text}: expected a number of seconds above 0 (the wall time by which the "
            "replan answers, loading and writing included)"
        )
    return seconds


@dataclass(frozen=True)
class Deadline:
    """When an answer is due: ``seconds`` after ``start`` (``time.perf_counter``)."""

    seconds: float
    start: float

    @classmethod
    def starting(cls, seconds: float, start: float | None = None) -> Deadline:
        """A deadline of ``seconds`` from ``start`` (default: now)."""
        return cls(seconds, time.perf_counter() if start is None else start)

    @property
    def end(self) -> float:
        """When the answer is due."""
        return self.start + self.seconds

    def remaining(self) -> float:
        """Seconds left (negative once past)."""
        return self.end - time.perf_counter()

    def check_loaded(self, what: str = "loading the mission") -> None:
        """Raise :class:`DeadlineError` when ``what`` has already used the whole deadline."""
        spent = time.perf_counter() - self.start
        if spent >= self.seconds:
            raise DeadlineError(
                f"--deadline {self.seconds:g}: shorter than {what} took ({spent:.2f} s); "
                "expected a deadline above that"
            )


def search_seconds(deadline: Deadline, config: PlannerConfig, reserve: float) -> float:
    """The time limit of a search started now: :data:`SEARCH_SHARE` of what is left but
    ``reserve`` (the caller's writing), its grace included (``budget.grace_share``)."""
    left = max(0.0, deadline.remaining() - reserve)
    return max(1e-3, SEARCH_SHARE * left / (1.0 + config.budget.grace_share))


def first_plan_settings(problem: Problem, overrides: Overrides) -> Overrides:
    """``overrides`` for the first search on a deadline: stop at the first plan that meets every
    requirement, and a team smaller than a large one's part (``parts.plan_first_agents``)
    planned whole (its parts' plans collide, and their repairs cost more than the team's own
    rounds); what ``overrides`` sets itself stays."""
    config = PlannerConfig.from_mission(problem.mission, overrides.dotted())
    large = config.parts.plan_first_agents
    settings = dict(overrides.config)
    if (large is None or len(problem.agents) < large) and "parts.enabled" not in settings:
        settings["parts.enabled"] = False
    first_plan = True if overrides.first_plan is None else overrides.first_plan
    return dataclasses.replace(overrides, first_plan=first_plan, config=settings)


class _Search(threading.Thread):
    """A replan's search in a thread of its own (module docstring): a first plan, then, with
    time left, the best plan from it; :attr:`answer` holds the best so far."""

    def __init__(self, phases: list[_Phase]) -> None:
        super().__init__(name="stlplan-replan", daemon=True)
        self.phases = phases
        self.answer: tuple[Problem, PlanResult] | None = None
        self.error: BaseException | None = None

    def run(self) -> None:
        try:
            for phase in self.phases:
                found = self.answer[1] if self.answer is not None else None
                if found is not None and not improvable(found):
                    return
                start = None if found is None else Plan(math.nan, found.values, meets_all=False)
                answer = phase(start)
                if self.answer is None or better_answer(answer[1], self.answer[1]):
                    self.answer = answer
        except BaseException as exc:  # handed to the caller, which raises it
            self.error = exc
        finally:
            signals.caught_up(self)


def improvable(found: PlanResult) -> bool:
    """Whether a first search's answer is worth a search for a better plan: a plan (of every
    task, or degraded) not proven optimal."""
    if found.trajectory is None or found.status not in (PlanStatus.FEASIBLE, PlanStatus.DEGRADED):
        return False
    return found.gap is None or found.gap > PROVEN


def better_answer(new: PlanResult, old: PlanResult) -> bool:
    """Whether ``new`` is a better answer than ``old``: a plan where there was none, one that
    drops fewer tasks, or one that drops as many with a higher objective of the plan written."""
    if new.trajectory is None:
        return False
    if old.trajectory is None or len(new.dropped) != len(old.dropped):
        return old.trajectory is None or len(new.dropped) < len(old.dropped)
    return _score(new) > _score(old)


def _score(found: PlanResult) -> float:
    return -math.inf if found.objective is None else found.objective


def replan_by(
    deadline: Deadline,
    problem: Problem,
    executed: Trajectory,
    step: int,
    lost: Sequence[str] = (),
    closed: Sequence[str] = (),
    overrides: Overrides | None = None,
    progress: Callable[[Any], None] | None = None,
    start: Plan | None = None,
    current: Trajectory | None = None,
    reserve: float = 0.0,
) -> tuple[Problem, PlanResult]:
    """:func:`stlplan.replanning.replan` answered by ``deadline`` (module docstring), ``reserve``
    seconds before it for the caller's writing. ``current`` is the plan being executed (none:
    no shifted plan, and a search that does not come back in time leaves no plan). The result's
    :class:`~stlplan.result.Replan` says which answer came back and why."""
    with _collected_after():
        again = replanned(problem, executed, step, lost, closed)
        fallback = None if current is None else shifted_plan(again, current, executed, step)
        if not signals.catch_up(_wait(deadline, reserve)):  # the last search still unwinds
            return _best(deadline, again, fallback, None)
        events = (executed, step, lost, closed)
        settings = overrides or Overrides()
        phases = _phases(deadline, problem, events, settings, progress, start, reserve)
        search = _Search(phases)
        search.start()
        search.join(timeout=_wait(deadline, reserve))
        answer = search.answer  # (what it found by now: a later answer is not taken)
        if search.is_alive():
            signals.leave_behind(search)
            if not search.is_alive():  # it ended in between: nothing is left behind
                signals.caught_up(search)
        elif search.error is not None:
            raise search.error
        return _best(deadline, again, fallback, answer)


def _wait(deadline: Deadline, reserve: float) -> float:
    """How long the caller may wait for a search: to the deadline but ``reserve`` and
    :data:`WAKING_SECONDS`."""
    return max(0.0, deadline.remaining() - reserve - WAKING_SECONDS)


@contextlib.contextmanager
def _collected_after() -> Iterator[None]:
    """Garbage collection in the block looks at the block's own objects only: a full collection
    of everything holds every thread for a tenth of a second or more (0.11-0.15 s measured
    during Case I's replans), and one at the deadline would make the answer late. The objects
    from before are frozen out of the collector in the block (:func:`gc.freeze`), and are
    collected as usual after it."""
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


_Phase = Callable[[Plan | None], tuple[Problem, PlanResult]]
"""A phase of the search: a replan from a start (the first phase's plan, or None)."""


def _phases(
    deadline: Deadline,
    problem: Problem,
    events: tuple[Trajectory, int, Sequence[str], Sequence[str]],
    overrides: Overrides,
    progress: Callable[[Any], None] | None,
    start: Plan | None,
    reserve: float,
) -> list[_Phase]:
    """The search's phases (module docstring), each timed when it starts."""
    from stlplan.replanning import replan

    config = PlannerConfig.from_mission(problem.mission, overrides.dotted())

    def phase(settings: Overrides) -> _Phase:
        def search(found: Plan | None) -> tuple[Problem, PlanResult]:
            limit = min(search_seconds(deadline, config, reserve), config.solver.time_limit)
            timed = dataclasses.replace(settings, time_limit=limit)
            return replan(problem, *events, timed, progress, found or start)

        return search

    first = first_plan_settings(problem, overrides)
    return [phase(first)] + ([phase(overrides)] if first != overrides else [])


def _best(
    deadline: Deadline,
    again: Problem,
    fallback: PlanResult | None,
    answer: tuple[Problem, PlanResult] | None,
) -> tuple[Problem, PlanResult]:
    """The best of the search's ``answer`` and the shifted plan (module docstring)."""
    waited = f"{time.perf_counter() - deadline.start:.2g} s"
    planned, found = answer or (again, None)
    if found is not None and found.trajectory is not None and not found.dropped:
        return planned, _with_answer(found, deadline, "new plan", _why_found(found))
    if fallback is not None and keeps_every_task(again, fallback):
        why = "the search had no plan of every task after " + waited
        return _answered(deadline, again, fallback, why, again)
    if found is not None and found.trajectory is not None:
        if fallback is None or not _gives_up_no_more(again, fallback, found):
            return planned, _with_answer(found, deadline, "degraded plan", _why_found(found))
        dropped = ", ".join(d.task for d in found.dropped)
        why = f"the search's plan drops {dropped}, which the shifted plan keeps trying for"
        return _answered(deadline, again, fallback, why, again)
    if found is None:
        why = f"the search had not come back after {waited}"
    else:
        why = f"the search found no plan: {found.message}"
    return _answered(deadline, again, fallback, why, planned, found)


def _gives_up_no_more(again: Problem, shifted: PlanResult, degraded: PlanResult) -> bool:
    """Whether the shifted plan breaks no constraint nor the separation from the replan's step
    on, and fails no task that ``degraded`` does not drop."""
    assert shifted.trajectory is not None
    report = monitor_check(again, shifted.trajectory, planned_only=True)
    failed = [v for v in report.verdicts if not v.satisfied]
    dropped = {d.task for d in degraded.dropped}
    return all(v.kind in ("task", "synchronous") and v.name in dropped for v in failed)


def keeps_every_task(again: Problem, shifted: PlanResult) -> bool:
    """Whether the shifted plan meets every task, and every constraint and separation from the
    replan's step on (what the executed past broke aside)."""
    assert shifted.trajectory is not None
    return monitor_check(again, shifted.trajectory, planned_only=True).satisfied


def _answered(
    deadline: Deadline,
    again: Problem,
    fallback: PlanResult | None,
    why: str,
    planned: Problem,
    found: PlanResult | None = None,
) -> tuple[Problem, PlanResult]:
    """The shifted plan (or, without a current plan, the search's result or no plan)."""
    if fallback is not None:
        message = f"no new plan by the deadline of {deadline.seconds:g} s ({why}); "
        out = dataclasses.replace(fallback, message=message + fallback.message)
        return again, _with_answer(out, deadline, "shifted plan", why, _record(again))
    if found is None:
        message = f"no plan by the deadline of {deadline.seconds:g} s ({why}) and no plan to go on"
        found = PlanResult(PlanStatus.NO_PLAN, message)
    return planned, _with_answer(found, deadline, "nothing", why, _record(again))


def _record(again: Problem) -> Replan:
    """The replan record of an answer that is not the search's: its step and events."""
    assert again.past is not None
    return Replan(again.past.step, tuple(again.past.events()))


def _why_found(found: PlanResult) -> str:
    if found.status is PlanStatus.DEGRADED and found.dropped:
        names = ", ".join(d.task for d in found.dropped)
        return f"{counted(len(found.dropped), 'task')} cannot be met ({names})"
    if found.status is PlanStatus.OPTIMAL:
        return "proven optimal in time"
    return "the best plan found in time"


def _with_answer(
    result: PlanResult, deadline: Deadline, came_back: str, why: str, record: Replan | None = None
) -> PlanResult:
    """``result`` with its :class:`Replan` record (``record`` when it has none) saying what came
    back, why, and when."""
    seconds = time.perf_counter() - deadline.start
    record = result.replan or record
    assert record is not None
    record = dataclasses.replace(
        record, seconds=seconds, deadline=deadline.seconds, came_back=came_back, why=why
    )
    message = result.message
    if came_back in ("new plan", "degraded plan"):
        message = f"{came_back} by the deadline of {deadline.seconds:g} s; {message}"
    return dataclasses.replace(result, replan=record, message=message)
