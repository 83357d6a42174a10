"""Result types shared by the planner and the monitor: trajectories, verdicts, plans."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import Enum
from typing import Any, Literal

import numpy as np

Element = tuple[str, ...]

Known = Literal["inputs", "states", "positions"]
"""What a trajectory gives: states and inputs, the states only, or the planar positions only."""


@dataclass(frozen=True, eq=False)
class Trajectory:
    """A team trajectory: states ``x_p(0..H)`` and inputs ``u_p(0..H-1)`` per agent.

    A trajectory from another tool may lack the inputs (``known = "states"``: they are NaN) or
    every state component but the planar position (``known = "positions"``: the others are NaN).
    """

    horizon: int
    states: Mapping[str, np.ndarray]
    """Agent name to an array of shape (H+1, n)."""
    inputs: Mapping[str, np.ndarray]
    """Agent name to an array of shape (H, m)."""
    known: Known = "inputs"

    def position(self, agent: str, components: tuple[int, int]) -> np.ndarray:
        """The agent's planar position over time, shape (H+1, 2)."""
        return self.states[agent][:, list(components)]


VerdictKind = Literal["task", "synchronous", "constraint", "separation", "dynamics"]


@dataclass(frozen=True)
class Verdict:
    """The monitor's decision on one task, constraint or physical requirement."""

    name: str
    kind: VerdictKind
    satisfied: bool
    robustness: float
    """Spatial robustness: margin by which the best group (or the constraint) holds; < 0 fails."""
    group: tuple[Element, ...] | None = None
    """Elements (agent names per role) of the group that satisfies the task, or the best one."""
    rho_s: float | None = None
    """Synchronous robustness (synchronous tasks only)."""
    run_start: int | None = None
    """First step of the longest synchronized run of the best group."""
    run_length: int | None = None
    """Number of steps of that run."""
    counted: float | None = None
    """``min(rho_s, gamma)``: what the objective counts of a synchronous task's ``rho_s``."""
    detail: str = ""
    """One line a person can read."""


@dataclass(frozen=True)
class MonitorReport:
    """Every verdict on one team trajectory."""

    verdicts: tuple[Verdict, ...]
    known: Known = "inputs"
    """What the judged trajectory gave, hence how its dynamics were checked."""
    tolerance: float = 1e-6
    """How far each number of the trajectory may be off (see :mod:`stlplan.monitor.dynamics`)."""

    @property
    def satisfied(self) -> bool:
        """Whether the trajectory satisfies the global specification and the physics."""
        return all(v.satisfied for v in self.verdicts)

    @property
    def rho_s(self) -> float | None:
        """``rho_s(Phi) = min_l rho_s(T_s^l)``; None when there is no synchronous task."""
        values = [v.rho_s for v in self.verdicts if v.rho_s is not None]
        return min(values) if values else None

    @property
    def spatial_robustness(self) -> float:
        """Smallest robustness over tasks and constraints."""
        values = [v.robustness for v in self.verdicts if v.kind != "dynamics"]
        return min(values) if values else float("inf")

    def verdict(self, name: str) -> Verdict:
        """The verdict called ``name``."""
        return next(v for v in self.verdicts if v.name == name)


class PlanStatus(str, Enum):
    """What a solve produced."""

    OPTIMAL = "optimal"
    FEASIBLE = "feasible"  # a plan, not proven optimal (time limit)
    INFEASIBLE = "infeasible"
    NO_PLAN = "no_plan"  # the time limit ended the solve before any plan was found
    ERROR = "error"
    INTERRUPTED = "interrupted"  # stopped by a signal; the best plan so far
    INTERRUPTED_NO_PLAN = "interrupted_no_plan"  # stopped by a signal before any plan
    DEGRADED = "degraded"  # infeasible; a plan of as many tasks as possible, the rest dropped
    SHIFTED = "shifted"  # no new plan by a replan's deadline: the current plan goes on

    @property
    def has_plan(self) -> bool:
        """Whether a trajectory comes with this status."""
        return self in (
            PlanStatus.OPTIMAL, PlanStatus.FEASIBLE, PlanStatus.INTERRUPTED, PlanStatus.DEGRADED,
            PlanStatus.SHIFTED,
        )  # fmt: skip

    @property
    def interrupted(self) -> bool:
        """Whether a signal cut the solve short."""
        return self in (PlanStatus.INTERRUPTED, PlanStatus.INTERRUPTED_NO_PLAN)


@dataclass(frozen=True)
class ModelSize:
    """Size of the optimization model."""

    variables: int
    binaries: int
    constraints: int


@dataclass(frozen=True)
class Assignment:
    """The group the plan uses for a task, with the synchronized run where it applies."""

    task: str
    group: tuple[Element, ...]
    rho_s: float | None = None
    run_start: int | None = None
    run_length: int | None = None


