"""Planning in the loop: a mission's plan kept up to date from measured states and events.

An :class:`OnlinePlanner` is made from a mission (and, optionally, a plan of it). At each step
``k`` a robot loop or a simulator gives it the measured states and any events (agents lost,
regions closed); it returns the inputs to apply and the plan they come from. It keeps the
executed history itself: when the measured states leave the plan (or an event comes, or the
policy says so), it replans from ``k`` with the history as the past (:mod:`stlplan.replanning`),
starting from its current plan. With a ``deadline``, each replan answers within that many
seconds of the step's call (:mod:`stlplan.deadline`): a new plan, a degraded plan, or the
current plan shifted on.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np

from stlplan.deadline import Deadline, deadline_seconds, replan_by
from stlplan.errors import EventError
from stlplan.mission.loader import load_problem
from stlplan.mission.problem import Problem
from stlplan.pipeline import plan
from stlplan.planner.overrides import Overrides
from stlplan.planner.run.outcome import Plan
from stlplan.replanning import replan, trajectory_start
from stlplan.result import PlanResult, Trajectory

Policy = Literal["every", "on-deviation", "never"]
"""When to replan: at every step (from step 1, or at step 0 when the measured states are not
those the plan starts from), when the measured states leave the plan (or an event comes), or
never (open loop: events and deviations are ignored)."""


@dataclass(frozen=True)
class Step:
    """What the planner says at one step.

    Attributes
    ----------
    k
        The step.
    inputs
        The input each agent applies at ``k`` (zeros for a lost agent).
    result
        The plan the inputs come from (verified by the monitor), for steps ``0..H``.
    replanned
        Whether this step replanned.
    """

    k: int
    inputs: Mapping[str, np.ndarray]
    result: PlanResult
    replanned: bool


class OnlinePlanner:
    """A mission's plan, kept up to date from measured states (module docstring).

    Parameters
    ----------
    mission
        A mission file or a checked problem.
    first
        A plan of the mission to execute (default: planned here, from its initial states).
    overrides
        Settings of every solve (time limit, threads, ...).
    policy
        When to replan (:data:`Policy`).
    tolerance
        How far (max norm) a measured state may be from the plan's and still be on it.
    progress
        Called with the solver's progress reports.
    deadline
        Seconds of wall time each step that replans may take, from the call of :meth:`step` to
        its answer (None: as long as the search needs).
    """

    def __init__(
        self,
        mission: str | Path | Problem,
        first: PlanResult | None = None,
        overrides: Overrides | None = None,
        policy: Policy = "on-deviation",
        tolerance: float = 1e-6,
        progress: Callable[[Any], None] | None = None,
        deadline: float | None = None,
    ) -> None:
        self.deadline = None if deadline is None else deadline_seconds(deadline, "deadline")
        self.problem = mission if isinstance(mission, Problem) else load_problem(mission)
        self.overrides, self.policy, self.tolerance = overrides, policy, tolerance
        self.progress = progress
        self.current = first or plan(self.problem, overrides, progress=progress)[1]
        if self.current.trajectory is None:
            raise EventError(f"the mission has no plan to execute: {self.current.message}")
        H = self.problem.horizon
        self.states = {a.name: np.full((H + 1, a.n), np.nan) for a in self.problem.agents}
        self.inputs = {a.name: np.full((H, a.m), np.nan) for a in self.problem.agents}
        self.lost: list[str] = []
        self.closed: list[str] = []
        self.replans = 0
        self.replanned: PlanResult | None = None
        """The last replan's own result (without a plan when it found none; the current plan
        is then the one before it)."""

    def step(
        self,
        k: int,
        measured: Mapping[str, Sequence[float] | np.ndarray],
        lost: Sequence[str] = (),
        closed: Sequence[str] = (),
    ) -> Step:
        """Take the measured states of step ``k`` and the events there; return the inputs to
        apply at ``k`` and the plan they come from."""
        called = time.perf_counter()
        for name, x in measured.items():
            self.states[name][k] = np.asarray(x, dtype=float)
        events = bool(lost or closed)
        self.lost += [a for a in lost if a not in self.lost]
        self.closed += [r for r in closed if r not in self.closed]
        changed = events or self._off_plan(k)
        # at step 0 the plan is made from these states: "every" replans from step 1 on
        every = self.policy == "every" and (k > 0 or changed)
        again = k < self.problem.horizon and (every or (self.policy == "on-deviation" and changed))
        if again:
            self._replan(k, called)
        inputs = self._inputs(k)
        for name, u in inputs.items():
            self.inputs[name][k] = u
        return Step(k, inputs, self.current, again)

    def history(self) -> Trajectory:
        """The executed trajectory so far (steps not yet taken are NaN)."""
        return Trajectory(self.problem.horizon, self.states, self.inputs)

    def _off_plan(self, k: int) -> bool:
        trajectory = self.current.trajectory
        assert trajectory is not None
        return any(
            float(np.max(np.abs(self.states[a][k] - trajectory.states[a][k]))) > self.tolerance
            for a in self.states
        )

    def _replan(self, k: int, called: float) -> None:
        current = self.current.trajectory
        assert current is not None
        if self.current.values:
            start = Plan(np.nan, self.current.values, meets_all=False)
        else:  # (a shifted plan has no solver values)
            start = trajectory_start(self.problem, current, k)
        events = (self.history(), k, self.lost, self.closed)
        if self.deadline is None:
            _, result = replan(self.problem, *events, self.overrides, self.progress, start)
        else:
            by = Deadline.starting(self.deadline, called)
            _, result = replan_by(
                by, self.problem, *events, self.overrides, self.progress, start, current
            )
        self.replans += 1
        self.replanned = result
        if result.trajectory is not None:
            self.current = result
        else:  # no new plan: keep following the old one
            self.current = dataclasses.replace(self.current, message=result.message)

    def _inputs(self, k: int) -> dict[str, np.ndarray]:
        trajectory = self.current.trajectory
        assert trajectory is not None
        if k >= self.problem.horizon:
            return {}
        return {
            a.name: np.zeros(a.m) if a.name in self.lost else trajectory.inputs[a.name][k].copy()
            for a in self.problem.agents
        }
