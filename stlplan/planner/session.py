"""HiGHS through Pyomo: planning options and a model kept loaded across solves.

The run's clock and progress reports are in :mod:`stlplan.planner.clock`; every
infeasible verdict a solve returns is first confirmed (:mod:`stlplan.planner.confirm`).

A :class:`HighsSession` loads a Pyomo model into one ``highspy.Highs`` object once; later solves
of the same model send HiGHS only what changed (Pyomo's persistent interface detects added rows
and variables, and changed bounds), which the lazy loop of :mod:`stlplan.planner.lazy` relies on.

Progress: HiGHS callbacks (improving solution, MIP interrupt) are registered on the
``highspy.Highs`` object inside Pyomo's solver; Pyomo redirects stdout/stderr during a solve,
so whatever the progress callback prints then is forwarded to the real stderr.
"""

from __future__ import annotations

import logging
import math
import sys
import time
from dataclasses import dataclass, fields, replace
from typing import Any

import highspy
import numpy as np
from highspy import cb
from pyomo.contrib.solver.common.results import Results, SolutionStatus, TerminationCondition
from pyomo.contrib.solver.solvers.highs import Highs
from pyomo.environ import ConcreteModel

from stlplan.mission.schema import Mission
from stlplan.planner import confirm, stops
from stlplan.planner.clock import (
    Clock,
    Phase,
)
from stlplan.planner.encoding.selection import TaskForm
from stlplan.planner.encoding.sos1 import Encoding
from stlplan.result import PlanStatus


@dataclass(frozen=True)
class PlanOptions:
    """Options of one planning run.

    Attributes
    ----------
    time_limit
        Wall-clock limit of the whole run, s: building, every lazy round and part, step 2, the
        confirmation of infeasible verdicts and the diagnosis share it (:class:`Clock`).
    gap
        Relative optimality gap at which HiGHS stops step 1.
    threads
        Threads HiGHS may use (None: HiGHS decides).
    seed
        HiGHS random seed.
    encoding
        Disjunctions with one binary per entry (``standard``, the default: measured the faster
        over the general-STL suite and the farm cases) or as a logarithmic SOS1 (``log``).
    tasks
        Tasks by selecting elements (``selection``, no group enumerated) or by the paper's
        group enumeration (``groups``).
    two_step
        Run step 2 (fix step 1's decisions, minimize the mission's effort norm).
    lazy
        Leave the step requirements of constraints and separation (obstacle avoidance, collision
        avoidance) out of the MILP and add those a plan violates, re-solving until none is
        violated (:mod:`stlplan.planner.lazy`); False encodes them all up front.
    lazy_window
        With ``lazy``: a violated requirement also brings the requirements of the same agent (or
        pair) within this many steps; None brings every step.
    lazy_margin
        With ``lazy``: when a round's plan violates requirements, every requirement it meets by
        less than this margin is added too.
    decompose
        With ``lazy``: solve independent parts of the team apart (:mod:`stlplan.planner.components`).
    floors
        Add the effort floors of :mod:`stlplan.planner.encoding.floors` (valid inequalities).
    highs_options
        Extra HiGHS options, ``(name, value)`` pairs, for experiments.
    """

    time_limit: float = 300.0
    gap: float = 1e-4
    threads: int | None = None
    seed: int = 0
    encoding: Encoding = "standard"
    tasks: TaskForm = "selection"
    two_step: bool = True
    lazy: bool = True
    lazy_window: int | None = 0
    lazy_margin: float = 0.0
    decompose: bool = True
    floors: bool = True
    highs_options: tuple[tuple[str, Any], ...] = ()

    @classmethod
    def from_mission(cls, mission: Mission, overrides: Overrides | None = None) -> PlanOptions:
        """Defaults from ``mission.solver`` and ``mission.objective``, then ``overrides``."""
        base = cls(
            time_limit=mission.solver.time_limit,
            gap=mission.solver.gap,
            threads=mission.solver.threads,
            seed=mission.solver.seed,
            encoding=mission.solver.encoding,
            tasks=mission.solver.tasks,
            two_step=mission.objective.two_step,
        )
        return base if overrides is None else overrides.applied(base)


