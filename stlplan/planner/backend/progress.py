"""HiGHS's figures while it solves the whole team's model, followed for the run's convergence
record (:mod:`stlplan.planner.run.convergence` says which figures count)."""

from __future__ import annotations

from collections.abc import Callable

from highspy import Highs, HighsCallbackEvent, cb

from stlplan.planner.run.clock import Clock


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
