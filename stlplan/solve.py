"""Solving the planning MILP with HiGHS (through Pyomo), in one or two steps (DESIGN 2.3).

Step 1 solves problem (step1) of :mod:`stlplan.encoding.model`. Step 2 fixes every binary of
step 1 (groups, time windows, obstacle sides) and every ``rho_s^l``, then minimizes the mission's
effort norm: ``l2`` is ``sum u^2`` (a convex QP), ``l1`` is ``sum |u|`` and ``linf`` is
``sum_p max |u_p|`` (LPs). In one-step mode the same fixing is followed by a continuous re-solve of
the step-1 objective, which moves the plan to an exact vertex: integrality tolerances cannot then
leak into the predicates the monitor checks.

Both continuous solves run on a small model (:mod:`stlplan.encoding.continuous`): an LP over the
step-1 model first finds the predicates the fixed decisions enforce, then only those, the
dynamics (states eliminated) and the effort remain. HiGHS's QP solver stalls on the full model,
whose Hessian is singular.

Progress: HiGHS callbacks (improving solution, MIP interrupt) are registered on the
``highspy.Highs`` object inside Pyomo's solver; Pyomo redirects stdout/stderr during a solve,
so whatever the progress callback prints then is forwarded to the real stderr.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, fields
from typing import Any, Literal

import highspy
from highspy import cb
from pyomo.contrib.solver.common.results import Results, SolutionStatus, TerminationCondition
from pyomo.contrib.solver.solvers.highs import Highs
from pyomo.environ import ConcreteModel, Constraint, Objective, Reals, Var, minimize, value

from stlplan.encoding.continuous import continuous_model, copy_plan
from stlplan.encoding.model import PlanModel, build_model
from stlplan.encoding.readout import plan_result
from stlplan.encoding.sos1 import Encoding
from stlplan.encoding.stl import Enforced
from stlplan.mission import Mission
from stlplan.problem import Problem
from stlplan.result import ModelSize, PlanResult, PlanStatus

Phase = Literal["build", "step1", "step2", "polish", "done"]


@dataclass(frozen=True)
class Progress:
    """A progress report while planning.

    Attributes
    ----------
    phase
        ``build`` (encoding), ``step1`` (MILP), ``step2`` (effort), ``polish``, ``done``.
    elapsed
        Seconds since planning started.
    incumbent, bound, gap
        Best objective found, best bound and relative gap of the MILP (None when unknown).
    """

    phase: Phase
    elapsed: float
    incumbent: float | None = None
    bound: float | None = None
    gap: float | None = None


ProgressCallback = Callable[[Progress], None]


@dataclass(frozen=True)
class PlanOptions:
    """Options of one planning run.

    Attributes
    ----------
    time_limit
        Wall-clock limit of each solve, seconds.
    gap
        Relative optimality gap at which HiGHS stops step 1.
    threads
        Threads HiGHS may use (None: HiGHS decides).
    seed
        HiGHS random seed.
    encoding
        Disjunctions as a logarithmic SOS1 (``log``) or one binary per entry (``standard``).
    two_step
        Run step 2 (fix step 1's decisions, minimize the mission's effort norm).
    """

    time_limit: float = 300.0
    gap: float = 1e-4
    threads: int | None = None
    seed: int = 0
    encoding: Encoding = "log"
    two_step: bool = True

    @classmethod
    def from_mission(cls, mission: Mission, **overrides: Any) -> PlanOptions:
        """Defaults from ``mission.solver`` and ``mission.objective``; None overrides are ignored."""
        known = {f.name for f in fields(cls)}
        unknown = set(overrides) - known
        if unknown:
            raise TypeError(f"unknown plan option(s): {', '.join(sorted(unknown))}")
        base: dict[str, Any] = {
            "time_limit": mission.solver.time_limit,
            "gap": mission.solver.gap,
            "threads": mission.solver.threads,
            "seed": mission.solver.seed,
            "encoding": mission.solver.encoding,
            "two_step": mission.objective.two_step,
        }
        base.update({k: v for k, v in overrides.items() if v is not None})
        return cls(**base)


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


def plan_status(results: Results) -> PlanStatus:
    """The :class:`PlanStatus` of a HiGHS result (one table, :data:`_STATUS`)."""
    with_plan, without = _STATUS.get(
        results.termination_condition, (PlanStatus.ERROR, PlanStatus.ERROR)
    )
    return with_plan if has_solution(results) else without


def has_solution(results: Results) -> bool:
    """Whether HiGHS returned a primal feasible point."""
    return results.solution_status in (SolutionStatus.optimal, SolutionStatus.feasible)


@dataclass
class _Clock:
    """Planning start time and the user's progress callback, with its first error."""

    start: float
    progress: ProgressCallback | None
    error: BaseException | None = None

    def report(
        self,
        phase: Phase,
        incumbent: float | None = None,
        bound: float | None = None,
        gap: float | None = None,
    ) -> None:
        if self.progress is None or self.error is not None:
            return
        try:
            self.progress(Progress(phase, time.perf_counter() - self.start, incumbent, bound, gap))
        except Exception as exc:  # re-raised once HiGHS has returned
            self.error = exc


