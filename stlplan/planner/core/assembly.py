"""The plans of several parts in one model: held near, loaded, and assembled.

A model that holds the agents of several parts (a merged part, or the full problem) starts from
their plans in one of three ways: its states and inputs bounded near them (:func:`hold_plans`:
the held repair of a merged part, and the assembly), set to them (:func:`plan_values`: a repair
in turn starts from a loaded plan), or both with every requirement the parts added encoded and
one solve choosing the indicators and binaries (:func:`assemble`).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import Any

from stlplan.planner.backend.session import HighsSession
from stlplan.planner.config import PlannerConfig
from stlplan.planner.core.in_turn import Held, hold_near, release
from stlplan.planner.encoding.deferred import requirement_key
from stlplan.planner.encoding.model import PlanModel, add_requirements
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.clock import Clock
from stlplan.planner.tolerances import HOLD
from stlplan.runtime import signals


def added_keys(pm: PlanModel) -> set[tuple[Any, ...]]:
    """Keys of the lazy requirements the model ``pm`` holds."""
    assert pm.deferral is not None
    return {requirement_key(pm.deferral.lazy[n]) for n in pm.added}


def plan_values(
    target: PlanModel, parts: Sequence[PlanModel], free: frozenset[str] = frozenset()
) -> Iterator[tuple[Any, float]]:
    """``(variable of target, its value in a part's plan)`` for every state and input of the
    agents of the parts' models but those in ``free`` (fixed variables and unset values
    skipped)."""
    for part in parts:
        for name in ("x", "u"):
            source, goal = getattr(part.model, name), getattr(target.model, name)
            for key, var in source.items():
                if not (goal[key].fixed or var.value is None or key[0] in free):
                    yield goal[key], float(var.value)


def hold_plans(
    target: PlanModel,
    parts: Sequence[PlanModel],
    width: float,
    free: frozenset[str] = frozenset(),
) -> Held:
    """Bound ``x`` and ``u`` of ``target`` to within ``width`` (``tolerances.HOLD``) of the parts'
    plans (but those of the agents in ``free``); returns what :func:`release` restores."""
    held: Held = []
    for var, planned in plan_values(target, parts, free):
        hold_near(var, planned, held, width)
    return held


def assemble(
    full: PlanModel,
    parts: Sequence[PlanModel],
    config: PlannerConfig,
    clock: Clock,
    budget: Budget,
) -> float | None:
    """Load the parts' plans into ``full`` with every indicator set; returns its objective.

    The parts' requirements are encoded in ``full``, its states and inputs held near the parts'
    plans (:func:`hold_plans`), and one solve chooses the indicators and binaries. None on
    failure.
    """
    assert full.deferral is not None
    index = {requirement_key(r): n for n, r in enumerate(full.deferral.lazy)}
    keys = set().union(*(added_keys(p) for p in parts))
    add_requirements(full, [index[k] for k in keys if k in index])
    held = hold_plans(full, parts, HOLD)
    with signals.finishing():  # the plan is found: a stop request lets this solve end
        session = HighsSession(full.model, config, clock, "step1")
        solved = session.solve(budget)
    release(held)
    objective = solved.results.incumbent_objective
    return None if objective is None else float(objective)
