"""The size of a mission's MILP, estimated from the mission before anything is built.

A horizon of thousands of steps, or a formula whose nested intervals multiply, can ask for a
model that no machine builds in time or holds in memory. :func:`estimate` counts, without
building, what the encoder creates: per agent and step the state, the input and its absolute
value (dynamics and effort rows); per task element the indicators of its formula's
(subformula, step) pairs, ``G[a,b] f`` and ``F[a,b] f`` evaluating ``f`` at ``b - a + 1``
steps, capped by the formula's size times ``H + 1`` (an indicator per subformula and step at
most); per element one selection binary (per group one indicator with the group encoding), and
per synchronous task one window binary per step; per agent pair and step the four sides
of the separation. :func:`check_size` refuses a model whose estimated memory exceeds the
machine's or whose estimated build time exceeds the time limit, with the numbers and what to
change.

Building time and memory grow faster than the model with the horizon (Pyomo and the solver
interface), so for ``S`` variables plus rows and horizon ``H`` they are estimated as
``t = c S (1 + H / H_t)`` and ``M = M_0 + b S (1 + (H / H_m)^2)``, with the constants measured
on Case I with horizons 9, 50 and 200 (1 s, 3 s and 21 s of building, 0.34 GB at 200) and on
``sync-pair`` with horizon 2000 (59 s, 3.8 GB).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from stlplan.errors import MissionError
from stlplan.formula import tree
from stlplan.formula.tree import Formula
from stlplan.mission.formula_checks import MAX_GROUPS
from stlplan.mission.groups import count_groups
from stlplan.mission.problem import Problem, TaskModel

SECONDS_PER_ENTRY = 9e-5
"""``c``: building seconds per variable or row at a short horizon."""
TIME_HORIZON = 170
"""``H_t``: horizon at which building one entry takes twice as long as at a short horizon."""
BYTES_PER_ENTRY = 1_600
"""``b``: memory per variable or row at a short horizon."""
MEMORY_HORIZON = 410
"""``H_m``: horizon at which one entry needs twice the memory it needs at a short horizon."""
BASE_BYTES = 200 * 2**20
"""``M_0``: memory of the process before any model is built."""
MIN_REFUSED_SECONDS = 30.0
"""A model estimated to build faster than this is always tried (the time budget handles it)."""


@dataclass(frozen=True)
class SizeEstimate:
    """What building the MILP of a mission would take, estimated before building it."""

    variables: int
    rows: int
    memory_bytes: int
    build_seconds: float

    @property
    def entries(self) -> int:
        """Variables plus rows."""
        return self.variables + self.rows


def _width(formula: Any) -> int:
    return int(formula.interval.hi - formula.interval.lo + 1)


_Count = Callable[[Any, Problem], int]
_EXPANDED: dict[type, _Count] = {
    # (subformula, step) pairs one evaluation of the node creates, with no sharing
    tree.InRegion: lambda f, p: 1 + len(p.regions[f.region][0]) if f.region in p.regions else 5,
    tree.Distance: lambda f, p: 5,
    tree.Linear: lambda f, p: 1,
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
    **{t: _EXPANDED[t] for t in (tree.InRegion, tree.Distance, tree.Linear, tree.Predicate)},
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


def estimate(problem: Problem, tasks: str = "selection") -> SizeEstimate:
    """The estimated size of ``problem``'s MILP with the task encoding ``tasks`` (see the module
    docstring)."""
    steps = problem.horizon + 1
    variables = sum((a.n + 2 * a.m) * steps for a in problem.agents)
    rows = sum((a.n + 2 * a.m) * problem.horizon for a in problem.agents)
    units = 0
    for task in problem.tasks:
        evaluations = 1 if task.sync is None else task.sync.b - task.sync.a + 1 + task.sync.d
        units += len(task.elements) * formula_cost(task.formula, problem, evaluations)
        units += choice_units(task, tasks, steps)
    for constraint in problem.constraints:
        units += len(constraint.bindings) * formula_cost(constraint.formula, problem)
    if problem.separation is not None:
        pairs = len(problem.agents) * (len(problem.agents) - 1) // 2
        units += 4 * pairs * steps
    variables += units
    rows += 2 * units
    entries = variables + rows
    return SizeEstimate(
        variables=variables,
        rows=rows,
        memory_bytes=int(
            BASE_BYTES + BYTES_PER_ENTRY * entries * (1 + (problem.horizon / MEMORY_HORIZON) ** 2)
        ),
        build_seconds=SECONDS_PER_ENTRY * entries * (1 + problem.horizon / TIME_HORIZON),
    )


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


def check_size(problem: Problem, time_limit: float, tasks: str = "selection") -> SizeEstimate:
    """The estimate, or a :class:`MissionError` (field ``horizon``) when the model cannot fit the
    machine's memory or be built within ``time_limit`` seconds."""
    size = estimate(problem, tasks)
    memory = available_memory()
    too_big = size.memory_bytes > memory
    too_slow = size.build_seconds > max(time_limit, MIN_REFUSED_SECONDS)
    if not (too_big or too_slow):
        return size
    gib = 2**30
    found = (
        f"the model would have about {size.variables:,} variables and {size.rows:,} rows "
        f"(horizon {problem.horizon}, {len(problem.agents)} agents), "
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