def _watch(solver: Highs, model: ConcreteModel, clock: _Clock, phase: Phase) -> Any:
    """Load ``model`` into ``solver`` and report HiGHS's MIP progress to ``clock``.

    Pyomo exposes no callback hook, so the callbacks go on the ``highspy.Highs`` object Pyomo
    keeps; the next ``solve`` of the same model reuses that object. Returns it (or None).
    """
    solver.set_instance(model)
    highs = getattr(solver, "_solver_model", None)
    if highs is None or clock.progress is None or not hasattr(highs, "cbMipInterrupt"):
        return highs
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
    return highs


_SCHEDULER: dict[str, int | None] = {}


def _use_threads(threads: int | None) -> None:
    """Restart HiGHS's process-wide thread pool when the thread count changes.

    HiGHS sizes one global scheduler at its first solve and fails later solves that ask for a
    different ``threads``; a planning run in the same process must not inherit that.
    """
    if _SCHEDULER.get("threads", threads) != threads:
        highspy.Highs.resetGlobalScheduler(True)
    _SCHEDULER["threads"] = threads


def _solve(
    model: ConcreteModel, options: PlanOptions, clock: _Clock, phase: Phase, mip: bool = True
) -> tuple[Results, float, float | None]:
    """One HiGHS solve; returns the results, its wall time and HiGHS's MIP gap."""
    solver = Highs()
    solver.config.load_solutions = False
    solver.config.raise_exception_on_nonoptimal_result = False
    solver.config.time_limit = options.time_limit
    solver.config.threads = options.threads
    solver.config.solver_options = {"random_seed": options.seed, "output_flag": False}
    if mip:
        solver.config.rel_gap = options.gap
    clock.report(phase)
    tick = time.perf_counter()
    _use_threads(options.threads)
    highs = _watch(solver, model, clock, phase)
    # Pyomo redirects the process's stdout/stderr while HiGHS runs; send what the progress
    # callback writes meanwhile to the real stderr (HiGHS's own log is off).
    results = solver.solve(model, tee=[sys.stderr] if clock.progress else [])
    seconds = time.perf_counter() - tick
    if clock.error is not None:
        raise clock.error
    gap = None
    if mip and highs is not None and has_solution(results):
        gap = float(highs.getInfo().mip_gap)  # HiGHS reports inf when there is no integer
        if not math.isfinite(gap):
            optimal = results.termination_condition == TC.convergenceCriteriaSatisfied
            gap = 0.0 if optimal else None
    if has_solution(results):
        results.solution_loader.load_vars()
    return results, seconds, gap


def model_size(model: ConcreteModel) -> ModelSize:
    """Free variables, binaries among them, and active constraints of ``model``."""
    free = [v for v in model.component_data_objects(Var, active=True) if not v.fixed]
    rows = sum(1 for _ in model.component_data_objects(Constraint, active=True))
    return ModelSize(len(free), sum(1 for v in free if v.is_binary()), rows)


def fix_decisions(pm: PlanModel) -> None:
    """Fix every binary at its rounded value (domain made real first: HiGHS has no MIQP).

    Each ``rho_s^l`` keeps its step-1 value as a lower bound (the fixed runs pin it anyway), and
    so does a maximized margin.
    """
    for v in pm.model.component_data_objects(Var, active=True):
        if v.is_binary() and not v.fixed:
            rounded = float(round(v.value or 0.0))
            v.domain = Reals
            v.fix(rounded)
    for enc in pm.synchronous:
        enc.rho_s.setlb(max(0.0, round(float(enc.rho_s.value), 6) - 1e-6))
    if not isinstance(pm.margin, float):
        pm.margin.setlb(float(pm.margin.value) - 1e-9)


