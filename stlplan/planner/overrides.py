"""What one run changes of a mission's planner settings: the command line's options, and any
other knob by its dotted name (:class:`Overrides`)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from stlplan.planner.config import Encoding, TaskForm

_NAMED = {
    "time_limit": "solver.time_limit",
    "gap": "solver.gap",
    "threads": "solver.threads",
    "seed": "solver.seed",
    "encoding": "model.encoding",
    "tasks": "model.tasks",
    "two_step": "continuous.two_step",
    "degrade": "diagnosis.degrade",
    "first_plan": "solver.first_plan",
    "deterministic": "solver.deterministic",
    "robust_to": "model.robust_to",
}
"""The planner settings a run may change by their command-line names."""


@dataclass(frozen=True)
class Overrides:
    """What one run changes of a mission's settings (the command line's options); None keeps
    the mission's value.

    Attributes
    ----------
    time_limit, gap, threads, seed, encoding, tasks, two_step, degrade, first_plan,
    deterministic, robust_to
        The :class:`PlannerConfig` knobs ``_NAMED`` maps them to (``solver.time_limit``,
        ``diagnosis.degrade``, ``model.robust_to``, ...).
    inter_sample
        Judge safety on the segments between steps (the mission's ``safety.inter_sample``).
    config
        Any other planner knob by its dotted name, e.g. ``{"repair.crowd_agents": 5}``
        (benchmarks compare formulations with them); checked by :meth:`PlannerConfig.with_overrides`.
    """

    time_limit: float | None = None
    gap: float | None = None
    threads: int | None = None
    seed: int | None = None
    encoding: Encoding | None = None
    tasks: TaskForm | None = None
    two_step: bool | None = None
    degrade: bool | None = None
    first_plan: bool | None = None
    deterministic: bool | None = None
    robust_to: float | None = None
    inter_sample: bool | None = None
    config: Mapping[str, Any] = field(default_factory=dict)

    def given(self) -> dict[str, Any]:
        """The values set (not None), by name, as the summary records them."""
        named = {name: getattr(self, name) for name in (*_NAMED, "inter_sample")}
        return {k: v for k, v in named.items() if v is not None} | dict(self.config)

    def dotted(self) -> dict[str, Any]:
        """The planner knobs set here, by dotted name (``inter_sample`` goes to the problem)."""
        named = {_NAMED[k]: getattr(self, k) for k in _NAMED if getattr(self, k) is not None}
        for name in ("solver.time_limit", "solver.gap", "model.robust_to"):
            if name in named:
                named[name] = float(named[name])
        return named | dict(self.config)
