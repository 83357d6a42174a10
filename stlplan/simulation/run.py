"""One run of a simulation: a plan executed on the mission's own dynamics under a bounded
disturbance, replanned by the policy, and judged.

**Execution.** Run ``r`` of seed ``S`` draws its disturbance from
``numpy.random.default_rng([S, r])``: for each step ``k = 0..H-1`` and each agent in the
mission's order, one draw per state component, uniform in ``[-W, W]`` (drawn for every agent,
lost or not, so that events do not change the other agents' draws). The loop
(:class:`stlplan.online.OnlinePlanner`) is given the state of every agent at each step and the
events there, and returns the inputs; the next state is

    ``x(k+1) = clip(A x(k) + B u(k) + w(k), state bounds)``.

The clip keeps states inside the bounds the planner and the replans require (a replan refuses a
state outside them); it moves a state towards ``A x(k) + B u(k)`` whenever that lies inside.
An agent lost at step ``K`` stays in its state of ``K`` to the end, undisturbed: a broken robot
in the field, as a replan assumes.

**Verdict.** The monitor (:func:`stlplan.monitor.verdicts.check`) judges the executed
trajectory's tasks, constraints and separation, safety between steps included, on the mission
with each region closed at ``K`` an obstacle from ``K`` on (the constraints a replan adds,
:func:`stlplan.mission.past.replanned`). The dynamics are judged up to the disturbance
bound (:func:`stlplan.monitor.dynamics.disturbed_verdict`): ``|x(k+1) - A x(k) - B u(k)| <= W``
per component, a lost agent still from its step, and the bounds.
"""

from __future__ import annotations

import dataclasses
import signal
import statistics
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from stlplan.errors import StlplanError
from stlplan.mission.past import replanned
from stlplan.mission.problem import Problem
from stlplan.monitor.dynamics import disturbed_verdict
from stlplan.monitor.verdicts import check
from stlplan.online import OnlinePlanner
from stlplan.planner.overrides import Overrides
from stlplan.result import Dropped, MonitorReport, PlanResult, PlanStatus, Trajectory
from stlplan.runtime import signals
from stlplan.simulation.settings import Simulated

TOLERANCE = 1e-6
"""The monitor's tolerance on the executed numbers (solver round-off, as for plans)."""


@dataclass(frozen=True)
class SimulationSpec:
    """One run of a simulation: the mission (as text, so remote workers need no files), run and
    seed, the planner's settings, the simulation's, and the plan every run executes."""

    mission_key: str
    mission_text: str
    source: str
    run: int
    seed: int
    overrides: Overrides
    simulated: Simulated
    first: PlanResult | None = field(default=None, compare=False, repr=False)

    def settings(self) -> dict[str, Any]:
        """The settings that change the run's answer (threads change only its time)."""
        planner = {k: v for k, v in self.overrides.given().items() if k != "threads"}
        return planner | self.simulated.describe()


@dataclass(frozen=True)
class Execution:
    """What one run did.

    Attributes
    ----------
    executed
        The executed trajectory: the states of steps ``0..H``, the inputs applied.
    replan_seconds
        The wall time of each step that replanned.
    dropped
        The tasks the last degraded replan dropped (empty when none was degraded).
    last
        The plan the run ended with.
    reduced
        The margins each replan that had to reduce them planned with (``diagnosis.margin_fractions``).
    came_back
        With a deadline, what each replan answered by it (``new plan``, ``degraded plan``,
        ``shifted plan``), in order.
    """

    executed: Trajectory
    replan_seconds: tuple[float, ...]
    dropped: tuple[Dropped, ...]
    last: PlanResult
    reduced: tuple[float, ...] = ()
    came_back: tuple[str, ...] = ()


def disturbances(problem: Problem, bound: float, seed: int, run: int) -> dict[str, np.ndarray]:
    """``w_p(k)`` of every agent, shape ``(H, n)``: uniform in ``[-bound, bound]``, drawn step
    by step in the mission's order of agents from ``default_rng([seed, run])``."""
    rng = np.random.default_rng([seed, run])
    sizes = [a.n for a in problem.agents]
    draws = rng.uniform(-bound, bound, size=(problem.horizon, sum(sizes)))
    parts = np.split(draws, np.cumsum(sizes)[:-1], axis=1)
    return {a.name: part for a, part in zip(problem.agents, parts, strict=True)}


def execute(
    problem: Problem,
    first: PlanResult,
    overrides: Overrides,
    simulated: Simulated,
    w: Mapping[str, np.ndarray],
) -> Execution:
    """Execute ``first`` on ``problem``'s dynamics under the disturbance ``w``, the loop
    replanning by ``simulated.policy`` and given ``simulated.events`` at their steps."""
    loop = OnlinePlanner(problem, first, overrides, simulated.policy, deadline=simulated.deadline)
    x = {a.name: a.initial_state.copy() for a in problem.agents}
    seconds: list[float] = []
    reduced: list[float] = []
    came_back: list[str] = []
    dropped: tuple[Dropped, ...] = ()
    for k in range(problem.horizon + 1):
        lost, closed = simulated.at(k)
        tick = time.perf_counter()
        step = loop.step(k, x, lost, closed)
        if step.result.status.interrupted or signals.requested():  # --resume runs it again
            raise signals.Interrupted(signals.last_signal() or signal.SIGINT)
        if step.replanned and loop.replanned is not None:  # (its own result, plan or not)
            seconds.append(time.perf_counter() - tick)
            own = loop.replanned
            if own.replan is not None and own.replan.came_back is not None:
                came_back.append(own.replan.came_back)
            dropped = own.dropped or dropped
            planned = own.trajectory is not None and own.status is not PlanStatus.SHIFTED
            if planned and own.robust_to < first.robust_to:
                reduced.append(own.robust_to)
        if k < problem.horizon:
            x = _advance(problem, x, step.inputs, w, k, loop.lost)
    answers = tuple(came_back)
    return Execution(loop.history(), tuple(seconds), dropped, loop.current, tuple(reduced), answers)