def enforced_predicates(
    pm: PlanModel, options: PlanOptions, clock: _Clock, phase: Phase
) -> tuple[list[Enforced] | None, float]:
    """The predicates step 1's fixed decisions enforce, and the seconds it took.

    With the binaries fixed, every indicator has a least feasible value, 1 exactly where the
    decisions enforce it (requirements only push indicators up). One LP finds them all:
    ``min sum z`` over the step-1 rows. Returns None if that LP fails.
    """
    model = pm.model
    model.step1.deactivate()
    model.least = Objective(expr=sum(model.spec.indicators.values()), sense=minimize)
    results, seconds, _ = _solve(model, options, clock, phase, mip=False)
    model.del_component(model.least)
    model.step1.activate()
    if results.termination_condition != TC.convergenceCriteriaSatisfied:
        return None, seconds
    guarded = [enforced for z, enforced in pm.ledger.guarded if value(z) > 0.5]
    return pm.ledger.required + guarded, seconds


def _continuous(pm: PlanModel, options: PlanOptions, clock: _Clock) -> tuple[bool, float]:
    """Step 2 (or the one-step polish) with step 1's decisions fixed; True on success.

    On failure the step-1 solution stays loaded in ``pm``.
    """
    snapshot = [(v, v.value) for v in pm.model.component_data_objects(Var)]
    phase: Phase = "step2" if options.two_step else "polish"
    fix_decisions(pm)
    enforced, seconds = enforced_predicates(pm, options, clock, phase)
    for v, val in snapshot:
        v.set_value(val, skip_validation=True)
    if enforced is None:
        return False, seconds
    small = continuous_model(pm, enforced, "effort" if options.two_step else "polish")
    results, more, _ = _solve(small, options, clock, phase, mip=False)
    if results.termination_condition != TC.convergenceCriteriaSatisfied:
        return False, seconds + more
    copy_plan(small, pm)
    return True, seconds + more


def plan(
    problem: Problem, options: PlanOptions | None = None, progress: ProgressCallback | None = None
) -> PlanResult:
    """Plan ``problem``: build the MILP, solve step 1, then step 2 (or a polish).

    Parameters
    ----------
    problem
        A checked problem.
    options
        Solver options (default: from the mission).
    progress
        Called with :class:`Progress` at phase changes and while HiGHS works.

    Returns
    -------
    PlanResult
        Status, trajectory and solver figures; ``report`` is left None for the monitor.
    """
    options = options or PlanOptions.from_mission(problem.mission)
    clock = _Clock(time.perf_counter(), progress)
    clock.report("build")
    pm = build_model(problem, options.encoding)
    size = model_size(pm.model)
    build_seconds = time.perf_counter() - clock.start
    results, solve_seconds, gap = _solve(pm.model, options, clock, "step1")
    status = plan_status(results)
    step1 = {"objective": results.incumbent_objective, "bound": results.objective_bound, "gap": gap}
    if not status.has_plan:
        clock.report("done")
        return PlanResult(
            status=status,
            message=_message(status, results, options),
            bound=results.objective_bound,
            model_size=size,
            build_seconds=build_seconds,
            solve_seconds=solve_seconds,
        )
    polished, seconds = _continuous(pm, options, clock)
    clock.report("done", step1["objective"], step1["bound"], gap)
    message = _message(status, results, options, gap)
    if not polished:
        message += "; the continuous re-solve failed, the step-1 plan is kept"
    elif options.two_step:
        message += f"; step 2 minimized the {problem.mission.objective.effort} effort"
    return plan_result(
        pm,
        status,
        message,
        step1,
        size,
        build_seconds,
        solve_seconds + seconds,
        steps=2 if options.two_step and polished else 1,
    )


def _message(
    status: PlanStatus, results: Results, options: PlanOptions, gap: float | None = None
) -> str:
    """One line on how step 1 ended."""
    bound = results.objective_bound
    stop = results.termination_condition.name
    where = f"gap {gap:.2%}, bound {bound:.6g}" if gap is not None and bound is not None else ""
    texts = {
        PlanStatus.OPTIMAL: "optimal plan",
        PlanStatus.FEASIBLE: f"a plan, not proven optimal: HiGHS stopped ({stop}; {where})",
        PlanStatus.INFEASIBLE: "the tasks and constraints cannot be met together",
        PlanStatus.NO_PLAN: f"no plan found within the time limit of {options.time_limit:g} s",
        PlanStatus.ERROR: f"HiGHS failed: {stop}",
    }
    return texts[status]
