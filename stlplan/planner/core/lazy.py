"""Step 1 with lazy constraints: solve, add the requirements the plan violates, solve again.

The loop runs around HiGHS, on one model kept loaded
(:class:`stlplan.planner.backend.session.HighsSession`). Round ``i`` solves problem (step1) with only the
step requirements (:mod:`stlplan.planner.encoding.deferred`) added so far: a relaxation of the
full problem, so its dual bound ``U_i`` bounds the full optimum from above, and so does the least
of them. The requirements its plan violates (found with numpy on the trajectory) are then encoded exactly as the up-front formulation
encodes them, and the next round starts, given the best plan so far that meets every
requirement (it meets the new ones too) to start from. Each round adds at least one
requirement, so the loop ends. While no plan meets every requirement and rounds are long, a
round's plan is first repaired agent by agent (:mod:`stlplan.planner.core.in_turn`): a large team
packed in a start area may otherwise wait several long rounds for its first plan.

While a round runs, every improving plan HiGHS finds is also checked against the requirements
not yet in the model. A plan that violates none is feasible for the full problem; the best such
plan ``L`` is kept across rounds, and the loop stops as soon as ``(U_i - L) / |L|`` is within the
gap, often before the last round would have ended. Either way the result is the full problem's
optimum to the same tolerance as an up-front solve.

When the time limit ends the loop without a plan feasible for the full problem, the last round's
plan is *completed*: its binaries are fixed, all remaining requirements added, and HiGHS looks for
a plan with those decisions (a small MILP) in the grace a finishing solve has past the run's
deadline (:mod:`stlplan.planner.core.completion`).
"""

from __future__ import annotations

import contextlib
import math
import time
from collections.abc import Callable, Iterator

from pyomo.contrib.solver.common.results import TerminationCondition

from stlplan.planner.backend.session import HighsSession, Solved, has_solution, plan_status
from stlplan.planner.config import PlannerConfig
from stlplan.planner.core.around import Publisher
from stlplan.planner.core.completion import complete
from stlplan.planner.core.in_turn import agents_of
from stlplan.planner.core.policy import RepairPolicy
from stlplan.planner.core.repairs import Broken
from stlplan.planner.core.watch import Watch, load_plan, pending_violations
from stlplan.planner.encoding.deferred import kind
from stlplan.planner.encoding.model import PlanModel, add_requirements
from stlplan.planner.run import outcome
from stlplan.planner.run.budget import Budget, least_solve
from stlplan.planner.run.clock import Clock
from stlplan.planner.run.outcome import Outcome, Plan, lowest, relative_gap
from stlplan.result import PlanStatus


