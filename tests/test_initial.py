"""Conflicts at step 0 and margins no region allows are found before solving, in well under a
second, naming the agent (or pair), the step and the requirement."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import yaml

import stlplan.planner.solve  # noqa: F401  (imported here: the timing below is the diagnosis's, not Pyomo's import)
from stlplan import api
from stlplan.analysis.initial import initial_reasons, step0_part
from stlplan.formula.parser import parse
from stlplan.mission.loader import load_problem
from stlplan.result import PlanStatus
from tests.helpers.paths import BASE, MISSIONS


def _variant(tmp: Path, edit: Callable[[dict[str, Any]], None]) -> Path:
    data = yaml.safe_load(BASE.read_text(encoding="utf-8"))
    edit(data)
    path = tmp / "variant.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return path


def _start_in_obstacle(data: dict[str, Any]) -> None:
    data["agents"][0]["initial_state"] = [2.5, 2.0, 0, 0]


def _start_too_close(data: dict[str, Any]) -> None:
    data["agents"][1]["initial_state"] = [0.52, 0.5, 0, 0]
    data["separation"] = 0.05


def _start_too_close_for_the_margin(data: dict[str, Any]) -> None:
    data["agents"][1]["initial_state"] = [0.6, 0.5, 0, 0]  # 0.1 apart: 0.05 to spare, not 0.1
    data["separation"] = 0.05
    data["objective"] = {"margin": {"minimum": 0.1}}


def _goal_off_the_map(data: dict[str, Any]) -> None:
    data["regions"]["Goal"] = {"box": [[7, 8], [1, 3]]}


def _margin_too_large(data: dict[str, Any]) -> None:
    data["objective"] = {"margin": {"minimum": 0.8}}


def _start_off_the_ground(data: dict[str, Any]) -> None:
    data["tasks"]["start"] = {"formula": "p.x[1] >= 3", "count": 2, "roles": {"p": "ground"}}


CASES = {
    "start_in_obstacle": (
        _start_in_obstacle,
        ("avoid",),
        ("constraint 'avoid'", "'!in(p, Obs)' at step 0", "p = a1 at (2.5, 2)", "-0.5"),
    ),
    "start_too_close": (
        _start_too_close,
        ("separation",),
        ("agents 'a1' and 'a2'", "0.02 apart at step 0", "separation 0.05"),
    ),
    "start_too_close_for_the_margin": (
        _start_too_close_for_the_margin,
        ("separation",),
        (
            "agents 'a1' and 'a2'",
            "0.1 apart at step 0",
            "separation 0.05 with the required margin 0.1",
        ),
    ),
    "goal_off_the_map": (
        _goal_off_the_map,
        ("meet",),
        ("task 'meet'", "region 'Goal'", "outside the state bounds", "a1: x in [0, 6]"),
    ),
    "margin_too_large": (
        _margin_too_large,
        ("meet",),
        ("task 'meet'", "region 'Goal'", "margin 0.8", "more than 0.75 inside"),
    ),
    "start_off_the_ground": (
        _start_off_the_ground,
        ("start",),
        ("task 'start'", "at step 0 (2 element(s)", "only 1 of its 2"),
    ),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_a_step0_conflict_is_diagnosed_before_solving(tmp_path: Path, name: str) -> None:
    edit, conflict, fragments = CASES[name]
    path = _variant(tmp_path, edit)
    started = time.perf_counter()
    _, result = api.plan(path, api.Overrides(threads=1, time_limit=60))
    assert time.perf_counter() - started < 1.0
    assert result.status is PlanStatus.INFEASIBLE
    assert result.model_size is None  # nothing was built
    assert result.diagnosis is not None and result.diagnosis.conflict == conflict
    text = result.diagnosis.reasons[0]
    for fragment in fragments:
        assert fragment in text, f"{fragment!r} not in {text!r}"


@pytest.mark.parametrize("path", sorted(MISSIONS.glob("*.yaml")), ids=lambda p: p.stem)
def test_shipped_missions_have_no_step0_conflict(path: Path) -> None:
    assert initial_reasons(load_problem(path)) == ()


def test_the_base_mission_has_no_step0_conflict() -> None:
    assert initial_reasons(load_problem(BASE)) == ()


def test_step0_part_follows_what_must_hold_at_step_0() -> None:
    def part(text: str) -> str | None:
        found = step0_part(parse(text))
        return None if found is None else repr(found)

    assert part("G[0,8] !in(p, Obs)") == repr(parse("!in(p, Obs)"))
    assert part("G[1,8] !in(p, Obs)") is None
    assert part("F[0,3] in(p, A)") is None
    assert part("F[0,0] in(p, A)") == repr(parse("in(p, A)"))
    assert part("in(p, A) U[1,3] in(p, B)") == repr(parse("in(p, A)"))
    assert part("in(p, A) | F[1,2] in(p, B)") is None
    assert part("in(p, A) & F[1,2] in(p, B)") == repr(parse("in(p, A)"))
    assert part("in(p, A) | G[0,2] in(p, B)") == repr(parse("in(p, A) | in(p, B)"))