@dataclass(frozen=True)
class Overrides:
    """What one run changes of a mission's settings (the command line's options); None keeps
    the mission's value.

    Attributes
    ----------
    time_limit, gap, threads, seed, encoding, tasks, two_step
        As in :class:`PlanOptions`.
    inter_sample
        Judge safety on the segments between steps (the mission's ``safety.inter_sample``).
    tuning
        Other :class:`PlanOptions` fields as ``(name, value)`` pairs, e.g. ``(("lazy", False),)``
        (benchmarks compare formulations with them).
    """

    time_limit: float | None = None
    gap: float | None = None
    threads: int | None = None
    seed: int | None = None
    encoding: Encoding | None = None
    tasks: TaskForm | None = None
    two_step: bool | None = None
    inter_sample: bool | None = None
    tuning: tuple[tuple[str, Any], ...] = ()

    def given(self) -> dict[str, Any]:
        """The values set (not None), by name, as the summary records them."""
        out = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "tuning"}
        return {k: v for k, v in out.items() if v is not None} | dict(self.tuning)

    def applied(self, options: PlanOptions) -> PlanOptions:
        """``options`` with the values set here.

        Raises
        ------
        TypeError
            If ``tuning`` names a field :class:`PlanOptions` does not have.
        """
        known = {f.name for f in fields(PlanOptions)}
        unknown = {name for name, _ in self.tuning} - known
        if unknown:
            raise TypeError(f"unknown plan option(s): {', '.join(sorted(unknown))}")
        chosen = {k: v for k, v in self.given().items() if k in known}
        return replace(options, **chosen)


MIN_SOLVE_SECONDS = 1.0
"""Every solve may run at least this long, even when the budget is spent."""

TC = TerminationCondition
_STATUS: dict[TerminationCondition, tuple[PlanStatus, PlanStatus]] = {
    # termination condition: (status with a plan, status without one)
    TC.convergenceCriteriaSatisfied: (PlanStatus.OPTIMAL, PlanStatus.ERROR),
    TC.maxTimeLimit: (PlanStatus.FEASIBLE, PlanStatus.NO_PLAN),
    TC.iterationLimit: (PlanStatus.FEASIBLE, PlanStatus.NO_PLAN),
    TC.objectiveLimit: (PlanStatus.FEASIBLE, PlanStatus.NO_PLAN),
    TC.interrupted: (PlanStatus.FEASIBLE, PlanStatus.NO_PLAN),
    TC.provenInfeasible: (PlanStatus.INFEASIBLE, PlanStatus.INFEASIBLE),
    TC.infeasibleOrUnbounded: (PlanStatus.INFEASIBLE, PlanStatus.INFEASIBLE),
}


def plan_status(results: Results, stopped: bool = False) -> PlanStatus:
    """The :class:`PlanStatus` of a HiGHS result (one table, :data:`_STATUS`).

    ``stopped``: the user asked to stop, so a solve cut short is "interrupted".
    """
    with_plan, without = _STATUS.get(
        results.termination_condition, (PlanStatus.ERROR, PlanStatus.ERROR)
    )
    status = with_plan if has_solution(results) else without
    if stopped and status not in (PlanStatus.OPTIMAL, PlanStatus.INFEASIBLE):
        return PlanStatus.INTERRUPTED if has_solution(results) else PlanStatus.INTERRUPTED_NO_PLAN
    return status


def has_solution(results: Results) -> bool:
    """Whether HiGHS returned a primal feasible point."""
    return results.solution_status in (SolutionStatus.optimal, SolutionStatus.feasible)


def _watch(highs: Any, clock: Clock, phase: Phase) -> None:
    """Report HiGHS's MIP progress to ``clock`` (callbacks on the ``highspy.Highs`` object)."""
    if highs is None or clock.progress is None or not hasattr(highs, "cbMipInterrupt"):
        return
    last = [0.0]

    def on_event(event: Any) -> None:
        now = time.perf_counter()
        improving = event.callback_type == cb.HighsCallbackType.kCallbackMipImprovingSolution
        if improving or now - last[0] >= 0.5:
            last[0] = now
            out = event.data_out
            found = abs(out.mip_primal_bound) < 1e30
            incumbent = out.objective_function_value if found else None
            clock.report(phase, incumbent, out.mip_dual_bound, out.mip_gap if found else None)
        if clock.error is not None:
            event.interrupt()  # the callback failed: stop HiGHS, re-raise after the solve

    highs.cbMipImprovingSolution += on_event
    highs.cbMipInterrupt += on_event


