"""Every knob of the planner, declared once: :class:`PlannerConfig`.

The planner reads its strategy (formulation, time shares, when to give up) from this tree only.
Each field has a type, default and docstring; a measured default names where (``Measured:``).

A run's configuration is the mission's settings (:meth:`PlannerConfig.from_mission`) with dotted
overrides (:meth:`PlannerConfig.with_overrides`, e.g. ``{"repair.crowd_agents": 5}``; a run's
options are :class:`stlplan.planner.overrides.Overrides`); an unknown
key or a wrong type is a :class:`ConfigError` naming it. ``summary.json`` records the tree and
the strategy's line (:func:`stlplan.planner.strategy.describe`). No Pyomo, no HiGHS here.
"""

from __future__ import annotations

import difflib
import itertools
from collections.abc import Mapping
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from stlplan.errors import StlplanError
from stlplan.mission.schema import MAX_THREADS, Mission

Encoding = Literal["log", "standard"]
"""How a disjunction is encoded: a logarithmic SOS1 (``log``) or one binary per entry."""
TaskForm = Literal["selection", "groups"]
"""How a task is encoded: by selecting elements, or by the paper's group enumeration."""
Fraction = Annotated[float, Field(ge=0, lt=1)]
"""A share of a margin: at least 0, below 1."""


class ConfigError(StlplanError):
    """An override names no knob, or gives a knob a value of the wrong type."""


class _Section(BaseModel):
    """A section of the planner's knobs: unknown keys and wrong types refused."""

    model_config = ConfigDict(
        extra="forbid", frozen=True, strict=True, use_attribute_docstrings=True
    )


class RepairConfig(_Section):
    """Repairing a plan agent by agent (prioritized planning) while no plan meets every
    requirement."""

    after_round_seconds: float | None = Field(default=8.0, ge=0)
    """A lazy round that took at least this long has its plan repaired before the next round
    (None: never by duration). Measured: docs/dropped.md#the-repair-in-turn."""
    crowd_agents: int | None = Field(default=7, ge=1)
    """A lazy round, or a merge of parts, whose violated requirements name at least this many
    agents is repaired in turn (None: never by crowd). Measured:
    docs/measurements.md#the-16-agent-farm-with-doubled-counts."""
    crowd_team: int | None = Field(default=10, ge=1)
    """A merge's crowd is repaired in turn only in a team of this many agents or more (None: any).
    Measured: docs/performance.md#crowded-merges-in-cases-i-iii."""
    by_elements: float | None = Field(default=0.5, gt=0, le=1)
    """Before a first plan, in a loop that looks for one, a round's plan is first repaired by
    elements (its task choices as parts of their own, planned in turn) within this share of the
    loop's time left, and so is a merge of parts too large for the prioritized repair (None:
    never). Measured: docs/measurements.md#the-repair-by-elements."""
    by_elements_gap: float = Field(default=0.1, ge=0)
    """Relative gap of the rounds of a loop that looks for its first plan, where its tasks
    choose, while the repair by elements is on: the repair takes a round's choices, not its
    optimum. Measured:
    docs/measurements.md#the-repair-by-elements."""
    gap: float = Field(default=0.01, ge=0)
    """Relative gap of a repair's solves (a turn's, the held repair's rounds): the repair looks
    for a plan, the rounds prove. Measured: docs/measurements.md#where-farm-x2s-first-plan-comes-from."""
    held_exact_share: float = Field(default=0.5, ge=0, le=1)
    """Share of its time the held repair of a merged part spends solving to the run's gap (its
    plan may then prove the merged part); the rest, when that found no plan, goes to solving
    to ``repair.gap``. Measured: docs/measurements.md#where-farm-x2s-first-plan-comes-from."""
    near: float = Field(default=0.3, ge=0)
    """A prioritized turn adds, with the requirements against earlier parts its plan violates,
    those it meets by less than this (fewer solves per turn). Measured:
    docs/measurements.md#the-prioritized-repair."""
    orders: int = Field(default=3, ge=0)
    """Orders of the parts a prioritized repair of a merged crowd tries with the turns' MILPs, a
    failed part moved before the parts in its way (0: no prioritized repair). Measured:
    docs/measurements.md#the-prioritized-repair."""
    guided_orders: int = Field(default=40, ge=0)
    """Orders a prioritized repair first tries with guided parts on their guide paths only,
    before its ``repair.orders`` orders with the turns' MILPs. Measured:
    docs/measurements.md#the-first-order-by-the-direction-of-travel."""
    guide_near: float = Field(default=0.5, ge=0)
    """A guided turn first holds the sides of the requirements its guide path meets by less
    than this; the others when its plan breaks them. Measured: docs/measurements.md#guided-turns."""
    part_agents: int = Field(default=4, ge=1)
    """A prioritized repair runs only when the parts of the merge have at most this many agents
    each: a larger part's turn is a MILP of its own that does not finish. Measured:
    docs/measurements.md#guided-turns."""


