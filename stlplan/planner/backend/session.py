"""HiGHS through Pyomo: a model kept loaded across solves.

The run's clock and progress reports are in :mod:`stlplan.planner.run.clock`; every
infeasible verdict a solve returns is first confirmed (:mod:`stlplan.planner.backend.confirm`).

A :class:`HighsSession` loads a Pyomo model into one ``highspy.Highs`` object once; later solves
of the same model send HiGHS only what changed (Pyomo's persistent interface detects added rows
and variables, and changed bounds), which the lazy loop of :mod:`stlplan.planner.core.lazy` relies on.

Progress: HiGHS callbacks (improving solution, MIP interrupt) are registered on the
``highspy.Highs`` object inside Pyomo's solver. Pyomo's capture of the process's output around
a solve is off for the planner's solves (:mod:`stlplan.planner.backend.uncaptured`), so what a progress
callback prints meanwhile goes where it would otherwise.
"""

from __future__ import annotations

import contextlib
import logging
import math
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import highspy
import numpy as np
from pyomo.contrib.solver.common.results import Results, SolutionStatus, TerminationCondition
from pyomo.contrib.solver.solvers.highs import Highs
from pyomo.environ import ConcreteModel

from stlplan.planner.backend import confirm, uncaptured
from stlplan.planner.backend.progress import Heard, Listener, follow, report_progress, searching
from stlplan.planner.backend.values import ColumnKeys
from stlplan.planner.config import PlannerConfig
from stlplan.planner.run.budget import Budget, least_solve
from stlplan.planner.run.clock import Clock, Phase
from stlplan.planner.run.outcome import Plan, of_solve
from stlplan.planner.tolerances import ROUND_OFF
from stlplan.result import PlanStatus
from stlplan.runtime import signals

_STATUS: dict[TerminationCondition, tuple[PlanStatus, PlanStatus]] = {
    # termination condition: (status with a plan, status without one)
    TerminationCondition.convergenceCriteriaSatisfied: (PlanStatus.OPTIMAL, PlanStatus.ERROR),
    TerminationCondition.maxTimeLimit: (PlanStatus.FEASIBLE, PlanStatus.NO_PLAN),
    TerminationCondition.iterationLimit: (PlanStatus.FEASIBLE, PlanStatus.NO_PLAN),
    TerminationCondition.objectiveLimit: (PlanStatus.FEASIBLE, PlanStatus.NO_PLAN),
    TerminationCondition.interrupted: (PlanStatus.FEASIBLE, PlanStatus.NO_PLAN),
    TerminationCondition.provenInfeasible: (PlanStatus.INFEASIBLE, PlanStatus.INFEASIBLE),
    TerminationCondition.infeasibleOrUnbounded: (PlanStatus.INFEASIBLE, PlanStatus.INFEASIBLE),
}


def plan_status(results: Results, stopped: bool = False) -> PlanStatus:
    """The :class:`PlanStatus` of a HiGHS result (one table, :data:`_STATUS`).

    ``stopped``: the user asked to stop, so a solve cut short is "interrupted".
    """
    with_plan, without = _STATUS.get(
        results.termination_condition, (PlanStatus.ERROR, PlanStatus.ERROR)
    )
    return of_solve(has_solution(results), stopped, with_plan, without)


def has_solution(results: Results) -> bool:
    """Whether HiGHS returned a primal feasible point."""
    return results.solution_status in (SolutionStatus.optimal, SolutionStatus.feasible)


_SCHEDULER: dict[str, int | None] = {}


def use_threads(threads: int | None) -> None:
    """Restart HiGHS's process-wide thread pool when the thread count changes.

    HiGHS sizes one global scheduler at its first solve and fails later solves that ask for a
    different ``threads``; a planning run in the same process must not inherit that.
    """
    if _SCHEDULER.get("threads", threads) != threads:
        highspy.Highs.resetGlobalScheduler(True)
    _SCHEDULER["threads"] = threads


WORK_RATE = 10_000.0
"""Simplex iterations a second, for a deterministic run's lengths (``solver.deterministic``):
about what one HiGHS thread makes on the farm's lazy rounds here (4,600 to 13,600, most near
9,000)."""


