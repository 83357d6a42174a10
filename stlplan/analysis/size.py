"""The size of a mission's MILP, estimated from the mission before anything is built.

A horizon of thousands of steps, a formula whose nested intervals multiply, or a team of
hundreds of agents can ask for a model that no machine builds in time or holds in memory.
:func:`estimate` counts, without building, what the encoder creates:

* per agent and step the state, the input and its absolute value (dynamics and effort rows);
* per task element the indicators of its formula's (subformula, step) pairs, ``G[a,b] f`` and
  ``F[a,b] f`` evaluating ``f`` at ``b - a + 1`` steps, capped by the formula's size times
  ``H + 1`` (an indicator per subformula and step at most); per element one selection binary
  (per group one indicator with the group encoding), and per synchronous task one window
  binary per step;
* the *step requirements* of constraints and separation (:func:`step_counts`): each a
  disjunction of half-planes at one step (``!in(p, Obs)`` at ``k``, one pair apart at ``k``),
  costing :data:`SIDE_VARIABLES` variables and :data:`SIDE_ROWS` rows per half-plane (its
  indicator, its share of the choice, and its segment to the next step); a constraint's other
  parts (temporal structure below a disjunction) are counted as task formulas.

With lazy rounds (``lazy.enabled``, the default) the step requirements are left out of the
first model and added while solving, within the time limit; the first model is the rest. The
estimate is of what planning builds before its first solve, which no time limit interrupts:
the first model, encoded and loaded into HiGHS (:data:`SECONDS_PER_ENTRY` and
:data:`BYTES_PER_ENTRY` per variable or row; :data:`PARTS_BUILDS` times with parts, whose
models and the whole team's, for the assembly, are all built first), the step requirements
listed and checked against the reachable boxes (:data:`SECONDS_PER_REQUIREMENT`,
:data:`BYTES_PER_REQUIREMENT`), and each agent's effort-floor LP set up, dense in the horizon
(:data:`SECONDS_PER_FLOOR_CELL`, :data:`FLOOR_BYTES_PER_CELL` per cell of its matrix). Not
counted: the floors' LPs, which stop at their share of the time (``budget.side_share``), and
the requirements lazy rounds add, each within the time limit. The constants were measured on
the shipped farm and crowd missions, the farm at horizons 50 and 200 and ``sync-pair`` at
horizons 500 to 2000 (docs/measurements.md#validation-size-and-building).

:func:`check_size` refuses a model whose estimated memory exceeds the machine's or whose
estimated build time exceeds the time limit, with the numbers and what to change.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from stlplan.errors import MissionError
from stlplan.formula import tree
from stlplan.formula.tree import Distance, Formula
from stlplan.mission.formula_checks import MAX_GROUPS
from stlplan.mission.groups import count_groups
from stlplan.mission.problem import Problem, TaskModel
from stlplan.planner.config import PlannerConfig

SECONDS_PER_ENTRY = 6e-5
"""Building and loading one variable or row of the first model, s."""
PARTS_BUILDS = 2
"""Models of the team built before the first solve when the team is solved by parts."""
SECONDS_PER_REQUIREMENT = 3e-5
"""Listing one step requirement and checking it against the reachable boxes, s."""
SECONDS_PER_FLOOR_CELL = 6e-8
"""Setting up one cell of an agent's dense effort-floor LP, s."""
SIDE_VARIABLES = 6
"""Variables of one half-plane of a step requirement (up front, or once added): its
indicator, its share of the choice, its segment to the next step."""
SIDE_ROWS = 8
"""Rows of one half-plane of a step requirement."""
BYTES_PER_ENTRY = 1_400
"""Memory per variable or row of a built and loaded model."""
BYTES_PER_REQUIREMENT = 600
"""Memory per listed step requirement."""
FLOOR_BYTES_PER_CELL = 3
"""Memory each agent's effort-floor LP keeps per cell of its matrix ..."""
FLOOR_PEAK_BYTES_PER_CELL = 19
"""... and needs while it is set up (one agent at a time)."""
BASE_BYTES = 200 * 2**20
"""``M_0``: memory of the process before any model is built."""
MIN_REFUSED_SECONDS = 30.0
"""A model estimated to build faster than this is always tried (the time budget handles it)."""


@dataclass(frozen=True)
class SizeEstimate:
    """What building the MILP of a mission would take, estimated before building it.

    Attributes
    ----------
    variables, rows
        Of the first model planning builds (with lazy rounds: the step requirements left out).
    requirements
        Step requirements of constraints and separation (left out of a lazy first model).
    memory_bytes
        Memory of what is built before the first solve.
    build_seconds
        Time spent building before the first solve (the floors' LPs, cut at their share of
        the time, left out).
    """

    variables: int
    rows: int
    requirements: int
    memory_bytes: int
    build_seconds: float

    @property
    def entries(self) -> int:
        """Variables plus rows of the first model."""
        return self.variables + self.rows


def _width(formula: Any) -> int:
    return int(formula.interval.hi - formula.interval.lo + 1)


