"""What HiGHS reports while it searches: its news as the planner reads them (:class:`Searching`),
its progress reported to the run's clock, and the whole team's figures followed for the run's
convergence record (:mod:`stlplan.planner.run.convergence` says which figures count)."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from highspy import Highs, HighsCallbackEvent, cb

from stlplan.planner.run.clock import Clock, Phase
from stlplan.planner.run.convergence import THIN_SECONDS, known

SolverEvent = HighsCallbackEvent
"""What HiGHS reports during a search: its figures (``data_out``) and a way to stop it."""

Listener = Callable[[SolverEvent], None]
"""What HiGHS calls during a MIP search, with the event."""


@dataclass(frozen=True)
class Searching:
    """A MIP search's news, as the planner reads it whatever the solver: its bound, an improving
    plan's objective and point (HiGHS's column vector, whose keys the session knows) when it
    found one, and a way to stop the search."""

    bound: float
    objective: float | None = None
    point: np.ndarray | None = None
    stop: Callable[[], None] = lambda: None


Heard = Callable[[Searching], None]
"""What the planner does with a search's news."""


def searching(event: SolverEvent, found: bool) -> Searching:
    """HiGHS's ``event`` as the planner reads it (``found``: an improving plan's event)."""
    out = event.data_out
    return Searching(
        float(out.mip_dual_bound),
        float(out.objective_function_value) if found else None,
        np.array(out.mip_solution) if found else None,
        event.interrupt,
    )


def report_progress(highs: Highs, clock: Clock, phase: Phase) -> None:
    """Report HiGHS's MIP progress to ``clock`` (callbacks on the ``Highs`` object)."""
    if clock.progress is None:
        return
    last = [0.0]

    def on_event(event: HighsCallbackEvent) -> None:
        now = time.perf_counter()
        improving = event.callback_type == cb.HighsCallbackType.kCallbackMipImprovingSolution
        if improving or now - last[0] >= THIN_SECONDS:  # as the convergence record's points
            last[0] = now
            out = event.data_out
            found = known(out.mip_primal_bound)
            incumbent = out.objective_function_value if found else None
            clock.report(phase, incumbent, out.mip_dual_bound, out.mip_gap if found else None)
        if clock.error is not None:
            event.interrupt()  # the callback failed: stop HiGHS, re-raise after the solve

    highs.cbMipImprovingSolution.subscribe(on_event)
    highs.cbMipInterrupt.subscribe(on_event)


def follow(highs: Highs, trial: Callable[[], bool], recorder: Clock, plans: bool) -> None:
    """Record the whole problem's figures HiGHS reports while it solves the whole team's model.

    Parameters
    ----------
    highs
        The ``highspy.Highs`` object of the whole team's model.
    trial
        Whether the solve running is a trial (its figures are then ignored).
    recorder
        The run's :class:`~stlplan.planner.run.clock.Clock` (``plan_found``, ``bound_found``).
    plans
        Whether HiGHS's improving plans are plans of the whole problem (a model holding every
        requirement).
    """
    improving = cb.HighsCallbackType.kCallbackMipImprovingSolution

    def on_event(event: HighsCallbackEvent) -> None:
        if trial():
            return
        out = event.data_out
        if plans and event.callback_type == improving:
            recorder.plan_found(float(out.objective_function_value))
        recorder.bound_found(float(out.mip_dual_bound))

    highs.cbMipImprovingSolution.subscribe(on_event)
    highs.cbMipInterrupt.subscribe(on_event)