@dataclass(frozen=True)
class Solved:
    """One HiGHS solve: its results (solution loaded when there is one), wall time, MIP gap."""

    results: Results
    seconds: float
    gap: float | None
    stopped: bool = False
    """Whether the user asked to stop (:mod:`stlplan.runtime.signals`): the solve was cut short."""
    nodes: int | None = None
    """Branch-and-bound nodes HiGHS explored (None for an LP or without HiGHS's figures)."""
    iterations: int | None = None
    """Simplex iterations HiGHS made, in every node (None without HiGHS's figures)."""

    def length(self, deterministic: bool) -> float:
        """How long the solve took, s: its wall time, or with ``deterministic`` its work (its
        simplex iterations at :data:`WORK_RATE` a second)."""
        if deterministic and self.iterations is not None:
            return self.iterations / WORK_RATE
        return self.seconds


class HighsSession:
    """A Pyomo model loaded into HiGHS once and solved as often as needed.

    Parameters
    ----------
    model
        The model; rows and variables added to it later reach HiGHS at the next solve.
    config
        The run's configuration: ``solver`` (time limit, gap, threads, seed, extra HiGHS
        options) and ``budget`` (the least time of a solve and of a confirmation).
    clock
        Progress reporting.
    phase
        Phase named in progress reports.
    mip
        Apply the relative gap (a MILP).
    """

    def __init__(
        self,
        model: ConcreteModel,
        config: PlannerConfig,
        clock: Clock,
        phase: Phase,
        mip: bool = True,
    ) -> None:
        self.model, self.config, self.clock, self.phase, self.mip = (
            model, config, clock, phase, mip
        )  # fmt: skip
        self._nodes: int | None = None  # branch-and-bound nodes of the solve under way
        self._iterations: int | None = None  # simplex iterations of the solve under way
        self.solver = Highs()
        settings = self.solver.config
        settings.load_solutions = False
        settings.raise_exception_on_nonoptimal_result = False
        settings.threads = config.solver.used_threads()
        settings.solver_options = {
            "random_seed": config.solver.seed,
            "output_flag": False,
            **config.solver.highs_options,
        }
        if mip:
            settings.rel_gap = config.solver.gap
        clock.report(phase)
        # Pyomo warns on HiGHS's "interrupted" status; every interrupt here is on purpose (the
        # lazy loop's, a stop request) and mapped by plan_status.
        logging.getLogger("pyomo.contrib.solver.solvers.highs").setLevel(logging.ERROR)
        use_threads(config.solver.used_threads())
        with clock.building(), uncaptured.solves():
            self.solver.set_instance(model)
        self.highs: highspy.Highs = self.solver._solver_model
        self._fresh = True
        self.verdict = ""
        """HiGHS's model status of the last solve, by name."""
        self.trial = False
        """Whether an infeasible verdict is taken as it is (a trial solve, whose verdict decides
        nothing about the mission)."""
        self._start: tuple[np.ndarray, np.ndarray] | None = None
        self._listeners: dict[tuple[Heard, Heard], tuple[Listener, Listener]] = {}
        self.keys = ColumnKeys(model, self.columns)
        """The key of each HiGHS column (plans are values by key)."""
        self.highs.cbMipUserSolution.subscribe(self._give_start)
        self.highs.cbMipInterrupt.subscribe(self._clear_stale_interrupt)
        for callbacks in (
            self.highs.cbMipInterrupt,
            self.highs.cbSimplexInterrupt,
            self.highs.cbIpmInterrupt,
        ):
            callbacks.subscribe(self._stop_if_asked)
        report_progress(self.highs, clock, phase)

    def listen(self, on_plan: Heard, on_progress: Heard) -> None:
        """Call ``on_plan`` at every improving plan of the MIP search and ``on_progress`` at
        its regular checks (until :meth:`unlisten`)."""
        plan, progress = self._listeners.setdefault(
            (on_plan, on_progress),
            (lambda e: on_plan(searching(e, True)), lambda e: on_progress(searching(e, False))),
        )
        self.highs.cbMipImprovingSolution.subscribe(plan)
        self.highs.cbMipInterrupt.subscribe(progress)

    def unlisten(self, on_plan: Heard, on_progress: Heard) -> None:
        """Stop calling what :meth:`listen` gave."""
        plan, progress = self._listeners[(on_plan, on_progress)]
        self.highs.cbMipImprovingSolution.unsubscribe(plan)
        self.highs.cbMipInterrupt.unsubscribe(progress)

    def listening(self, on_plan: Heard, on_progress: Heard) -> bool:
        """Whether the search's news go to ``on_plan`` and ``on_progress`` (:meth:`listen`)."""
        heard = self._listeners.get((on_plan, on_progress))
        return heard is not None and (
            heard[0] in self.highs.cbMipImprovingSolution.callbacks
            and heard[1] in self.highs.cbMipInterrupt.callbacks
        )

    def set_gaps(self, rel: float | None = None, abs_gap: float | None = None) -> None:
        """The relative gap at which solves stop (None keeps it), or the absolute one alone
        (``abs_gap``: the relative one is then 0)."""
        settings = self.solver.config
        if abs_gap is not None:
            settings.abs_gap, settings.rel_gap = abs_gap, 0.0
        elif rel is not None:
            settings.rel_gap = rel

    @property
    def rel_gap(self) -> float:
        """The relative gap at which solves stop."""
        return float(self.solver.config.rel_gap or 0.0)

    def first_plan_only(self) -> None:
        """Stop each solve at its first improving plan (a model holding every requirement:
        that plan meets them all)."""
        options = self.solver.config.solver_options
        self.solver.config.solver_options = {**options, "mip_max_improving_sols": 1}

    def last_point(self) -> np.ndarray:
        """The point the last solve ended at (HiGHS's column vector; empty without one)."""
        return np.asarray(self.highs.getSolution().col_value)

    def follow(self, trial: Callable[[], bool], recorder: Clock, plans: bool) -> None:
        """Record the whole problem's figures while it solves (:func:`~.progress.follow`)."""
        follow(self.highs, trial, recorder, plans)

    def _stop_if_asked(self, event: highspy.HighsCallbackEvent) -> None:
        """Interrupt HiGHS when the user asked to stop (:mod:`stlplan.runtime.signals`)."""
        if signals.should_interrupt():
            event.interrupt()

    def _clear_stale_interrupt(self, event: highspy.HighsCallbackEvent) -> None:
        """HiGHS keeps an interrupt flag set by an earlier solve; clear it once per solve."""
        if self._fresh and event.data_in is not None:
            event.interrupt(False)
            self._fresh = False

    def start_from(self, plan: Plan) -> None:
        """Give the next solve ``plan`` to start from; HiGHS completes the variables it does
        not give (columns added since it was found, or a start of states and inputs only), or
        drops it."""
        self._start = self.keys.start(plan.values)

    def _give_start(self, event: highspy.HighsCallbackEvent) -> None:
        start, self._start = self._start, None
        if start is None or event.data_in is None or len(start[0]) == 0:
            return
        columns, values = start
        event.data_in.setSolution(columns, values)
        if len(columns) < self.highs.getNumCol():
            event.data_in.repairSolution()

    @contextlib.contextmanager
    def looking_for_a_plan(self, gap: float) -> Iterator[None]:
        """Within the block, solves stop at the relative gap ``gap`` (or the run's, when looser)
        and are trials: a repair looks for a plan, and its bound and verdicts prove nothing."""
        settings, usual, trial = self.solver.config, self.solver.config.rel_gap, self.trial
        settings.rel_gap, self.trial = max(gap, usual or 0.0), True
        try:
            yield
        finally:
            settings.rel_gap, self.trial = usual, trial

    def load_changes(self) -> None:
        """Send HiGHS what changed in the model since the last solve (rows and variables
        added, bounds changed) now rather than at the next solve, counted as building: a solve's
        time limit does not bound it."""
        with self.clock.building():
            self.solver.update()

    def columns(self) -> dict[int, int]:
        """HiGHS column of each Pyomo variable in the model, by ``id`` (fixed ones have none)."""
        return dict(self.solver._pyomo_var_to_solver_var_map)

    def solve(self, budget: Budget) -> Solved:
        """Solve (again) within ``budget`` (at least one least solve).

        An infeasible verdict is confirmed (:mod:`stlplan.planner.backend.confirm`) before it is returned; when
        a confirmation solve finds a plan, that solve is the one returned.
        """
        tick = time.perf_counter()
        self._nodes = self._iterations = None
        results = self.solve_once(budget.remaining())
        if self.mip and results.termination_condition == TerminationCondition.error:
            # HiGHS's "solve error": its optimum fails its own check by more than its feasibility
            # tolerance, binaries accepted within the integrality tolerance (a nearly infeasible
            # model); solved again with that tolerance at round-off, HiGHS decides it
            results = self.solve_once(budget.remaining(), {"mip_feasibility_tolerance": ROUND_OFF})
        infeasible = results.termination_condition in (
            TerminationCondition.provenInfeasible,
            TerminationCondition.infeasibleOrUnbounded,
        )
        if infeasible and not self.trial and not signals.should_interrupt():
            first = (self.verdict, time.perf_counter() - tick)
            results = self._confirmed(results, first, budget)
        seconds = time.perf_counter() - tick
        gap, nodes = None, self._nodes
        if self.mip and self.highs is not None and has_solution(results):
            gap = float(self.highs.getInfo().mip_gap)  # HiGHS reports inf without an integer
            if not math.isfinite(gap):
                optimal = (
                    results.termination_condition
                    == TerminationCondition.convergenceCriteriaSatisfied
                )
                gap = 0.0 if optimal else None
        if has_solution(results):
            results.solution_loader.load_vars()
        stopped = signals.should_interrupt()
        return Solved(results, seconds, gap, stopped, nodes, self._iterations)

    def solve_once(self, seconds: float, settings: confirm.Settings | None = None) -> Results:
        """One HiGHS solve through Pyomo within ``seconds`` (at least
        one least solve, :func:`~stlplan.planner.run.budget.least_solve`), with extra options."""
        config = self.solver.config
        config.time_limit = max(least_solve(self.config), seconds)
        self._fresh = True
        use_threads(self.config.solver.used_threads())
        usual = config.solver_options
        config.solver_options = {**usual, **(settings or {})}
        try:
            with signals.solving(), uncaptured.solves():
                results = self.solver.solve(self.model)
        finally:
            config.solver_options = usual
        self.verdict = confirm.verdict(self.highs)
        if self.highs is not None:  # every run of a solve, confirmations included
            info = self.highs.getInfo()
            self._iterations = (self._iterations or 0) + max(0, int(info.simplex_iteration_count))
            nodes = int(info.mip_node_count)  # (HiGHS says -1 for a model without integers)
            if self.mip and nodes >= 0:
                self._nodes = (self._nodes or 0) + nodes
        signals.raise_if_hard()
        if self.clock.error is not None:
            raise self.clock.error
        return results

    def _confirmed(self, results: Results, first: tuple[str, float], budget: Budget) -> Results:
        """The results after confirming an infeasible verdict (recorded on the clock)."""
        last = [results]

        def run(settings: confirm.Settings, limit: float) -> None:
            last[0] = self.solve_once(limit, settings)

        where: str = self.phase
        if self.phase == "step1" and self.clock.round is not None:
            where += f" round {self.clock.round}"
        confirmation = confirm.confirm(
            self.highs,
            first,
            run,
            self.config.solver.seed,
            budget.remaining,
            where,
            least_solve(self.config),
        )
        self.clock.confirmations.append(confirmation)
        return last[0]


def solve_once(
    model: ConcreteModel,
    config: PlannerConfig,
    clock: Clock,
    phase: Phase,
    budget: Budget,
    mip: bool = True,
) -> tuple[Results, float, float | None]:
    """One HiGHS solve of ``model`` within ``budget``; returns the results, its wall time and
    HiGHS's MIP gap."""
    solved = HighsSession(model, config, clock, phase, mip).solve(budget)
    return solved.results, solved.seconds, solved.gap