@dataclass(frozen=True)
class Diagnosis:
    """Why a mission is infeasible."""

    reasons: tuple[str, ...] = ()
    """Cheap reasons found without solving (e.g. a region no capable agent can reach in time)."""
    conflict: tuple[str, ...] = ()
    """A minimal set of tasks and constraints ('separation' included) that cannot hold together."""
    complete: bool = True
    """False when some feasibility solve ran out of time, so the set may not be minimal."""
    kinds: tuple[str, ...] = ()
    """What each name of `conflict` is: ``task``, ``constraint`` or ``separation``."""

    def named(self) -> tuple[str, ...]:
        """The conflict by kind and name: ``task 'meet'``, ``constraint 'avoid'``, ``separation``."""
        if len(self.kinds) != len(self.conflict):
            return tuple(f"'{name}'" for name in self.conflict)
        return tuple(
            kind if kind == name else f"{kind} '{name}'"
            for kind, name in zip(self.kinds, self.conflict, strict=True)
        )


@dataclass(frozen=True)
class Check:
    """One HiGHS solve of a model that some solve called infeasible."""

    settings: tuple[tuple[str, str | int | float], ...]
    """HiGHS options of this solve that differ from the usual ones (empty: the usual solve)."""
    verdict: str
    """HiGHS's model status, as HiGHS names it (``Infeasible``, ``Optimal``, ...)."""
    seconds: float


@dataclass(frozen=True)
class Confirmation:
    """How an infeasible verdict of HiGHS was checked before it was believed.

    ``outcome`` is ``confirmed`` (every check said infeasible), ``overturned`` (a check found a
    plan, and the solve went on from it) or ``undecided`` (a check ended without a verdict, for
    example at the time limit: the infeasibility is not established).
    """

    where: str
    """The solve that said infeasible (phase and lazy round, or a diagnosis probe)."""
    checks: tuple[Check, ...]
    """The solve that said infeasible, then each confirmation solve."""
    outcome: Literal["confirmed", "overturned", "undecided"]


