"""The catalogue of broken missions: each file in tests/broken/ has ONE mistake and gets ONE message.

``_base.yaml`` is the valid mission every broken file is derived from; the table below says, for
each broken file, which error type it raises and fragments its message must contain (the field
path and the line where the mistake is, plus a phrase saying what was expected).
"""

from __future__ import annotations

import difflib
import re
from pathlib import Path

import pytest

from stlplan.errors import FormulaError, MissionError, StlplanError
from stlplan.mission.loader import load_problem
from tests.helpers.messages import NOISE
from tests.helpers.paths import BASE, BROKEN

# name -> (error type, fragments the message must contain)
CATALOGUE: dict[str, tuple[type[StlplanError], tuple[str, ...]]] = {
    "a_not_square": (MissionError, ("line 6,", "dynamics.di.A", "square")),
    "agent_name_pattern": (MissionError, ("line 12,", "agents[1].name", "letters, digits")),
    "b_ragged": (MissionError, ("line 7,", "dynamics.di.B[3]", "m = 2 entries", "found 1")),
    "b_rows": (MissionError, ("line 7,", "dynamics.di.B", "n = 4 rows", "found 3")),
    "bounds_pair": (MissionError, ("line 9,", "input_bounds[1]", "expected 2 values")),
    "component_out_of_range": (FormulaError, ("line 18,", "tasks.meet.formula", "p.x[7]")),
    "constraint_past_horizon": (
        FormulaError,
        ("line 23,", "constraints.avoid.formula", "up to 9", "horizon 8"),
    ),
    "constraint_role_unbound": (
        FormulaError,
        ("line 23,", "constraints.avoid.formula", "role 'r'", "bound roles: p"),
    ),
    "count_zero": (MissionError, ("line 19,", "tasks.meet.count", ">= 1", "found 0")),
    "duplicate_agent": (MissionError, ("line 12,", "agents[1].name", "duplicate agent name 'a1'")),
    "duplicate_key": (MissionError, ("line 16,", "regions.Goal", "duplicate key", "line 14")),
    "empty_box": (MissionError, ("line 15,", "regions.Obs.box", "empty box", "x interval")),
    "for_each_pinned": (MissionError, ("line 24,", "constraints.avoid.for_each", "both")),
    "formula_huge_number": (
        FormulaError,
        ("line 23,", "constraints.avoid.formula", "not finite"),
    ),
    "formula_past_horizon": (
        FormulaError,
        ("line 18,", "tasks.meet.formula", "up to 10", "horizon 8"),
    ),
    "formula_starts_with_bang": (MissionError, ("line 23,", "YAML", "must be quoted")),
    "formula_syntax": (
        FormulaError,
        ("line 23,", "constraints.avoid.formula", "column 14", "expected one of: ','", "^"),
    ),
    "initial_outside_bounds": (
        MissionError,
        ("line 12,", "agents[1].initial_state[1]", "4.5", "[0.0, 4.0]"),
    ),
    "initial_state_length": (
        MissionError,
        ("line 12,", "agents[1].initial_state", "2 values", "4 state components"),
    ),
    "input_bounds_length": (
        MissionError,
        ("line 9,", "dynamics.di.input_bounds", "expected 2 input bounds", "found 1"),
    ),
    "interval_inverted": (FormulaError, ("line 18,", "tasks.meet.formula", "[6,0]")),
    "inverted_bounds": (MissionError, ("line 9,", "input_bounds[1]", "[1.0, -1.0]")),
    "inverted_box": (MissionError, ("line 14,", "regions.Goal.box", "y interval [3.0, 1.0]")),
    "literal_effort": (MissionError, ("line 21,", "objective.effort", "'linf'", "found 'l3'")),
    "missing_field": (MissionError, ("line 11,", "agents[0]", "missing required field")),
    "negated_until": (FormulaError, ("line 18,", "tasks.meet.formula", "until")),
    "negative_horizon": (MissionError, ("line 3,", "horizon", ">= 1", "found -3")),
    "no_agent_has_all": (MissionError, ("line 20,", "tasks.meet.roles.p", "all of")),
    "non_finite_initial": (
        MissionError,
        ("line 11,", "agents[0].initial_state[1]", "finite", "found nan"),
    ),
    "non_finite_matrix": (MissionError, ("line 7,", "dynamics.di.B[2][0]", "found inf")),
    "pinned_role_key": (
        MissionError,
        ("line 20,", "tasks.meet.roles.p.agnet", "did you mean 'agent'"),
    ),
    "polytope_rows": (MissionError, ("line 15,", "regions.Obs.h", "3 rows", "2 entries")),
    "position_out_of_range": (
        MissionError,
        ("line 8,", "dynamics.di.position", "0..3", "[0, 4]"),
    ),
    "region_no_shape": (MissionError, ("line 15,", "regions.Obs", "'box'")),
    "role_bad_type": (
        MissionError,
        ("line 20,", "tasks.meet.roles.p", "capability name", "found 5"),
    ),
    "state_bounds_length": (
        MissionError,
        ("line 8,", "dynamics.di.state_bounds", "expected 4 state bounds"),
    ),
    "sweep_region": (
        MissionError,
        ("line 21,", "sweep.initial_region", "undefined region 'Start'"),
    ),
    "sync_past_horizon": (
        MissionError,
        ("line 21,", "tasks.meet.synchronous.within", "synchronous window", "= 9", "horizon 8"),
    ),
    "sync_window_inverted": (
        MissionError,
        ("line 21,", "tasks.meet.synchronous.within", "[5, 2]"),
    ),
    "too_few_agents": (
        MissionError,
        ("line 19,", "tasks.meet.count", "count 3", "only 2 element", "p: a1, a2"),
    ),
    "undefined_dynamics": (
        MissionError,
        ("line 12,", "agents[1].dynamics", "undefined dynamics 'dl'", "di"),
    ),
    "undefined_region": (
        FormulaError,
        ("line 18,", "tasks.meet.formula", "'Gaol'", "did you mean 'Goal'"),
    ),
    "undefined_role": (
        FormulaError,
        ("line 18,", "tasks.meet.formula", "role 'q'", "not declared"),
    ),
    "unknown_capability": (
        MissionError,
        ("line 20,", "tasks.meet.roles.p", "'gruond'", "did you mean 'ground'"),
    ),
    "unknown_constraint_agent": (
        MissionError,
        ("line 25,", "constraints.avoid.agents[1]", "undefined agent 'b2'"),
    ),
    "unknown_constraint_pinned": (
        MissionError,
        ("line 24,", "constraints.avoid.roles.p", "undefined agent 'ghost'"),
    ),
    "unknown_key": (MissionError, ("line 3, column 1", "horizn", "did you mean 'horizon'")),
    "unknown_nested_key": (
        MissionError,
        ("line 24,", "constraints.avoid.foreach", "did you mean 'for_each'"),
    ),
    "unknown_pinned_agent": (
        MissionError,
        ("line 20,", "tasks.meet.roles.p.agent", "undefined agent 'a3'"),
    ),
    "unused_role": (MissionError, ("line 20,", "tasks.meet.roles.q", "not used")),
    "wrong_type": (MissionError, ("line 3,", "horizon", "expected an integer", "'eight'")),
    "yaml_syntax": (MissionError, ("line 16,", "YAML syntax error", "line 15")),
    # refused, never reinterpreted
    "octal_horizon": (MissionError, ("line 3,", "leading zero", "octal", "such as 10")),
    "separation_yes": (MissionError, ("line 25,", "separation", "expected a number", "'yes'")),
    "quoted_number": (
        MissionError,
        ("line 25,", "objective.beta", "expected a number", "'0.01'", "without quotes"),
    ),
    "null_value": (MissionError, ("line 25,", "separation", "found nothing (null)")),
    "dist_same_role": (
        FormulaError,
        ("line 18,", "tasks.meet.formula", "dist(p, p)", "two different roles"),
    ),
    "empty_polytope_region": (
        MissionError,
        ("line 15,", "regions.Obs.G", "empty polytope", "-1 x + 0 y <= -3"),
    ),
    "gap_too_large": (MissionError, ("line 25,", "solver.gap", "< 1", "found 2")),
    "gamma_negative": (MissionError, ("line 25,", "objective.gamma", ">= 0", "found -1")),
    "seed_too_large": (MissionError, ("line 25,", "solver.seed", "2147483647", "4294967296")),
    "constraint_no_agents": (
        MissionError,
        ("line 25,", "constraints.avoid.agents", "at least 1", "found []"),
    ),
    "role_rule_empty": (MissionError, ("line 20,", "tasks.meet.roles.p", "at least 1", "[]")),
    "task_constraint_same_name": (
        MissionError,
        ("line 23,", "constraints.meet", "both a task and a constraint"),
    ),
    "task_named_separation": (MissionError, ("line 18,", "tasks.separation", "another name")),
    "numeric_task_name": (MissionError, ("line 17,", "tasks.1", "as a number", "quote it")),
    "boolean_region_name": (
        MissionError,
        ("line 15,", "regions.true", "as a boolean", "quote it"),
    ),
    "disturbance_negative": (
        MissionError,
        ("line 25,", "execution.disturbance", "expected a value >= 0", "-0.1"),
    ),
    "separation_negative": (MissionError, ("line 25,", "separation", "expected a value >= 0")),
    "threads_too_many": (MissionError, ("line 25,", "solver.threads", "<= 256", "100000")),
    "region_name_with_space": (
        MissionError,
        ("line 15,", "regions.O bs", "a name a formula can use", "found 'O bs'"),
    ),
    "null_task_name": (MissionError, ("line 16,", "tasks", "a key YAML reads as null")),
    "beta_huge": (MissionError, ("line 25,", "objective.beta", "between -1e6 and 1e6")),
    "bounds_huge": (
        MissionError,
        ("line 8,", "dynamics.di.state_bounds[0][1]", "between -1e6 and 1e6", "6000000000"),
    ),
    "swapped_in_args": (
        FormulaError,
        ("line 18,", "tasks.meet.formula", "in(Goal, p) has its arguments swapped", "in(p, Goal)"),
    ),
    "count_above_team": (
        FormulaError,
        ("line 18,", "tasks.meet.formula", "can never hold", "1 agent(s) with lidar", "1 to 1"),
    ),
    "count_unknown_capability": (
        FormulaError,
        ("line 18,", "tasks.meet.formula", "'lidarr'", "did you mean 'lidar'"),
    ),
    "count_fraction": (
        FormulaError,
        ("line 18,", "tasks.meet.formula", "whole number", "found 1.5"),
    ),
    "count_negative": (FormulaError, ("line 18,", "tasks.meet.formula", "whole number", "-1")),
    "count_always_holds": (
        FormulaError,
        ("line 18,", "tasks.meet.formula", "count(Obs) <= 2", "always holds", "below 2"),
    ),
    "visits_beyond_reach": (
        FormulaError,
        ("line 18,", "tasks.meet.formula", "enter at most 4 times", "from 1 to 4"),
    ),
    "roles_pinned_same_agent": (
        MissionError,
        ("line 20,", "tasks.meet.roles.q", "both pinned to agent 'a1'"),
    ),
    "homoglyph_region": (
        FormulaError,
        ("line 18,", "tasks.meet.formula", "U+043E CYRILLIC SMALL LETTER O", "in ASCII"),
    ),
    "formula_huge_coefficient": (
        FormulaError,
        ("line 23,", "constraints.avoid.formula", "magnitude above 1e6"),
    ),
}


