"""HiGHS's figures while it solves the whole team's model, followed for the run's convergence
record (:mod:`stlplan.planner.run.convergence` says which figures count)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from highspy import cb


def follow(highs: Any, trial: Callable[[], bool], recorder: Any, plans: bool) -> None:
    """Record the whole problem's figures HiGHS reports while it solves the whole team's model.

    Parameters
    ----------
    highs
        The ``highspy.Highs`` object of the whole team's model (None: nothing is followed).
    trial
        Whether the solve running is a trial (its figures are then ignored).
    recorder
        The run's :class:`~stlplan.planner.run.clock.Clock` (``plan_found``, ``bound_found``).
    plans
        Whether HiGHS's improving plans are plans of the whole problem (a model holding every
        requirement).
    """
    if highs is None or not hasattr(highs, "cbMipInterrupt"):
        return
    improving = cb.HighsCallbackType.kCallbackMipImprovingSolution

    def on_event(event: Any) -> None:
        if trial():
            return
        out = event.data_out
        if plans and event.callback_type == improving:
            recorder.plan_found(float(out.objective_function_value))
        recorder.bound_found(float(out.mip_dual_bound))

    highs.cbMipImprovingSolution += on_event
    highs.cbMipInterrupt += on_event
