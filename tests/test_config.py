"""The planner's one configuration tree (stlplan.planner.config)."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from stlplan import api
from stlplan.mission.loader import load_problem
from stlplan.planner.config import ConfigError, PlannerConfig, knob_docs
from stlplan.planner.encoding.model import build_model
from stlplan.planner.encoding.sos1 import sos1
from stlplan.planner.encoding.stl import StlContext
from stlplan.planner.overrides import Overrides
from stlplan.planner.solve import model_size
from stlplan.planner.strategy import describe
from tests.helpers import knob_table
from tests.helpers.paths import MISSIONS, ROOT

PAIR = MISSIONS / "sync-pair.yaml"


def test_an_override_sets_its_knob_and_nothing_else() -> None:
    config = PlannerConfig().with_overrides({"repair.crowd_agents": 5})
    assert config.repair.crowd_agents == 5
    changed = {k for k, v in config.dotted().items() if PlannerConfig().dotted()[k] != v}
    assert changed == {"repair.crowd_agents"}


@pytest.mark.parametrize(
    ("dotted", "named"),
    [
        ({"repair.crowd": 5}, "repair.crowd"),
        ({"colour": "red"}, "colour"),
        ({"solver": 1.0}, "solver"),
    ],
)
def test_an_unknown_knob_is_an_error_that_names_it(dotted: dict, named: str) -> None:
    with pytest.raises(ConfigError, match=f"unknown planner setting '{named}'"):
        PlannerConfig().with_overrides(dotted)


@pytest.mark.parametrize(
    ("dotted", "expected"),
    [
        ({"repair.crowd_agents": "5"}, "valid integer"),
        ({"model.encoding": "binary"}, "'log' or 'standard'"),
        ({"lazy.enabled": 1}, "valid boolean"),
        ({"solver.gap": -0.1}, "greater than or equal to 0"),
        ({"parts.merge_reserve": 1.5}, "less than 1"),
    ],
)
def test_a_wrong_value_is_an_error_that_names_the_knob(dotted: dict, expected: str) -> None:
    (name,) = dotted
    with pytest.raises(ConfigError, match=f"'{name}'") as caught:
        PlannerConfig().with_overrides(dotted)
    assert expected in str(caught.value)


def test_the_mission_sets_its_solver_settings_and_overrides_come_last() -> None:
    mission = load_problem(PAIR).mission
    config = PlannerConfig.from_mission(
        mission, Overrides(gap=0.5, config={"repair.orders": 2}).dotted()
    )
    assert config.solver.time_limit == mission.solver.time_limit
    assert config.solver.gap == 0.5 and config.repair.orders == 2
    assert config.continuous.two_step is mission.objective.two_step


def test_every_layer_has_the_same_defaults() -> None:
    defaults = PlannerConfig()
    context = StlContext.__dataclass_fields__["encoding"].default
    assert context == defaults.model.encoding
    assert sos1.__defaults__ == (defaults.model.encoding,)
    problem = load_problem(MISSIONS / "warehouse.yaml")
    direct = model_size(build_model(problem).model)
    planned = model_size(build_model(problem, PlannerConfig.from_mission(problem.mission)).model)
    assert direct == planned


def test_every_knob_is_documented() -> None:
    rows = knob_docs()
    assert len(rows) == len(PlannerConfig().dotted())
    assert all(doc.strip() for _, _, _, doc in rows)


def test_the_tree_holds_at_most_forty_knobs() -> None:
    # every tuning value is a knob of the one tree, and a knob nobody measured is dropped
    assert len(PlannerConfig().dotted()) <= 40


def test_the_strategy_line_follows_the_configuration() -> None:
    line = describe(PlannerConfig())
    assert "parts(lazy rounds(" in line and ">= 7 agents" in line
    assert "; plan first if >= 10 agents, improved by elements)" in line
    assert "tasks kept" not in line  # (no repair once a plan meets every requirement)
    assert "lazy rounds(direct, by elements before a first plan, repair in turn" in line
    assert "merge: prioritized or by elements before a first plan, in turn" in line
    off = describe(PlannerConfig().with_overrides({"repair.by_elements": None}))
    assert "by elements before" not in off
    direct = describe(PlannerConfig().with_overrides({"lazy.enabled": False}))
    assert "lazy" not in direct and "parts" not in direct
    quiet = describe(
        PlannerConfig().with_overrides(
            {
                "repair.crowd_agents": None,
                "parts.plan_first_agents": None,
            }
        )
    )
    assert "agents" not in quiet


@pytest.mark.heavy
def test_the_summary_records_the_configuration_and_strategy(tmp_path: Path) -> None:
    overrides = Overrides(time_limit=60, config={"repair.crowd_agents": 4})
    api.solve(PAIR, tmp_path / "out", overrides, animation=False)
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    mission = load_problem(PAIR).mission
    used = PlannerConfig.from_mission(mission, overrides.dotted())
    assert summary["config"] == json.loads(json.dumps(used.model_dump()))
    assert summary["config"]["repair"]["crowd_agents"] == 4
    assert summary["strategy"] == describe(used)


def test_the_configuration_loads_no_solver() -> None:
    code = "import sys, stlplan.planner.config; print('pyomo' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def _anchors(page: Path) -> set[str]:
    """GitHub's anchors of the headings of a Markdown page."""
    headings = [
        line.lstrip("#").strip() for line in page.read_text().splitlines() if line.startswith("#")
    ]
    return {re.sub(r"[^\w\- ]", "", h.lower()).replace(" ", "-") for h in headings}


def test_every_measured_default_points_at_its_measurement() -> None:
    cited = [re.search(r"Measured:\s*(\S+?)#(\S+?)\.?$", doc, re.S) for *_, doc in knob_docs()]
    links = [m.groups() for m in cited if m is not None]
    assert len(links) >= 10
    for page, anchor in links:
        assert anchor in _anchors(ROOT / page), f"{page}#{anchor}"


def test_the_planner_page_lists_every_knob() -> None:
    page = (ROOT / "docs" / "planner.md").read_text()
    missing = [name for name in PlannerConfig().dotted() if f"`{name}`" not in page]
    assert not missing


def test_the_knob_table_is_the_one_the_code_gives() -> None:
    # regenerate with: python -m tests.helpers.knob_table
    page = (ROOT / "docs" / "planner.md").read_text()
    assert knob_table.page_table(page) == knob_table.table()


def test_every_knob_acts_somewhere() -> None:
    acting = knob_table.readers()
    assert not [name for name in PlannerConfig().dotted() if not acting.get(name)]
    assert "planner/core/policy.py" in acting["repair.crowd_agents"]
    assert "planner/run/budget.py" in acting["budget.grace_share"]  # read through an alias