class LazySolver:
    """The loop of the module docstring on one model; :meth:`run` may be called again.

    Parameters
    ----------
    pm
        A model built with ``lazy=True`` (or without: then a run is one solve).
    config
        The run's configuration (solver settings, the repairs' shares).
    clock
        Progress reporting; every solve is recorded in ``clock.round_log``.
    policy
        When a round's plan is repaired in turn (default: ``config``'s).
    whole
        Whether ``pm`` is the whole team's model: its plans and bounds are then the run's
        (:mod:`stlplan.planner.run.convergence`), not a part's.
    """

    def __init__(
        self,
        pm: PlanModel,
        config: PlannerConfig,
        clock: Clock,
        policy: RepairPolicy | None = None,
        whole: bool = False,
    ) -> None:
        self.pm, self.config, self.clock, self.whole = pm, config, clock, whole
        self.policy = policy or RepairPolicy.of(config)
        self.min_solve = least_solve(config)
        self.session = HighsSession(pm.model, config, clock, "step1")
        self.watch: Watch | None = None
        if pm.deferral is not None:
            self.watch = Watch(pm, self.session.keys, config.solver.gap)
            self.watch.first = config.solver.first_plan
            if config.solver.first_plan:
                self.session.set_gaps(self._first_gap(config.solver.gap))
            self.session.listen(self.watch.on_plan, self.watch.maybe_stop)
            self.watch.found = self._kept
        elif config.solver.first_plan:  # every requirement in the model: HiGHS's first plan
            self.session.first_plan_only()
        self.trial = False
        self.rounded: Callable[[], None] | None = None
        """Called at the end of every round but a trial's (the parts record the whole's bound)."""
        self.published: Publisher | None = None
        """Other parts' first plans for the repairs to plan around (:mod:`.around`)."""
        if whole:
            self.session.follow(lambda: self.session.trial, clock, pm.deferral is None)

    def _kept(self, objective: float) -> None:
        """The watch kept a plan with ``objective``: credited to the stage the part is in, and
        for the whole team's model a plan of the run (:mod:`stlplan.planner.run.trace`)."""
        self.clock.reached.kept()
        if self.whole:
            self.clock.plan_found(objective)

    def sibling(self, pm: PlanModel) -> LazySolver:
        """A lazy loop of another model (a part's) with this loop's configuration, clock and
        repair policy."""
        return LazySolver(pm, self.config, self.clock, self.policy)

    def stop_at_first_plan(self, first: bool) -> None:
        """Stop at the first plan that meets every requirement, the rounds meanwhile solved to
        ``repair.gap`` (their plans show what to add; their bounds still bound), or go back to
        the run's gap."""
        if self.watch is None:
            return
        self.watch.first = first
        gap = self.config.solver.gap
        loose = max(gap, self.config.repair.gap)
        self.session.set_gaps(self._first_gap(loose) if first else gap)

    def _first_gap(self, gap: float) -> float:
        """The gap of the rounds of a loop that looks for its first plan: ``gap``, or the looser
        ``repair.by_elements_gap`` where the repair by elements may run (it takes the round's
        choices, not its optimum)."""
        return self.policy.first_gap(self.pm.problem, gap, self.config.repair.by_elements_gap)

    @contextlib.contextmanager
    def lent(self, gap: float) -> Iterator[HighsSession]:
        """The session, for other solves of the model (a prioritized turn's) within the block:
        without the loop's watch, a trial, at the relative gap ``gap`` (or the run's, when
        looser)."""
        watch = self.watch
        if watch is not None:
            self.session.unlisten(watch.on_plan, watch.maybe_stop)
        try:
            with self.session.looking_for_a_plan(gap):
                yield self.session
        finally:
            if watch is not None:
                self.session.listen(watch.on_plan, watch.maybe_stop)

    def run(self, budget: Budget, abs_gap: float | None = None, trial: bool = False) -> Outcome:
        """Solve within ``budget``, to the relative gap (or to ``abs_gap`` alone).

        The plan of the returned :class:`Outcome` (when there is one) is loaded into ``pm``. A
        ``trial`` neither confirms an infeasible verdict nor completes a plan at the time limit
        (no plan then).
        """
        tick, watch, first = time.perf_counter(), self.watch, len(self.clock.round_log)
        self._begin(abs_gap, trial)
        while True:
            if watch is not None:
                watch.stopped = False  # (the session clears HiGHS's stale interrupt flag)
                if watch.best is not None:
                    self.session.start_from(watch.best)
            else:  # every requirement in the model: one solve
                self.clock.reached.enter("up front")
            self.clock.next_round()
            solved = self._recorded_round(self.session.solve(budget))
            if watch is None:
                return _ended(solved, time.perf_counter() - tick, 1, 0)
            ended = self._after_round(solved, budget, tick, first)
            if ended is not None:
                return self._capped(ended)

    def _begin(self, abs_gap: float | None, trial: bool) -> None:
        """Begin a run that is a ``trial`` or not, to the relative gap or to ``abs_gap`` alone."""
        self.trial = self.session.trial = trial
        if abs_gap is not None:  # the absolute gap alone decides
            self.session.set_gaps(abs_gap=abs_gap)
            if self.watch is not None:
                self.watch.abs_gap, self.watch.gap = abs_gap, 0.0

    def _recorded_round(self, solved: Solved) -> Solved:
        """``solved``, a round just solved, recorded on the clock."""
        pm, clock, watch = self.pm, self.clock, self.watch
        results = solved.results
        if watch is not None:
            best = None if watch.best is None else watch.best.objective
        else:  # HiGHS's plan meets every requirement
            best = results.incumbent_objective if has_solution(results) else None
        held = added_by_kind(pm) if pm.deferral is not None else {}
        agents = [a.name for a in pm.problem.agents]
        ended = results.termination_condition.name
        bound = results.objective_bound
        clock.record_round(agents, solved.seconds, ended, bound, best, held, solved.nodes)
        return solved

    def _capped(self, step1: Outcome) -> Outcome:
        """``step1`` with the watch's ceiling as its bound when that is tighter."""
        assert self.watch is not None
        ceiling = self.watch.ceiling
        return outcome.capped(step1, ceiling, self.watch.closed(lowest(step1.bound, ceiling)))

    def _after_round(
        self, solved: Solved, budget: Budget, tick: float, first: int
    ) -> Outcome | None:
        """How the rounds end after the round ``solved`` (the loop began at ``tick``, with the
        round log ``first`` long), or None: its violations added, another round."""
        pm, clock, watch = self.pm, self.clock, self.watch
        assert pm.deferral is not None and watch is not None
        rounds, seconds = len(clock.round_log) - first, time.perf_counter() - tick
        results = solved.results
        bound = results.objective_bound
        if not self.trial and bound is not None and math.isfinite(bound):
            watch.ceiling = lowest(bound, watch.ceiling)  # every round bounds the problem
        self._recorded(bound)
        if watch.best is not None and watch.closed(results.objective_bound):
            return self._from_best(solved, tick, rounds, PlanStatus.OPTIMAL)
        if watch.done():
            return self._from_best(solved, tick, rounds, PlanStatus.FEASIBLE)
        converged = (
            results.termination_condition == TerminationCondition.convergenceCriteriaSatisfied
        )
        bad = pending_violations(pm) if has_solution(results) else []
        if converged and not bad:
            done = _ended(solved, seconds, rounds, len(pm.added))
            return outcome.within(done, watch.gap) if watch.first else done  # (maybe a loose round)
        left = budget.remaining()
        # another round while the time left is what this one took (or a least solve)
        needed = min(self.min_solve, solved.seconds)
        out_of_time = not (converged or watch.stopped) or left < needed
        if solved.stopped or out_of_time:
            return self._last(solved, tick, rounds, budget)
        length = solved.length(self.config.solver.deterministic)
        self._repair_between_rounds(bad, budget, length)
        if watch.closed(watch.ceiling):
            return self._from_best(solved, tick, rounds, PlanStatus.OPTIMAL)
        if watch.done():  # a repair found the first plan
            return self._from_best(solved, tick, rounds, PlanStatus.FEASIBLE)
        add_requirements(pm, bad)
        return None

    def _recorded(self, bound: float | None) -> None:
        """Outside a trial, a round's bound (a relaxation's) is the run's when the model is the
        whole team's, and the parts' sum is brought up to date."""
        if self.trial:
            return
        if self.whole:
            self.clock.bound_found(bound, force=True)
        if self.rounded is not None:
            self.rounded()

    def _repair_between_rounds(self, bad: list[int], budget: Budget, seconds: float) -> None:
        """Repair the round's plan (which violates ``bad``) in turn while no plan meets every
        requirement and the round (of ``seconds``) was long or crowded (the repair policy);
        the watch keeps the repaired plan. The violated requirements are added
        after it, for the next round (none when no round follows)."""
        pm, watch = self.pm, self.watch
        assert watch is not None
        if watch.best is not None:  # a plan meets every requirement: the rounds prove
            return
        repairs = self.policy.round_repairs(seconds, len(agents_of(pm, bad)), watch.first)
        for repair, share in repairs:
            plan = repair.repair(Broken(self, bad), self.config, budget.share(share))
            if plan is not None:
                watch.offer(plan)
                return

    def _last(self, last: Solved, tick: float, rounds: int, budget: Budget) -> Outcome:
        """The loop ends short of the optimum (time, a stop request, infeasible, an error).

        The best plan feasible for the full problem is kept. Without one, the last round's plan
        (which violates some requirement left out) is completed (:func:`_complete`), unless the
        user asked to stop: then there is no plan.
        """
        if self.watch is not None and self.watch.best is not None:
            return self._from_best(last, tick, rounds, outcome.kept_status(last.stopped))
        ended = _ended(last, time.perf_counter() - tick, rounds, len(self.pm.added))
        given_up = outcome.cut_short(ended, last.stopped, has_solution(last.results), self.trial)
        if given_up is not None:
            return given_up
        self.clock.reached.enter("completion")  # the last stage: it ends the part's solve
        with self.clock.reached.timed("completion"):
            return complete(self.pm, self.session, last, tick, rounds, budget.finishing())

    def _from_best(self, last: Solved, tick: float, rounds: int, status: PlanStatus) -> Outcome:
        """Load the best plan feasible for the full problem; the bound is the last round's.

        Requirements added after the plan was found get the side the plan meets best
        (:func:`stlplan.planner.encoding.model.assign_side`), so every indicator and binary agrees.
        """
        objective = self._load_best()
        bound = last.results.objective_bound
        return Outcome(
            status=status,
            objective=objective,
            bound=bound,
            gap=relative_gap(objective, bound),
            seconds=time.perf_counter() - tick,
            rounds=rounds,
            added=len(self.pm.added),
            stop=last.results.termination_condition.name,
        )

    def repaired(self, plan: Plan, seconds: float) -> Outcome:
        """The best of ``plan`` (a repair's, meeting every requirement) and the plans found so
        far, loaded into ``pm``, as a result without a bound."""
        assert self.watch is not None
        self.watch.offer(plan)
        objective = self._load_best()
        return Outcome(PlanStatus.FEASIBLE, objective, None, None, seconds, 0, len(self.pm.added),
                     "repaired")  # fmt: skip

    def _load_best(self) -> float:
        """Load the watch's best plan; requirements added after it was found get the side the
        plan meets best. Returns its objective."""
        pm, watch = self.pm, self.watch
        assert watch is not None and watch.best is not None and pm.deferral is not None
        load_plan(pm, watch.best.values, watch.best.added)
        return watch.best.objective


