"""The general-STL suite (missions/stl/): stlplan's optimum equals an independent reference.

The reference (:mod:`tests.reference.robustness_milp`) is the standard robustness encoding of STL
solved with plain highspy; it shares no code with stlplan's planner. Infeasible variants must be
called infeasible by both, and stlplan's command line must exit 4 with a diagnosis.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from stlplan import api
from stlplan.api import Overrides
from stlplan.cli import app
from stlplan.mission.loader import load_problem
from stlplan.result import PlanStatus
from tests.helpers.paths import MISSIONS
from tests.reference.robustness_milp import reference_optimum

SUITE = MISSIONS / "stl"

FEASIBLE = (
    "bounded-until", "door-key", "dwell", "dwell-sequence", "either-or", "formation-pair",
    "formation-trio", "many-targets", "narrow-passage", "patrol", "stepping-stones",
)  # fmt: skip
INFEASIBLE = ("door-locked", "dwell-too-late", "formation-split", "patrol-too-far")
SLOW = {*FEASIBLE, "door-locked"} - {"bounded-until"}
"""Missions whose reference and stlplan solves take more than about 10 s together (one core)."""


def _cases(names: tuple[str, ...]) -> list[object]:
    # the reference and stlplan each have 120 s: together they may pass the suite's 300 s
    slow = [pytest.mark.slow, pytest.mark.timeout(600)]
    return [pytest.param(n, marks=slow) if n in SLOW else n for n in names]


def test_the_suite_lists_every_mission_once() -> None:
    shipped = sorted(p.stem for p in SUITE.glob("*.yaml"))
    assert shipped == sorted(FEASIBLE + INFEASIBLE)
    assert len(FEASIBLE) >= 10 and len(INFEASIBLE) >= 3


def test_reference_reaches_the_analytic_cap_of_reach_avoid() -> None:
    # The goal is a 2 x 2 box, so no margin exceeds 1; a path keeping 1 from the obstacle exists.
    found = reference_optimum(load_problem(MISSIONS / "reach-avoid.yaml"))
    assert found.status == "optimal"
    assert found.margin == pytest.approx(1.0, abs=1e-7)


@pytest.mark.parametrize("name", _cases(FEASIBLE))
def test_suite_optimum_equals_the_reference(name: str) -> None:
    path = SUITE / f"{name}.yaml"
    reference = reference_optimum(load_problem(path))
    assert reference.status == "optimal" and reference.objective is not None
    _, result = api.plan(path, overrides=Overrides(threads=1))
    assert result.status is PlanStatus.OPTIMAL
    assert result.objective == pytest.approx(reference.objective, abs=1e-5)
    assert result.report is not None and result.report.satisfied
    assert result.margin is not None and result.margin >= 0
    assert result.margin == pytest.approx(result.report.spatial_robustness, abs=1e-9)


@pytest.mark.parametrize("name", _cases(INFEASIBLE))
def test_suite_infeasible_variant_exits_4_with_a_diagnosis(name: str, tmp_path: Path) -> None:
    path = SUITE / f"{name}.yaml"
    assert reference_optimum(load_problem(path)).status == "infeasible"
    out = tmp_path / "plan"
    found = CliRunner().invoke(app, ["solve", str(path), "--out", str(out), "-q", "--threads", "1"])
    assert found.exit_code == 4, found.output
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert summary["status"] == "infeasible"
    diagnosis = summary["diagnosis"]
    assert diagnosis["reasons"] or diagnosis["conflict"]
