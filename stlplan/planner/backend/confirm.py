"""An infeasible verdict of HiGHS is confirmed before it is believed.

HiGHS's MIP solver can call a feasible model infeasible: a presolve reduction or a cut that is
wrong for one random seed, while other seeds, or the same solve without presolve, find the
optimum. One "infeasible" is therefore not proof. Whenever a solve says infeasible, the same
model is solved again with the settings of :func:`attempts` (presolve off, other random seeds),
one after the other:

* a check that finds a plan **overturns** the verdict: the solve goes on from that plan;
* a check that ends without a verdict (time limit, a stop request) leaves it **undecided**: the
  infeasibility is not established, and the run reports what that check ended with;
* only a verdict every check repeats is **confirmed**.

The rule works on a ``highspy.Highs`` object (:class:`stlplan.planner.backend.session.HighsSession`
drives it through Pyomo's solve).
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterator
from typing import Any

import highspy

from stlplan.planner.config import BudgetConfig
from stlplan.result import Check, Confirmation

Settings = dict[str, Any]

_INFEASIBLE = (
    highspy.HighsModelStatus.kInfeasible,
    highspy.HighsModelStatus.kUnboundedOrInfeasible,
)


def attempts(seed: int) -> tuple[Settings, ...]:
    """The confirmation solves: presolve off with another seed, then presolve on, a third seed.

    Presolve is the usual source of a false verdict; a different seed changes the branching, the
    cuts and the primal heuristics.
    """
    return (
        {"presolve": "off", "random_seed": seed + 1},
        {"presolve": "on", "random_seed": seed + 2},
    )


def says_infeasible(highs: highspy.Highs) -> bool:
    """Whether the last solve of ``highs`` ended with an infeasible verdict."""
    return highs.getModelStatus() in _INFEASIBLE


def has_plan(highs: highspy.Highs) -> bool:
    """Whether the last solve of ``highs`` left a primal feasible point."""
    return int(highs.getInfo().primal_solution_status) == 2


def verdict(highs: highspy.Highs) -> str:
    """HiGHS's name of its last model status."""
    return str(highs.modelStatusToString(highs.getModelStatus()))


def option(highs: highspy.Highs, name: str) -> Any:
    """The value of HiGHS option ``name`` (highspy returns ``(status, value)`` or the value)."""
    found = highs.getOptionValue(name)
    return found[1] if isinstance(found, tuple) else found


@contextlib.contextmanager
def applied(highs: highspy.Highs, settings: Settings) -> Iterator[None]:
    """HiGHS options ``settings`` set on ``highs`` for the block, the earlier values restored."""
    saved = {name: option(highs, name) for name in settings}
    try:
        for name, value in settings.items():
            highs.setOptionValue(name, value)
        yield
    finally:
        for name, value in saved.items():
            highs.setOptionValue(name, value)


def confirm(
    highs: highspy.Highs,
    first: tuple[str, float],
    run: Callable[[Settings, float], None],
    seed: int,
    time_left: Callable[[], float],
    where: str = "",
    min_seconds: float = BudgetConfig().min_solve_seconds,
) -> Confirmation:
    """Check the infeasible verdict of the solve ``highs`` just ran by the solves of
    :func:`attempts`.

    ``first`` is that solve's verdict (HiGHS's name) and wall time. ``run(settings, seconds)`` solves the model
    again with the HiGHS options ``settings`` (also set on ``highs`` meanwhile) within
    ``seconds``; ``time_left()`` is what the run's budget still allows (each check gets at least
    ``min_seconds``, even past the run's budget). On return ``highs`` holds the last check's solve: a plan when
    overturned.
    """
    usual = tuple((name, option(highs, name)) for name in attempts(seed)[0])
    checks = [Check(usual, *first)]
    for settings in attempts(seed):
        seconds = max(min_seconds, time_left())
        tick = time.perf_counter()
        with applied(highs, settings):
            run(settings, seconds)
        checks.append(Check(tuple(settings.items()), verdict(highs), time.perf_counter() - tick))
        if has_plan(highs):
            return Confirmation(where, tuple(checks), "overturned")
        if not says_infeasible(highs):
            return Confirmation(where, tuple(checks), "undecided")
    return Confirmation(where, tuple(checks), "confirmed")