def _counted(f: Any, p: Problem) -> int:
    # a count: per agent counted, its in(@a, R) (and for visits, an entry per step) and a binary
    faces = len(p.regions[f.region][0]) if f.region in p.regions else 4
    agents = sum(f.who.admits(a.capabilities) for a in p.agents)
    per_agent = 2 + faces if isinstance(f, tree.Count) else _width(f) * (4 + 2 * faces)
    return 1 + agents * per_agent


_Count = Callable[[Any, Problem], int]
_EXPANDED: dict[type, _Count] = {
    # (subformula, step) pairs one evaluation of the node creates, with no sharing
    tree.InRegion: lambda f, p: 1 + len(p.regions[f.region][0]) if f.region in p.regions else 5,
    tree.Distance: lambda f, p: 5,
    tree.Linear: lambda f, p: 1,
    tree.Count: _counted,
    tree.Visits: _counted,
    tree.Predicate: lambda f, p: 1,
    tree.Not: lambda f, p: expanded(f.atom, p),
    tree.And: lambda f, p: 1 + sum(expanded(c, p) for c in f.children),
    tree.Or: lambda f, p: 1 + sum(expanded(c, p) for c in f.children),
    tree.Always: lambda f, p: 1 + _width(f) * expanded(f.child, p),
    tree.Eventually: lambda f, p: 1 + _width(f) * expanded(f.child, p),
    tree.Until: lambda f, p: 1 + _width(f) * (expanded(f.left, p) + expanded(f.right, p)),
}
_STATIC: dict[type, _Count] = {
    # nodes of the tree, each atom counted with its rows
    **{t: _EXPANDED[t] for t in (*tree.ATOM_TYPES,)},
    tree.Not: lambda f, p: static(f.atom, p),
    tree.And: lambda f, p: 1 + sum(static(c, p) for c in f.children),
    tree.Or: lambda f, p: 1 + sum(static(c, p) for c in f.children),
    tree.Always: lambda f, p: 1 + static(f.child, p),
    tree.Eventually: lambda f, p: 1 + static(f.child, p),
    tree.Until: lambda f, p: 1 + static(f.left, p) + static(f.right, p),
}


def expanded(formula: Formula, problem: Problem) -> int:
    """Indicators one evaluation of ``formula`` needs when nothing is shared."""
    return _EXPANDED[type(formula)](formula, problem)


def static(formula: Formula, problem: Problem) -> int:
    """Nodes of ``formula``, each atom counted with its half-space rows."""
    return _STATIC[type(formula)](formula, problem)


def formula_cost(formula: Formula, problem: Problem, evaluations: int = 1) -> int:
    """Indicators of ``evaluations`` evaluations of ``formula``, at most one per subformula and
    step."""
    return min(
        evaluations * expanded(formula, problem), static(formula, problem) * (problem.horizon + 1)
    )


def choice_units(task: TaskModel, tasks: str, steps: int) -> int:
    """Variables of a task's choice: one per group (the paper's encoding, per step for a
    synchronous task), or one per element (selection; the window adds one per step)."""
    per = 1 if task.sync is None else steps
    if tasks == "groups":
        return per * count_groups(task.elements, task.count, task.reuse_agents, MAX_GROUPS + 1)
    return len(task.elements) * per + (0 if task.sync is None else steps)


@dataclass(frozen=True)
class StepCounts:
    """A lowered constraint split as the encoder splits it (``stlplan.planner.encoding.deferred``).

    Attributes
    ----------
    requirements
        Step requirements: a half-plane, or a disjunction of half-planes, at one step.
    sides
        Their half-planes.
    other
        Indicators of the other parts (temporal structure below a disjunction).
    """

    requirements: int = 0
    sides: int = 0
    other: int = 0

    def __add__(self, more: StepCounts) -> StepCounts:
        return StepCounts(
            self.requirements + more.requirements, self.sides + more.sides, self.other + more.other
        )

    def times(self, n: int) -> StepCounts:
        """``n`` copies: at ``n`` steps, or under ``n`` bindings."""
        return StepCounts(n * self.requirements, n * self.sides, n * self.other)


def step_counts(formula: Formula, problem: Problem) -> StepCounts:
    """The step parts of a lowered ``formula`` (``G`` and ``and`` unrolled, as
    :func:`stlplan.formula.tree.step_parts` yields them), counted without unrolling."""
    if isinstance(formula, tree.And):
        return sum((step_counts(c, problem) for c in formula.children), StepCounts())
    if isinstance(formula, tree.Always):
        return step_counts(formula.child, problem).times(_width(formula))
    if isinstance(formula, tree.Predicate):
        return StepCounts(1, 1)
    if isinstance(formula, tree.Or) and all(
        isinstance(c, tree.Predicate) for c in formula.children
    ):
        return StepCounts(1, len(formula.children))
    return StepCounts(other=formula_cost(formula, problem))