def added_by_kind(pm: PlanModel) -> dict[str, int]:
    """The lazy requirements ``pm`` holds, counted by kind: separation or a constraint, at a
    step or on a segment."""
    assert pm.deferral is not None
    counts: dict[str, int] = {}
    for n in pm.added:
        key = kind(pm.deferral.lazy[n])
        counts[key] = counts.get(key, 0) + 1
    return counts


def solve_step1(solver: LazySolver, budget: Budget, start: Plan | None = None) -> Outcome:
    """Solve problem (step1) of the whole team's model by its loop ``solver`` (its plans and
    bounds are the run's) within ``budget``, lazily when the model was built with ``lazy=True``,
    the first solve starting from ``start``."""
    clock = solver.clock
    clock.reached.solving([a.name for a in solver.pm.problem.agents])
    if start is not None:
        solver.session.start_from(start)
    ended = solver.run(budget)
    if ended.status.has_plan:
        clock.plan_found(ended.objective)  # (at the latest: when step 1 ends with one)
    return ended


def _ended(solved: Solved, seconds: float, rounds: int, added: int) -> Outcome:
    results = solved.results
    return Outcome(
        status=plan_status(results, solved.stopped),
        objective=results.incumbent_objective,
        bound=results.objective_bound,
        gap=solved.gap,
        seconds=seconds,
        rounds=rounds,
        added=added,
        stop=results.termination_condition.name,
    )