def _message(path: Path) -> StlplanError:
    with pytest.raises(StlplanError) as caught:
        load_problem(path)
    return caught.value


def test_base_mission_loads() -> None:
    problem = load_problem(BASE)
    assert [a.name for a in problem.agents] == ["a1", "a2"]


def test_catalogue_matches_the_folder() -> None:
    files = {p.stem for p in BROKEN.glob("*.yaml") if not p.stem.startswith("_")}
    assert files == set(CATALOGUE)
    assert len(files) >= 20


@pytest.mark.parametrize("name", sorted(CATALOGUE))
def test_each_file_has_one_mistake(name: str) -> None:
    base = BASE.read_text(encoding="utf-8").splitlines()[1:]
    broken = (BROKEN / f"{name}.yaml").read_text(encoding="utf-8").splitlines()[1:]
    changed = [d for d in difflib.ndiff(base, broken) if d[:1] in "+-"]
    assert 1 <= len(changed) <= 2, changed


@pytest.mark.parametrize("name", sorted(CATALOGUE))
def test_broken_mission_gets_one_clear_message(name: str) -> None:
    kind, fragments = CATALOGUE[name]
    path = BROKEN / f"{name}.yaml"
    error = _message(path)
    text = str(error)
    assert type(error) is kind, text
    assert text.startswith(str(path)), text
    for fragment in fragments:
        assert fragment in text, f"{fragment!r} not in {text!r}"
    assert not any(noise in text for noise in NOISE), text
    assert "\n  line " not in error.message, f"more than one message: {text}"