def safety_counts(problem: Problem) -> StepCounts:
    """The step parts of every constraint under every binding, and of the separation of every
    pair at every step."""
    counts = StepCounts()
    for constraint in problem.constraints:
        if constraint.bindings:
            lowered = problem.lowered(constraint.formula, constraint.bindings[0])
            counts += step_counts(lowered, problem).times(len(constraint.bindings))
    agents = len(problem.agents)
    if problem.separation is not None and agents > 1:
        apart = Distance("p", "q", ">=", problem.separation)
        lowered = problem.lowered(apart, {"p": problem.agents[0].name, "q": problem.agents[1].name})
        pairs = agents * (agents - 1) // 2
        counts += step_counts(lowered, problem).times(pairs * (problem.horizon + 1))
    return counts


def floor_cells(problem: Problem, config: PlannerConfig) -> tuple[int, int]:
    """Cells of the agents' dense effort-floor LPs (``stlplan.planner.encoding.effort_lp``):
    rows ``2 H m + H n`` by columns ``2 H m`` per agent; their sum and the largest (none
    without floors)."""
    floors = config.model.floors and problem.mission.objective.beta > 0
    if not floors or problem.past is not None:
        return 0, 0
    h = problem.horizon
    cells = [(2 * h * a.m + h * a.n) * 2 * h * a.m for a in problem.agents]
    return sum(cells), max(cells, default=0)


def _first_model(problem: Problem, config: PlannerConfig, safety: StepCounts) -> tuple[int, int]:
    """Variables and rows of the first model: agents, tasks, the constraints' other parts, and
    the step requirements unless they are left out (lazy)."""
    steps = problem.horizon + 1
    variables = sum((a.n + 2 * a.m) * steps for a in problem.agents)
    rows = sum((a.n + 2 * a.m) * problem.horizon for a in problem.agents)
    units = safety.other
    for task in problem.tasks:
        evaluations = 1 if task.sync is None else task.sync.b - task.sync.a + 1 + task.sync.d
        units += len(task.elements) * formula_cost(task.formula, problem, evaluations)
        units += choice_units(task, config.model.tasks, steps)
    variables, rows = variables + units, rows + 2 * units
    if not config.lazy.enabled:
        variables, rows = variables + SIDE_VARIABLES * safety.sides, rows + SIDE_ROWS * safety.sides
    return variables, rows


def estimate(problem: Problem, config: PlannerConfig | None = None) -> SizeEstimate:
    """The estimated size of ``problem``'s MILP as ``config`` (default: the mission's) builds
    it (see the module docstring)."""
    config = config or PlannerConfig.from_mission(problem.mission)
    safety = safety_counts(problem)
    variables, rows = _first_model(problem, config, safety)
    cells, largest = floor_cells(problem, config)
    built = (variables + rows) * (
        PARTS_BUILDS if config.lazy.enabled and config.parts.enabled else 1
    )
    seconds = (
        SECONDS_PER_ENTRY * built
        + SECONDS_PER_REQUIREMENT * safety.requirements
        + SECONDS_PER_FLOOR_CELL * cells
    )
    memory = (
        BASE_BYTES
        + BYTES_PER_ENTRY * built
        + BYTES_PER_REQUIREMENT * safety.requirements
        + FLOOR_BYTES_PER_CELL * cells
        + FLOOR_PEAK_BYTES_PER_CELL * largest
    )
    return SizeEstimate(variables, rows, safety.requirements, int(memory), seconds)


def available_memory() -> int:
    """Bytes of memory this machine has available (physical memory when that is unknown)."""
    try:
        with open("/proc/meminfo", encoding="ascii") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return 2**62  # unknown: never refuse on memory


def _left_out(size: SizeEstimate, config: PlannerConfig) -> str:
    """What the lazy rounds add later, in words (empty when nothing is left out)."""
    if not config.lazy.enabled or not size.requirements:
        return ""
    return f"; {size.requirements:,} step requirements left for the lazy rounds"


def check_size(problem: Problem, config: PlannerConfig | None = None) -> SizeEstimate:
    """The estimate, or a :class:`MissionError` (field ``horizon``) when the model cannot fit the
    machine's memory or be built within the time limit (``solver.time_limit`` of ``config``,
    default: the mission's)."""
    config = config or PlannerConfig.from_mission(problem.mission)
    time_limit = config.solver.time_limit
    size = estimate(problem, config)
    memory = available_memory()
    too_big = size.memory_bytes > memory
    too_slow = size.build_seconds > max(time_limit, MIN_REFUSED_SECONDS)
    if not (too_big or too_slow):
        return size
    gib = 2**30
    found = (
        f"the model would have about {size.variables:,} variables and {size.rows:,} rows "
        f"(horizon {problem.horizon}, {len(problem.agents)} agents{_left_out(size, config)}), "
    )
    if too_big:
        found += (
            f"needing about {size.memory_bytes / gib:,.1f} GiB of memory where this machine has "
            f"{memory / gib:.1f} GiB available"
        )
    else:
        found += (
            f"taking about {size.build_seconds:,.0f} s to build where the time limit is "
            f"{time_limit:g} s"
        )
    raise MissionError(
        f"{found}; expected a model that fits: shorten the horizon or the formulas' intervals, "
        "use fewer agents or groups" + ("" if too_big else ", or raise the time limit"),
        source=problem.source,
        where="horizon",
    )
