"""Classes of interchangeable agents and their ordering rows (symmetry.py)."""

from __future__ import annotations

import copy
from collections.abc import Callable
from typing import Any

import pytest
import yaml

from stlplan import api
from stlplan.mission.loader import load_problem
from stlplan.mission.problem import Problem, build_problem
from stlplan.mission.schema import Mission
from stlplan.planner.config import TaskForm
from stlplan.planner.encoding.model import build_model
from stlplan.planner.encoding.selection import Selection
from stlplan.planner.encoding.symmetry import agent_classes, chain_task
from stlplan.planner.solve import model_size
from stlplan.result import PlanStatus
from tests.helpers.configs import paper_model
from tests.helpers.paths import MISSIONS

SMALL = MISSIONS / "scale" / "farm-depot-small.yaml"
DEPOT = MISSIONS / "scale" / "farm-x2-depot.yaml"
UV, VIS = ("uv1", "uv2"), ("vis1", "vis2")


def small(change: Callable[[dict[str, Any]], None]) -> Problem:
    """The small depot mission with ``change`` applied to its document."""
    document = yaml.safe_load(SMALL.read_text(encoding="utf-8"))
    change(document)
    return build_problem(Mission.model_validate(document))


def _agent(document: dict[str, Any], name: str) -> dict[str, Any]:
    agent: dict[str, Any] = next(a for a in document["agents"] if a["name"] == name)
    return agent


def test_classes_of_the_depot_missions() -> None:
    assert agent_classes(load_problem(SMALL)) == [UV, VIS]
    assert agent_classes(load_problem(DEPOT)) == [
        tuple(f"uv{i}" for i in range(1, 7)),
        tuple(f"ir{i}" for i in range(1, 5)),
        tuple(f"vis{i}" for i in range(1, 7)),
    ]
    assert agent_classes(load_problem(MISSIONS / "farm.yaml")) == []


def _initial_state(d: dict[str, Any]) -> None:
    _agent(d, "vis2")["initial_state"] = [1.1, 3.8 + 1e-9, 0, 0]


def _capability(d: dict[str, Any]) -> None:
    _agent(d, "uv2")["capabilities"] = ["UV", "IR"]


def _input_bounds(d: dict[str, Any]) -> None:
    d["dynamics"]["slow"] = copy.deepcopy(d["dynamics"]["ground"])
    d["dynamics"]["slow"]["input_bounds"] = [[-2, 2], [-1.9, 2]]
    _agent(d, "vis2")["dynamics"] = "slow"


def _at_rest(d: dict[str, Any]) -> None:
    _agent(d, "uv1")["final"] = "at_rest"


def _constraint_list(d: dict[str, Any]) -> None:
    d["constraints"]["stay"] = {"formula": "G[0,9] !in(p, C)", "for_each": "p", "agents": ["uv2"]}


def _constraint_role(d: dict[str, Any]) -> None:
    d["constraints"]["visit"] = {"formula": "F[0,9] in(p, C)", "roles": {"p": "vis1"}}


def _pinned_role(d: dict[str, Any]) -> None:
    d["tasks"]["crop_A1"]["roles"] = {"p": {"agent": "uv1"}}


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        (_initial_state, [UV]),
        (_capability, [VIS]),
        (_input_bounds, [UV]),
        (_at_rest, [VIS]),
        (_constraint_list, [VIS]),
        (_constraint_role, [UV]),
        (_pinned_role, [VIS]),
    ],
    ids=lambda v: getattr(v, "__name__", ""),
)
def test_agents_that_differ_or_are_named_are_not_interchangeable(
    change: Callable[[dict[str, Any]], None], expected: list[tuple[str, ...]]
) -> None:
    assert agent_classes(small(change)) == expected


def test_a_copy_of_the_dynamics_keeps_the_class() -> None:
    def copied(d: dict[str, Any]) -> None:
        d["dynamics"]["twin"] = copy.deepcopy(d["dynamics"]["ground"])
        _agent(d, "vis2")["dynamics"] = "twin"

    assert agent_classes(small(copied)) == [UV, VIS]


def test_swapping_class_members_maps_elements_and_bindings_onto_themselves() -> None:
    problem = load_problem(DEPOT)
    for members in agent_classes(problem):
        swap = {members[0]: members[-1], members[-1]: members[0]}
        for task in problem.tasks:
            elements = set(task.elements)
            assert {tuple(swap.get(a, a) for a in e) for e in elements} == elements, task.name
        for constraint in problem.constraints:
            bindings = {tuple(sorted(b.items())) for b in constraint.bindings}
            moved = {tuple(sorted((r, swap.get(a, a)) for r, a in b)) for b in bindings}
            assert moved == bindings, constraint.name


def test_the_chain_skips_a_task_whose_elements_are_all_required() -> None:
    problem = small(lambda d: d["tasks"]["crop_A1"].update(count=2, reuse_agents=True))
    a1, a2, c = problem.tasks
    selections = {
        "crop_A1": Selection(a1, (1.0, 1.0)),
        "crop_A2": Selection(a2, ("x0", "x1")),
        "crop_C": Selection(c, ("x2", "x3")),
    }
    assert chain_task(problem, UV, selections) is selections["crop_A2"]
    assert chain_task(problem, VIS, selections) is selections["crop_C"]


@pytest.mark.parametrize("path", [SMALL, MISSIONS / "farm.yaml"], ids=lambda p: p.stem)
def test_rows_only_with_the_option_and_with_selection(path: Any) -> None:
    problem = load_problem(path)
    chains = sum(len(c) - 1 for c in agent_classes(problem))
    sizes = {}
    forms: tuple[TaskForm, ...] = ("selection", "groups")
    for tasks in forms:
        for on in (False, True):
            pm = build_model(
                problem,
                paper_model(lazy__enabled=True, model__tasks=tasks, model__symmetry=on),
            )
            sizes[tasks, on] = model_size(pm.model)
    rows = sizes["selection", True].constraints - sizes["selection", False].constraints
    assert rows == chains == (2 if path == SMALL else 0)
    assert sizes["groups", True] == sizes["groups", False]
    assert sizes["selection", True].variables == sizes["selection", False].variables


def test_same_optimum_with_and_without_the_rows() -> None:
    objectives, groups = [], {}
    for on in (False, True):
        overrides = api.Overrides(threads=1, gap=1e-6, config={"model.symmetry": on})
        _, result = api.plan(SMALL, overrides)
        assert result.status is PlanStatus.OPTIMAL, result.message
        assert result.report is not None and result.report.satisfied, result.message
        assert result.solver is not None and result.solver.objective is not None
        objectives.append(result.solver.objective)
        groups = {v.name: v.group for v in result.report.verdicts}
    assert objectives[1] == pytest.approx(objectives[0], rel=2e-6)  # both within the gap 1e-6
    assert groups["crop_A1"] == (("uv1",),) and groups["crop_C"] == (("vis1",),)  # the chains