@pytest.mark.parametrize("name", sorted(CATALOGUE))
def test_line_number_points_at_the_mistake(name: str) -> None:
    """The reported line is one the mistake changed (or, for a missing value, its mapping)."""
    error = _message(BROKEN / f"{name}.yaml")
    match = re.search(r"line (\d+), column \d+", error.where or error.message)
    assert match is not None, str(error)
    base = BASE.read_text(encoding="utf-8").splitlines()
    broken = (BROKEN / f"{name}.yaml").read_text(encoding="utf-8").splitlines()
    line = int(match.group(1))
    near = {line - 1, line, line + 1}  # YAML reports a syntax error on the line after the cause
    changed = {i + 1 for i, text in enumerate(broken) if i == 0 or text not in base}
    assert near & changed, (line, sorted(changed))


def _variants(text: str) -> list[str]:
    lines = text.splitlines(keepends=True)
    out = ["".join(lines[:i] + lines[i + 1 :]) for i in range(1, len(lines))]
    for match in re.finditer(r"(?<![\w.])-?\d+(\.\d+)?(?![\w.])", text):
        for replacement in ("-7", "x", "1e999", "0"):
            out.append(text[: match.start()] + replacement + text[match.end() :])
    return out


@pytest.mark.heavy
def test_mutations_of_the_base_never_raise_a_bare_exception(tmp_path: Path) -> None:
    """Delete any one line, or replace any number: the result loads or raises StlplanError."""
    target = tmp_path / "mutant.yaml"
    failures = 0
    for variant in _variants(BASE.read_text(encoding="utf-8")):
        target.write_text(variant, encoding="utf-8")
        try:
            load_problem(target)
        except StlplanError as error:
            failures += 1
            assert str(error).startswith(str(target))
            assert not any(noise in str(error) for noise in NOISE), str(error)
    assert failures > 0


def test_a_look_alike_name_is_shown_by_code_point_not_suggested() -> None:
    from stlplan.errors import did_you_mean

    zero_width = did_you_mean("Goal", ["Goal\u200b", "Obs"])
    assert "U+200B ZERO WIDTH SPACE at position 5" in zero_width
    assert "did you mean" not in zero_width
    cyrillic = did_you_mean("Goal", ["G\u043eal"])
    assert "U+043E CYRILLIC SMALL LETTER O at position 2" in cyrillic
    assert did_you_mean("Gaol", ["Goal"]) == " (did you mean 'Goal'?)"
