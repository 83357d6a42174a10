"""The options of one planning run: the mission's settings and what a run overrides of them."""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from typing import Any

from stlplan.mission.schema import Mission
from stlplan.planner.encoding.selection import TaskForm
from stlplan.planner.encoding.sos1 import Encoding


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
    in_turn_after
        With ``lazy``: while no plan meets every requirement, a round that took at least this
        many seconds has its plan repaired agent by agent before the next round
        (:mod:`stlplan.planner.in_turn`); None never repairs. Measured on the farm cases, a
        repair after short rounds adds requirements that slow the later rounds more than its
        early plan saves; after long rounds (a large team packed in a start area) it gives the
        first plan where the next round finds none.
    in_turn_agents
        With ``lazy``: while no plan meets every requirement, a round whose plan violates
        requirements naming at least this many agents is repaired too, however short it was;
        None repairs by duration alone. A crowd that large collides again in the next rounds'
        plans, which may then find no plan at all.
    floors
        Add the effort floors of :mod:`stlplan.planner.encoding.floors` (valid inequalities).
    symmetry
        With tasks by selection: for each class of interchangeable agents (same capabilities,
        dynamics and initial state, named nowhere), order their shares of one task
        (:mod:`stlplan.planner.encoding.symmetry`; valid rows that keep an optimal plan). A
        mission without such a class gets the same model either way; on the depot farms the
        rows cut the solve's CPU time to a third or less.
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
    in_turn_after: float | None = 8.0
    in_turn_agents: int | None = 7
    floors: bool = True
    symmetry: bool = True
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