def _advance(
    problem: Problem,
    x: Mapping[str, np.ndarray],
    inputs: Mapping[str, np.ndarray],
    w: Mapping[str, np.ndarray],
    k: int,
    lost: list[str],
) -> dict[str, np.ndarray]:
    """``x(k+1) = clip(A x(k) + B u(k) + w(k), state bounds)``; a lost agent stays."""
    after = {}
    for a in problem.agents:
        if a.name in lost:
            after[a.name] = x[a.name].copy()
            continue
        moved = a.A @ x[a.name] + a.B @ inputs[a.name] + w[a.name][k]
        after[a.name] = np.clip(moved, a.state_lo, a.state_hi)
    return after


def judged_problem(problem: Problem, executed: Trajectory, simulated: Simulated) -> Problem:
    """``problem`` with each region closed at ``K`` an obstacle from ``K`` on, for every agent not
    lost by then (as a replan from ``K`` has it)."""
    judged = problem
    for k in sorted({e.step for e in simulated.events if e.kind == "close"}):
        lost = [e.name for e in simulated.events if e.kind == "lose" and e.step <= k]
        judged = replanned(judged, executed, k, lost, simulated.at(k)[1])
    return judged if judged is problem else dataclasses.replace(judged, past=None, _by_name={})


def judge(problem: Problem, executed: Trajectory, simulated: Simulated) -> MonitorReport:
    """The monitor's verdicts on ``executed`` (module docstring): tasks, constraints (closed
    regions included) and separation, then the dynamics up to the disturbance bound."""
    report = check(judged_problem(problem, executed, simulated), executed, tol=TOLERANCE)
    lost_at = simulated.lost_at()
    physics = [
        disturbed_verdict(a, executed, TOLERANCE, simulated.disturbance, lost_at.get(a.name))
        for a in problem.agents
    ]
    kept = tuple(v for v in report.verdicts if v.kind != "dynamics")
    return dataclasses.replace(report, verdicts=kept + tuple(physics))


def simulate_one(spec: SimulationSpec) -> dict[str, Any]:
    """Execute and judge run ``spec.run``; its record. Never raises for a failed run (a replan
    that fails is recorded as an error)."""
    from stlplan.mission.loader import problem_from_text

    simulated = spec.simulated
    record: dict[str, Any] = {"mission": spec.mission_key, "run": spec.run, "seed": spec.seed}
    record.update(simulated.describe(), robust_to=spec.overrides.robust_to)
    started = time.monotonic()
    try:
        assert spec.first is not None
        problem = problem_from_text(spec.mission_text, spec.source)
        w = disturbances(problem, simulated.disturbance, spec.seed, spec.run)
        run = execute(problem, spec.first, spec.overrides, simulated, w)
        report = judge(problem, run.executed, simulated)
    except StlplanError as exc:
        record.update(status="error", message=str(exc), wall_seconds=time.monotonic() - started)
        return record
    record.update(figures(report, run), wall_seconds=time.monotonic() - started)
    return record


def figures(report: MonitorReport, run: Execution) -> dict[str, Any]:
    """What a record keeps of a judged run."""
    seconds = list(run.replan_seconds)
    return dict(
        status="satisfied" if report.satisfied else "violated",
        satisfied=report.satisfied,
        rho_s=report.rho_s,
        failed=[v.name for v in report.verdicts if not v.satisfied],
        dropped=[d.task for d in run.dropped],
        replans=len(seconds),
        reduced_margins=list(run.reduced),
        replan_seconds=seconds,
        replan_median_s=statistics.median(seconds) if seconds else None,
        replan_max_s=max(seconds) if seconds else None,
        came_back={kind: run.came_back.count(kind) for kind in dict.fromkeys(run.came_back)},
        executed=trajectory_record(run.executed),
    )


def trajectory_record(trajectory: Trajectory) -> dict[str, Any]:
    """``trajectory`` as JSON holds it: ``states`` and ``inputs``, agent to rows."""
    return {
        "states": {name: x.tolist() for name, x in trajectory.states.items()},
        "inputs": {name: u.tolist() for name, u in trajectory.inputs.items()},
    }


def trajectory_from_record(record: Mapping[str, Any], horizon: int) -> Trajectory:
    """The executed trajectory a record holds (:func:`trajectory_record`)."""
    executed = record["executed"]
    return Trajectory(
        horizon,
        {name: np.array(x, dtype=float) for name, x in executed["states"].items()},
        {
            name: np.array(u, dtype=float).reshape(horizon, -1)
            for name, u in executed["inputs"].items()
        },
    )