class SolverConfig(_Section):
    """HiGHS's settings for every solve of a run."""

    time_limit: float = Field(default=300.0, gt=0)
    """Wall-clock limit of the whole run, s: building, step 1, step 2, confirmations and the
    diagnosis of an infeasible mission share it (:class:`stlplan.planner.run.budget.Budget`)."""
    gap: float = Field(default=1e-4, ge=0)
    """Relative optimality gap at which step 1 stops."""
    threads: int | None = Field(default=None, ge=1, le=MAX_THREADS)
    """Threads HiGHS may use (None: HiGHS decides)."""
    seed: int = Field(default=0, ge=0)
    """HiGHS's random seed."""
    highs_options: dict[str, Any] = Field(default_factory=dict)
    """Extra HiGHS options by name, for experiments."""
    first_plan: bool = False
    """Stop step 1 at the first plan that meets every requirement (``--first-plan``); its gap
    is reported beside it."""
    deterministic: bool = False
    """Decisions read the solver's work, not the clock: one thread (HiGHS's, and one part at a
    time), and a lazy round's length, which decides its repairs, is its simplex iterations at
    :data:`~stlplan.planner.backend.session.WORK_RATE` a second. Two runs then take the same
    decisions whatever the machine's load, as long as no solve reaches its time limit (for
    comparing code, not machines)."""

    def used_threads(self) -> int | None:
        """The threads HiGHS may use: one when :attr:`deterministic`, else :attr:`threads`."""
        return 1 if self.deterministic else self.threads


class ModelConfig(_Section):
    """The MILP of step 1: which formulation, which valid inequalities."""

    encoding: Encoding = "standard"
    """Disjunctions with one binary per entry (``standard``) or as a logarithmic SOS1 (``log``).
    Measured:
    docs/measurements.md#the-disjunction-encoding-chosen-by-measurement."""
    tasks: TaskForm = "selection"
    """Tasks by selecting elements (no group enumerated) or by the paper's groups (``groups``,
    kept for comparisons with the paper). Measured: docs/measurements.md#tasks-by-selection-against-groups."""
    floors: bool = True
    """Add the effort floors (valid inequalities on effort, per agent, per pair of tasks an
    agent serves and per element). Measured: docs/performance.md#where-the-speed-comes-from."""
    max_combinations: int = Field(default=64, ge=1)
    """Most linear programs one effort floor may solve: a pair of tasks one agent serves gets
    no joint floor when its unions of predicates number more, and an element's floor takes one
    child of every disjunction together while there are at most this many combinations, else
    the largest single floor. No shipped mission reaches it (the pairs' unions at most 64, the
    elements' combinations at most 9). Measured: docs/measurements.md#the-floors-work-bound."""
    robust_to: float = Field(default=0.0, ge=0)
    """W: keep every predicate's margin above what one step of an additive disturbance bounded
    by W per state component can use up (the mission's ``execution.disturbance``,
    ``--robust-to``)."""
    symmetry: bool = True
    """With tasks by selection: order the task shares of interchangeable agents (valid rows
    that keep an optimal plan). Measured: docs/performance.md#where-the-speed-comes-from."""
    shared_subformulas: bool = True
    """Encode a subformula once for every element that gives the roles it reads the same
    agents (False: once per element). Measured: docs/performance.md#shared-subformulas."""