_SCHEDULER: dict[str, int | None] = {}


def use_threads(threads: int | None) -> None:
    """Restart HiGHS's process-wide thread pool when the thread count changes.

    HiGHS sizes one global scheduler at its first solve and fails later solves that ask for a
    different ``threads``; a planning run in the same process must not inherit that.
    """
    if _SCHEDULER.get("threads", threads) != threads:
        highspy.Highs.resetGlobalScheduler(True)
    _SCHEDULER["threads"] = threads


def forget_threads() -> None:
    """Restart the thread pool now (after solves that did not go through :func:`use_threads`)."""
    highspy.Highs.resetGlobalScheduler(True)
    _SCHEDULER.clear()


@dataclass(frozen=True)
class Solved:
    """One HiGHS solve: its results (solution loaded when there is one), wall time, MIP gap."""

    results: Results
    seconds: float
    gap: float | None
    stopped: bool = False
    """Whether the user asked to stop (:mod:`stlplan.planner.stops`): the solve was cut short."""


class HighsSession:
    """A Pyomo model loaded into HiGHS once and solved as often as needed.

    Parameters
    ----------
    model
        The model; rows and variables added to it later reach HiGHS at the next solve.
    options
        Time limit, gap, threads, seed and extra HiGHS options.
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
        options: PlanOptions,
        clock: Clock,
        phase: Phase,
        mip: bool = True,
    ) -> None:
        self.model, self.options, self.clock, self.phase, self.mip = (
            model, options, clock, phase, mip
        )  # fmt: skip
        self.solver = Highs()
        config = self.solver.config
        config.load_solutions = False
        config.raise_exception_on_nonoptimal_result = False
        config.threads = options.threads
        config.solver_options = {
            "random_seed": options.seed,
            "output_flag": False,
            **dict(options.highs_options),
        }
        if mip:
            config.rel_gap = options.gap
        clock.report(phase)
        # Pyomo warns on HiGHS's "interrupted" status; every interrupt here is on purpose (the
        # lazy loop's, a stop request) and mapped by plan_status.
        logging.getLogger("pyomo.contrib.solver.solvers.highs").setLevel(logging.ERROR)
        use_threads(options.threads)
        with clock.building():
            self.solver.set_instance(model)
        self.highs: Any = getattr(self.solver, "_solver_model", None)
        self._fresh = True
        self.verdict = ""
        """HiGHS's model status of the last solve, by name."""
        self.trial = False
        """Whether an infeasible verdict is taken as it is (a trial solve, whose verdict decides
        nothing about the mission)."""
        self._start: np.ndarray | None = None
        if self.highs is not None and hasattr(self.highs, "cbMipInterrupt"):
            self.highs.cbMipUserSolution += self._give_start
            self.highs.cbMipInterrupt += self._clear_stale_interrupt
            for name in ("cbMipInterrupt", "cbSimplexInterrupt", "cbIpmInterrupt"):
                callbacks = getattr(self.highs, name)
                callbacks += self._stop_if_asked
        _watch(self.highs, clock, phase)

    def _stop_if_asked(self, event: Any) -> None:
        """Interrupt HiGHS when the user asked to stop (:mod:`stlplan.planner.stops`)."""
        if stops.should_interrupt():
            event.interrupt()

    def _clear_stale_interrupt(self, event: Any) -> None:
        """HiGHS keeps an interrupt flag set by an earlier solve; clear it once per solve."""
        if self._fresh and event.data_in is not None:
            event.interrupt(False)
            self._fresh = False

    def start_from(self, x: np.ndarray) -> None:
        """Give the next solve a plan to start from: the values of columns ``0..len(x)-1`` (a
        plan of an earlier solve; HiGHS repairs the columns added since, or drops the plan)."""
        self._start = np.asarray(x, dtype=float)

    def _give_start(self, event: Any) -> None:
        start, self._start = self._start, None
        if start is None or event.data_in is None:
            return
        count = min(len(start), int(self.highs.getNumCol()))
        event.data_in.setSolution(np.arange(count, dtype=np.int32), start[:count])
        if count < self.highs.getNumCol():
            event.data_in.repairSolution()

    def columns(self) -> dict[int, int]:
        """HiGHS column of each Pyomo variable in the model, by ``id`` (fixed ones have none)."""
        return dict(self.solver._pyomo_var_to_solver_var_map)

    def solve(self, time_limit: float | None = None, finishing: bool = False) -> Solved:
        """Solve (again) within ``time_limit`` seconds (default: the options' limit) and what the
        run's budget leaves (:meth:`Clock.remaining`, with the grace when ``finishing``).

        An infeasible verdict is confirmed (:mod:`stlplan.planner.confirm`) before it is returned; when
        a confirmation solve finds a plan, that solve is the one returned.
        """
        limit = self.options.time_limit if time_limit is None else time_limit
        tick = time.perf_counter()
        results = self._run(min(limit, self.clock.remaining(finishing)))
        infeasible = results.termination_condition in (
            TC.provenInfeasible,
            TC.infeasibleOrUnbounded,
        )
        if infeasible and not self.trial and not stops.should_interrupt():
            first = (self.verdict, time.perf_counter() - tick)
            results = self._confirmed(results, first, finishing)
        seconds = time.perf_counter() - tick
        gap = None
        if self.mip and self.highs is not None and has_solution(results):
            gap = float(self.highs.getInfo().mip_gap)  # HiGHS reports inf without an integer
            if not math.isfinite(gap):
                optimal = results.termination_condition == TC.convergenceCriteriaSatisfied
                gap = 0.0 if optimal else None
        if has_solution(results):
            results.solution_loader.load_vars()
        return Solved(results, seconds, gap, stops.should_interrupt())

    def _run(self, seconds: float, settings: confirm.Settings | None = None) -> Results:
        """One HiGHS solve through Pyomo within ``seconds`` (at least :data:`MIN_SOLVE_SECONDS`),
        with extra options."""
        config = self.solver.config
        config.time_limit = max(MIN_SOLVE_SECONDS, seconds)
        self._fresh = True
        use_threads(self.options.threads)
        usual = config.solver_options
        config.solver_options = {**usual, **(settings or {})}
        try:
            # Pyomo redirects the process's stdout/stderr while HiGHS runs; send what the
            # progress callback writes meanwhile to the real stderr (HiGHS's own log is off).
            with stops.solving():
                tee = [sys.stderr] if self.clock.progress else []
                results = self.solver.solve(self.model, tee=tee)
        finally:
            config.solver_options = usual
        self.verdict = confirm.verdict(self.highs)
        stops.raise_if_hard()
        if self.clock.error is not None:
            raise self.clock.error
        return results

    def _confirmed(self, results: Results, first: tuple[str, float], finishing: bool) -> Results:
        """The results after confirming an infeasible verdict (recorded on the clock)."""
        last = [results]

        def run(settings: confirm.Settings, limit: float) -> None:
            last[0] = self._run(limit, settings)

        where: str = self.phase
        if self.phase == "step1" and self.clock.round is not None:
            where += f" round {self.clock.round}"
        confirmation = confirm.confirm(
            self.highs,
            first,
            run,
            self.options.seed,
            lambda: self.clock.remaining(finishing),
            where,
        )
        self.clock.confirmations.append(confirmation)
        return last[0]


def solve_once(
    model: ConcreteModel, options: PlanOptions, clock: Clock, phase: Phase, mip: bool = True
) -> tuple[Results, float, float | None]:
    """One HiGHS solve of ``model``; returns the results, its wall time and HiGHS's MIP gap.

    Step 2 and the polish are finishing solves (:meth:`HighsSession.solve`).
    """
    solved = HighsSession(model, options, clock, phase, mip).solve(
        finishing=phase in ("step2", "polish")
    )
    return solved.results, solved.seconds, solved.gap