@dataclass(frozen=True)
class SolverFigures:
    """The solver's own values for a plan (the reported ones are the monitor's)."""

    objective: float | None
    margin: float | None
    rho_s: Mapping[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class Dropped:
    """A task a degraded plan gave up, and why."""

    task: str
    reason: str


@dataclass(frozen=True)
class Replan:
    """What a replan kept and changed (DESIGN 2.13-14).

    Attributes
    ----------
    step
        ``K``: the executed states of steps ``0..K`` were kept as data.
    events
        The events applied at ``K``, in words (``vis1 lost``, ``C closed``).
    seconds
        Wall time of the replan, s.
    past_effort
        The effort of the executed inputs before ``K`` (0 when the file gave none): the
        objective counts the planned inputs only.
    deadline
        The seconds the replan was given (None: no deadline; :mod:`stlplan.deadline`).
    came_back
        With a deadline, what came back by it: ``new plan``, ``degraded plan``,
        ``shifted plan`` (the current plan continued), or ``nothing`` (no current plan to go on).
    why
        With a deadline, why that came back, in words.
    """

    step: int
    events: tuple[str, ...] = ()
    seconds: float = 0.0
    past_effort: float = 0.0
    deadline: float | None = None
    came_back: str | None = None
    why: str = ""


@dataclass(frozen=True)
class Fallback:
    """A step that failed and what the plan kept instead costs."""

    step: str
    """The step that failed (``step 2``, ``polish``)."""
    reason: str
    """Why: HiGHS's status of the failed solve."""
    kept: str
    """What was kept instead."""
    cost: Mapping[str, float] = field(default_factory=dict)
    """Quantity (``objective``, ``margin``) to solver's value minus the written plan's value."""


@dataclass(frozen=True)
class ConvergencePoint:
    """The whole problem's incumbent and bound at one moment of step 1
    (:mod:`stlplan.planner.run.convergence` says which figures count)."""

    at: float
    """Seconds since planning started."""
    incumbent: float | None
    """The best objective of a plan meeting every requirement found by then (None: none yet)."""
    bound: float | None
    """The least upper bound on the optimum proven by then (None: none yet)."""


@dataclass(frozen=True, eq=False)
class PlanResult:
    """The outcome of planning a mission."""

    status: PlanStatus
    message: str
    trajectory: Trajectory | None = None
    objective: float | None = None
    """Objective of problem (step1): rho_s(Phi) - beta * L1 effort (+ margin term); once verified,
    recomputed from the written plan (the monitor's rho_s and margin, the trajectory's effort)."""
    bound: float | None = None
    gap: float | None = None
    rho_s: Mapping[str, float] = field(default_factory=dict)
    """Synchronous robustness per synchronous task (the monitor's once verified)."""
    effort: float | None = None
    """Effort of the final plan in the mission's effort norm."""
    margin: float | None = None
    """Spatial margin of the plan (the monitor's spatial robustness once verified)."""
    assignments: tuple[Assignment, ...] = ()
    model_size: ModelSize | None = None
    build_seconds: float = 0.0
    solve_seconds: float = 0.0
    report: MonitorReport | None = None
    """The independent monitor's verdicts on ``trajectory``."""
    steps: int = 1
    """1 or 2: whether step 2 (effort minimization) ran."""
    diagnosis: Diagnosis | None = None
    """For an infeasible mission: what cannot be met together."""
    confirmations: tuple[Confirmation, ...] = ()
    """Every infeasible verdict of HiGHS and how it was confirmed (or overturned)."""
    solver: SolverFigures | None = None
    """The solver's own objective, margin and rho_s, kept beside the reported ones."""
    fallback: Fallback | None = None
    """A step that failed, why, and what keeping the earlier plan costs."""
    config: Mapping[str, Any] = field(default_factory=dict)
    """The planner's whole configuration for this run, by section and knob."""
    strategy: str = ""
    """The composed strategy of the run in one line."""
    rounds: int = 0
    """Lazy rounds: solves of step 1's model (and of its parts' models), one record each in
    :attr:`round_log`."""
    requirements_added: int = 0
    """Lazy requirements the rounds and the repairs between them added to the final models
    (the plan's, or the last tried): what the last record of each final part held, and what a
    repair added after it."""
    requirements_by_kind: Mapping[str, int] = field(default_factory=dict)
    """The lazy requirements of the final models (:attr:`requirements_added`) by kind:
    ``separation`` or ``constraint``, at a ``step`` or on a ``segment``."""
    requirements_candidates: int = 0
    """Step requirements (separation, constraints) the lazy loop could have added to the whole
    team's model: those reachability does not rule out."""
    requirements_unneeded: int = 0
    """Step requirements reachability proves met by every reachable state (never encoded): pairs
    of agents that cannot meet, obstacles out of reach."""
    requirements_completed: int = 0
    """Lazy requirements a completion added at the time limit (every one left out, or those
    added before its time ran out)."""
    events: tuple[str, ...] = ()
    """What happened on the way, in words (lazy rounds, a completion, overturned verdicts, a
    strict retry, a landed step 2)."""
    round_log: tuple[Mapping[str, Any], ...] = ()
    """One record per lazy round: ``round``, ``part`` (its agents in a few words: a part's, or
    the team's), ``stage`` (of that part: ``lazy rounds``, ``held repair``, ``tightening``, ``up front``),
    ``agents`` (how many), ``at`` (s since planning started), ``seconds``, ``ended`` (HiGHS's
    termination), ``bound``, ``best`` (the best plan meeting every requirement so far) and
    ``held`` (the lazy requirements in the model when it was solved, by kind) and ``nodes``
    (HiGHS's branch-and-bound nodes)."""
    stage_seconds: Mapping[str, float] = field(default_factory=dict)
    """Wall time of each stage of the run (step 1, the continuous stage, a diagnosis, the
    monitor's verification), s."""
    first_plan_seconds: float | None = None
    """Seconds from the start of the run until step 1 first held a plan of the whole problem
    meeting every requirement (None without a plan)."""
    convergence: tuple[ConvergencePoint, ...] = ()
    """The whole problem's incumbent and bound over step 1, thinned, in time order (empty
    when neither was ever known)."""
    trace: Mapping[str, Any] = field(default_factory=dict)
    """Every incumbent of step 1 credited to the stage that found it, and each stage's seconds
    (:mod:`stlplan.planner.run.trace`): ``incumbents`` (``at``, ``objective``, ``stage``, ``part``,
    and for an assembly ``parts``: how many parts' plans each stage found), ``stages`` (s),
    ``first_plan`` and ``final_plan`` (the stages that found the first and the best plan)."""
    replan: Replan | None = None
    """For a replan: its step, events and time (None for a plan from the initial states)."""
    dropped: tuple[Dropped, ...] = ()
    """For a degraded plan: the tasks given up, each with its reason."""
    broken_by_the_past: tuple[str, ...] = ()
    """For a replan: the constraints (and the separation) its executed past broke. They fail on
    the whole trajectory, so the plan is degraded; the plan keeps them from getting worse (a
    separation: no closer, and restored as soon as it can be)."""
    robust_to: float = 0.0
    """The disturbance bound the plan's margins withstand (``model.robust_to``; lower than asked
    when keeping every task needed smaller margins, ``diagnosis.margin_fractions``)."""
    values: Mapping[tuple[str, Any], float] = field(default_factory=dict, repr=False)
    """Step 1's plan: the value of each of its model's variables, by component name and index
    (a start for a later solve of the same problem, such as a replan)."""