class LazyConfig(_Section):
    """Step 1 with the step requirements of constraints and separation added on demand."""

    enabled: bool = True
    """Leave the step requirements of constraints and separation out of the MILP and add those a
    round's plan violates, solving again until none is (False: encode them all up front).
    Measured: docs/performance.md#where-the-speed-comes-from."""


class PartsConfig(_Section):
    """Step 1 by independent parts of the team (with lazy requirements)."""

    enabled: bool = True
    """Solve the parts of the team that no task, constraint or objective term links apart.
    Measured: docs/performance.md#where-the-speed-comes-from."""
    merge_reserve: float = Field(default=0.1, ge=0, lt=1)
    """Share of the time left that the parts' first solves leave for merging parts that
    collide. Measured: docs/dropped.md#parts-and-merges."""
    plan_first_agents: int | None = Field(default=10, ge=1)
    """When the largest part has this many agents, the parts look for a plan of the whole team
    before their proofs (null: never). Measured: docs/measurements.md#a-first-plan-before-the-proof."""
    side_by_side: int | None = Field(default=None, ge=1)
    """Parts solved at the same time, each in a thread (None: ``solver.threads``, one when
    HiGHS decides). Measured: docs/performance.md#parts-side-by-side."""


class BudgetConfig(_Section):
    """How the run's time limit is kept."""

    grace_share: float = Field(default=0.1, ge=0)
    """Finishing solves (step 2, a completion, the assembly) may run past the deadline by this
    share of the time limit ..."""
    grace_max_seconds: float = Field(default=10.0, ge=0)
    """... and by at most this many seconds: they turn a plan already found into the one
    written."""
    min_solve_seconds: float = Field(default=1.0, gt=0)
    """Every solve, and every confirmation of an infeasible verdict, may run at least this long,
    even when the budget is spent (or the grace, when a short time limit makes that smaller);
    and a solve of a prioritized repair's turn this long at most before its best plan is taken
    (the turn looks for a plan, not for its optimum). Measured:
    docs/measurements.md#the-prioritized-repair."""
    side_share: float = Field(default=0.25, gt=0, lt=1)
    """Share of the time left that a step beside the search may take: computing a model's
    effort floors, a repair between lazy rounds, the held repair of a merged part, and the
    improvement of a large team's first plan element by element (each around all the others,
    while that lowers the effort; the share that improvement was measured with). Measured:
    docs/measurements.md#the-first-plan-improved-element-by-element."""
    search_share: float = Field(default=0.75, gt=0, lt=1)
    """Share of the time left that a search for a first plan may take: a repair between the
    rounds of a loop that looks for its first plan only (the repair is its way to a plan; the
    next round, a relaxation, rarely gives one), each repair of a merged crowd (prioritized,
    then in turn; the solve that joins the prioritized repair's plans may take all of it: see
    docs/dropped.md, parts and merges), a large team's plan before the parts' proofs, and the
    improvement's sweeps within its share. Measured:
    docs/measurements.md#a-first-plan-under-a-short-time-limit."""


class ContinuousConfig(_Section):
    """The continuous stage after step 1: step 2, or the polish of one-step mode."""

    two_step: bool = True
    """Run step 2 (fix step 1's decisions, minimize the mission's effort norm)."""
    near_sides: float | None = Field(default=0.2, ge=0)
    """The continuous model starts with the kept sides of the lazy requirements step 1 left
    out that step 1's plan meets with at most this much to spare (in the units of the map),
    and adds the others its plan breaks (:mod:`stlplan.planner.core.kept_sides`); None: every side
    from the start. Measured: docs/measurements.md#the-continuous-stage-of-a-large-team."""


