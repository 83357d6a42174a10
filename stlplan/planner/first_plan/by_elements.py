"""A plan repaired element by element: its task choices as small problems, planned in turn.

A lazy round's plan (:mod:`stlplan.planner.core.lazy`) meets every task: each task ``<phi, c,
Pattern>`` has chosen ``c`` elements, and a synchronous one a run of steps on which they all
satisfy ``phi``. Held to those choices, the team falls apart into small problems: an element's
agents must satisfy ``phi`` (on the chosen run, for a synchronous task: ``G[start, end] phi``),
an agent no element chose must only meet its constraints, and nothing else links them but
separation. Any plan that gives every chosen element its formula meets every task with the same
choices, and every synchronous task with the synchronous robustness of its run.

So the choices are written as a problem of their own (:func:`element_problem`): every task
replaced by one task of count 1 per chosen element. Its independent parts
(:func:`stlplan.planner.core.team_split.agent_parts`: an element's agents, or an agent alone) are planned
one after another, each around the plans of those before it, and reordered on failure
(:func:`stlplan.planner.first_plan.prioritized.prioritized`, as for a merge of a crowd's parts): the
assignment of the relaxation without separation, then prioritized planning. When every part
finds a plan, the part's model is solved once with every agent held near it, which sets every
decision of the full problem, and the loop's watch takes the plan as any other.

A round's plan does not meet the requirements left out of its model: an agent may reach the
synchronized run's first step only through an obstacle. A part that finds no plan even alone,
first in an order, and that holds a synchronous run, has its task's run start one step later
for every element (while the run stays ``G[0, d]`` long), and the orders start again.

The repair runs before a first plan only (:class:`~stlplan.planner.core.policy.RepairPolicy`):
on a round's plan, or on the plans of parts whose plans collide (each part's choices). It needs
the choices to split the team into parts of at most ``repair.part_agents`` agents. A problem
whose margin is maximized (one part) or that has an executed past (a replan, whose tasks count
past steps) is left to the other repairs.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Hashable, Mapping, Sequence
from dataclasses import dataclass

from stlplan.formula.tree import Always, Interval
from stlplan.mission.problem import Problem, TaskModel
from stlplan.planner.backend.values import load_values, model_values, trajectory_values
from stlplan.planner.config import PlannerConfig
from stlplan.planner.core.repairs import Broken, Rounds
from stlplan.planner.core.team_split import agent_parts, sub_problem
from stlplan.planner.encoding.model import PlanModel, build_model
from stlplan.planner.encoding.readout import chosen, chosen_run
from stlplan.planner.first_plan.prioritized import prioritized
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.outcome import Plan, VarKey

RUN = "_run_e"
"""Between a synchronous task's name and an element's index in the name of the element's task
(:func:`run_of`)."""

Late = Mapping[str, int]
"""Steps a synchronous task's run starts after the chosen run's start, by task name."""


def element_tasks(pm: PlanModel, late: Late | None = None) -> tuple[TaskModel, ...]:
    """The loaded plan's choices as tasks of count 1: one per chosen element of every task,
    a synchronous task's element holding its formula on the chosen run (started ``late``
    steps later; :class:`ValueError` when that leaves the run shorter than ``G[0, d]``)."""
    out: list[TaskModel] = []
    for enc in pm.tasks:
        out += [_single(enc.task, i) for i in chosen(enc)]
    for sync in pm.synchronous:
        members, start, length = chosen_run(sync)
        task, later = sync.task, (late or {}).get(sync.task.name, 0)
        assert task.sync is not None
        if length - later < task.sync.d + 1:
            raise ValueError(f"run of task {task.name} too short")
        run = Interval(start + later, start + length - 1)
        out += [_single(task, i, run) for i in members]
    return tuple(out)


def _single(task: TaskModel, index: int, run: Interval | None = None) -> TaskModel:
    """Element ``index`` of ``task`` as a task of its own (``G run phi`` for a synchronous
    task's run)."""
    formula = task.formula if run is None else Always(run, task.formula)
    name = f"{task.name}_e{index}" if run is None else f"{task.name}{RUN}{index}"
    element = (task.elements[index],)
    return TaskModel(
        name, formula, 1, task.roles, task.rules, task.reuse_agents, element, team=task.team
    )


def has_choices(problem: Problem) -> bool:
    """Whether a task of ``problem`` chooses: among more elements than its count, or a run."""
    return any(t.sync is not None or len(t.elements) > t.count for t in problem.tasks)


def element_problem(
    problem: Problem, models: Sequence[PlanModel], late: Late | None = None
) -> Problem | None:
    """``problem`` with the choices of the plans loaded in ``models`` (its parts, or its own
    model) as its tasks (:func:`element_tasks`); None for a problem whose margin is maximized
    or that has an executed past, or whose tasks choose nothing (:func:`has_choices`: the same
    problem), or when ``late`` leaves a run too short."""
    if problem.past is not None or problem.mission.objective.margin.maximize:
        return None
    if not has_choices(problem):
        return None
    try:
        tasks = tuple(t for pm in models for t in element_tasks(pm, late))
    except ValueError:
        return None
    return dataclasses.replace(problem, tasks=tasks, _by_name={})


@dataclass(frozen=True)
class ElementsRepair:
    """The plan's choices as small problems, planned one after another (module docstring): the
    orders within ``orders_share`` of the repair's time, the solve that turns their plans into
    the part's within all of it."""

    orders_share: float = 0.75

    def repair(self, broken: Broken, config: PlannerConfig, budget: Budget) -> Plan | None:
        solver = broken.solver
        reached, saved = solver.clock.reached, model_values(solver.pm.model)
        with reached.within("repair by elements"):
            plan = _by_elements(broken, config, budget, self.orders_share, saved)
            if plan is None:
                reached.failed("repair by elements")
                load_values(solver.pm.model, saved)  # the broken plan, for the next repair
        return plan

    def describe(self) -> str:
        return "by elements"


def _by_elements(
    broken: Broken,
    config: PlannerConfig,
    budget: Budget,
    share: float,
    loaded: Mapping[VarKey, float],
) -> Plan | None:
    """The repair's orders (:class:`ElementsRepair`) from the broken plan's ``loaded`` values,
    a synchronous run started later for each part that holds one and finds no plan alone."""
    solver = broken.solver
    models = broken.parts or (solver.pm,)
    states = trajectory_values(loaded)
    names = {s.task.name for pm in models for s in pm.synchronous}
    late: dict[str, int] = {}
    built: dict[Hashable, Rounds] = {}
    while not budget.expired():
        problem = element_problem(solver.pm.problem, models, late)
        if problem is None:
            return None
        groups = element_groups(problem, config)
        if groups is None:
            return None
        parts = [element_part(problem, g, solver, config, budget, states, built) for g in groups]
        alone: list[int] = []
        plan = prioritized(solver, parts, config, budget.share(share), budget, alone)
        runs = {run_of(t.name, names) for i in alone for t in parts[i].pm.problem.tasks}
        if plan is not None or not runs - {None}:
            return plan
        for name in runs - {None}:
            late[str(name)] = late.get(str(name), 0) + 1
    return None


def element_groups(problem: Problem, config: PlannerConfig) -> list[tuple[str, ...]] | None:
    """The independent parts of an element problem (:func:`element_problem`) when there are two
    or more, each of at most ``repair.part_agents`` agents; None otherwise."""
    groups = agent_parts(problem)
    if len(groups) < 2 or max(map(len, groups)) > config.repair.part_agents:
        return None
    return groups


def run_of(name: str, synchronous: set[str]) -> str | None:
    """The task of ``synchronous`` (names) whose run the element task ``name`` holds (None:
    not such a task)."""
    head, found, index = name.rpartition(RUN)
    return head if found and index.isdigit() and head in synchronous else None


def element_part(
    problem: Problem,
    agents: tuple[str, ...],
    solver: Rounds,
    config: PlannerConfig,
    budget: Budget,
    states: Mapping[VarKey, float],
    built: dict[Hashable, Rounds],
) -> Rounds:
    """The lazy loop of the part of ``agents`` of ``problem`` (a sibling of ``solver``'s), with
    the plan's ``states`` loaded (the reference of a guided turn); built once for the same
    agents and tasks."""
    sub = sub_problem(problem, agents)
    key = (agents, tuple((t.name, t.formula) for t in sub.tasks))
    if key not in built:
        with solver.clock.building():
            floors = budget.share(config.budget.side_share).deadline
            pm = build_model(sub, config, floors)
        load_values(pm.model, states)
        built[key] = solver.sibling(pm)
    return built[key]