class DiagnosisConfig(_Section):
    """Finding a minimal conflict of an infeasible mission (a deletion filter)."""

    degrade: bool = False
    """When the mission is infeasible, plan as many tasks as possible instead (by priority, else
    by count), naming each task dropped and why (on for a replan)."""
    margin_fractions: list[Fraction] = Field(default_factory=lambda: [0.5, 0.0])
    """Before a degraded plan drops a task of a mission with robust margins (``model.robust_to``),
    plan it again with its margins scaled by each of these fractions in turn and keep the first
    plan that meets every task. Measured: docs/simulation.md#an-agent-lost."""

    @field_validator("margin_fractions")
    @classmethod
    def _decreasing(cls, fractions: list[float]) -> list[float]:
        if any(later >= earlier for earlier, later in itertools.pairwise(fractions)):
            raise ValueError(f"expected fractions in decreasing order, found {fractions}")
        return fractions


class PlannerConfig(_Section):
    """The planner's whole configuration; see the module docstring."""

    solver: SolverConfig = SolverConfig()
    model: ModelConfig = ModelConfig()
    lazy: LazyConfig = LazyConfig()
    repair: RepairConfig = RepairConfig()
    parts: PartsConfig = PartsConfig()
    budget: BudgetConfig = BudgetConfig()
    continuous: ContinuousConfig = ContinuousConfig()
    diagnosis: DiagnosisConfig = DiagnosisConfig()

    @classmethod
    def from_mission(
        cls, mission: Mission, overrides: Mapping[str, Any] | None = None
    ) -> PlannerConfig:
        """The mission's ``solver`` and ``objective`` settings, then dotted ``overrides``."""
        settings, objective = mission.solver, mission.objective
        base = {
            "solver.time_limit": float(settings.time_limit),
            "solver.gap": float(settings.gap),
            "solver.threads": settings.threads,
            "solver.seed": settings.seed,
            "model.encoding": settings.encoding,
            "model.tasks": settings.tasks,
            "continuous.two_step": objective.two_step,
            "model.robust_to": float(mission.execution.disturbance),
        }
        return cls().with_overrides({**base, **(overrides or {})})

    def with_overrides(self, dotted: Mapping[str, Any]) -> PlannerConfig:
        """This configuration with ``dotted`` values (``"section.knob": value``) in place.

        Raises
        ------
        ConfigError
            When a key names no knob or a value has the wrong type or range.
        """
        tree = self.model_dump()
        for key, value in dotted.items():
            section, _, knob = key.partition(".")
            if (
                section not in tree
                or not isinstance(tree[section], dict)
                or knob not in tree[section]
            ):
                raise ConfigError(_unknown(key))
            tree[section][knob] = value
        try:
            return PlannerConfig.model_validate(tree)
        except ValidationError as exc:
            raise ConfigError(_problems(exc)) from None

    def dotted(self) -> dict[str, Any]:
        """Every knob by its dotted name."""
        return {
            f"{section}.{knob}": value
            for section, knobs in self.model_dump().items()
            for knob, value in knobs.items()
        }


def _unknown(key: str) -> str:
    """The message for a key that names no knob, with the nearest names."""
    known = list(PlannerConfig().dotted())
    near = difflib.get_close_matches(key, known, n=3, cutoff=0.6)
    hint = f"did you mean {' or '.join(map(repr, near))}?" if near else f"known: {', '.join(known)}"
    return f"unknown planner setting {key!r}; {hint}"


def _problems(exc: ValidationError) -> str:
    """One line per wrong value: its dotted name, what was given, what is expected."""
    lines = []
    for error in exc.errors():
        name = ".".join(str(part) for part in error["loc"][:2])
        lines.append(f"planner setting {name!r} = {error.get('input')!r}: {error['msg']}")
    return "; ".join(lines)


def knob_docs() -> list[tuple[str, str, Any, str]]:
    """``(dotted name, type, default, doc)`` of every knob, for the documentation."""
    rows = []
    for section, declared in PlannerConfig.model_fields.items():
        kind = declared.annotation
        assert isinstance(kind, type)
        for knob, info in kind.model_fields.items():
            default = info.get_default(call_default_factory=True)
            rows.append(
                (f"{section}.{knob}", str(info.annotation), default, info.description or "")
            )
    return rows
