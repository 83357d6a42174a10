"""Fuzzing the two text inputs of stlplan: formula strings and mission documents (Hypothesis).

The only allowed outcomes are a result or a :class:`StlplanError` with a message a user can act
on; any other exception is a bug. The normal suite runs ``FUZZ_EXAMPLES`` examples per test
(150, a few seconds in all); ``STLPLAN_FUZZ_EXAMPLES=5000`` (``make fuzz``) runs a longer
campaign.

* Formulas: token soups from the grammar's tokens, and valid formulas mutated by inserting,
  deleting or replacing characters. ``parse`` returns a tree or raises :class:`FormulaError`,
  whose syntax errors name a line and a column; a tree with finite numbers prints back to text
  that parses to the same tree.
* Missions: a small valid mission (modelled on ``missions/sync-pair.yaml``, horizon 4) mutated by
  dropping keys, changing types, putting NaN/inf/negative/huge numbers, renaming region
  references, emptying lists and nesting values deeply, then dumped to YAML (and, in one test,
  mutated again as text). ``problem_from_text`` returns a Problem or raises
  :class:`StlplanError`; an accepted Problem must also go through the monitor and the trajectory
  CSV round trip without a crash.
"""

from __future__ import annotations

import copy
import math
import os
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from stlplan.errors import FormulaError, StlplanError
from stlplan.formula.parser import parse, to_text
from stlplan.formula.tree import Distance, Formula, Linear, atoms
from stlplan.mission.loader import problem_from_text
from stlplan.mission.problem import Problem
from stlplan.monitor.verdicts import check
from stlplan.outputs.trajio import write_trajectory_csv
from stlplan.outputs.trajread import read_trajectory_csv
from stlplan.result import MonitorReport, Trajectory
from tests.helpers.messages import NOISE

FUZZ_EXAMPLES = int(os.environ.get("STLPLAN_FUZZ_EXAMPLES", "150"))
FUZZ = settings(
    max_examples=FUZZ_EXAMPLES,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
SOURCE = "fuzz.yaml"

# --- formulas ----------------------------------------------------------------------------------

TOKENS = (
    "G", "F", "U", "in", "dist", "x", "(", ")", "[", "]", ",", ".", "*", "+", "-", "!", "&", "|",
    "<=", ">=", "<", "=", "0", "1", "7", "12", "0.5", ".5", "1e3", "1e999", "2.", "p", "q",
    "Goal", "A_1", " ", "\n", "\t", "#", "é", "\x00", "99999999999999999999",
)  # fmt: skip
ROLES = st.sampled_from(["p", "q", "r"])
REGIONS = st.sampled_from(["Goal", "Obstacle", "Start"])
STEPS = st.integers(0, 12)
NUMBERS = st.one_of(
    st.integers(-50, 50).map(str),
    st.floats(-1e3, 1e3, allow_nan=False).map(repr),
    st.sampled_from(["0.5", ".25", "1e-3", "2E2", "1e999"]),
)


@st.composite
def intervals(draw: st.DrawFn) -> str:
    lo = draw(STEPS)
    return f"[{lo},{lo + draw(STEPS)}]"


def _atom_texts() -> st.SearchStrategy[str]:
    term = st.builds(
        lambda c, r, i: f"{c}{r}.x[{i}]",
        st.sampled_from(["", "2*", "0.5*", "1e3*"]),
        ROLES,
        st.integers(0, 5),
    )
    linear = st.builds(
        lambda ts, signs, op, b: (
            "".join(
                f" {s} {t}" if k else t for k, (t, s) in enumerate(zip(ts, signs, strict=False))
            )
            + f" {op} {b}"
        ),
        st.lists(term, min_size=1, max_size=3),
        st.lists(st.sampled_from("+-"), min_size=3, max_size=3),
        st.sampled_from(["<=", ">="]),
        NUMBERS,
    )
    return st.one_of(
        st.builds(lambda r, g: f"in({r}, {g})", ROLES, REGIONS),
        st.builds(
            lambda a, b, op, n: f"dist({a}, {b}) {op} {n}",
            ROLES,
            ROLES,
            st.sampled_from(["<=", ">="]),
            NUMBERS,
        ),
        linear,
    )


def _extend(inner: st.SearchStrategy[str]) -> st.SearchStrategy[str]:
    return st.one_of(
        st.builds(lambda i, f: f"G{i} {f}", intervals(), inner),
        st.builds(lambda i, f: f"F{i} {f}", intervals(), inner),
        st.builds(lambda f: f"!({f})", inner),
        st.builds(lambda f, g: f"({f} & {g})", inner, inner),
        st.builds(lambda f, g: f"({f} | {g})", inner, inner),
        st.builds(lambda f, i, g: f"({f} U{i} {g})", inner, intervals(), inner),
    )


VALID_FORMULAS = st.recursive(_atom_texts(), _extend, max_leaves=8)
TOKEN_SOUPS = st.lists(st.sampled_from(TOKENS), max_size=30).flatmap(
    lambda tokens: st.sampled_from([" ".join(tokens), "".join(tokens)])
)


@st.composite
def mutated(draw: st.DrawFn, texts: st.SearchStrategy[str]) -> str:
    """``texts`` with a few characters inserted, deleted or replaced."""
    chars = list(draw(texts))
    alphabet = st.one_of(st.sampled_from("()[],.*+-!&|<>=GFUx0123456789pq \n"), st.characters())
    for _ in range(draw(st.integers(1, 4))):
        at = draw(st.integers(0, len(chars)))
        edit = draw(st.sampled_from(["insert", "delete", "replace"]))
        if edit == "insert":
            chars.insert(at, draw(alphabet))
        elif chars:
            at = min(at, len(chars) - 1)
            if edit == "delete":
                del chars[at]
            else:
                chars[at] = draw(alphabet)
    return "".join(chars)


def _finite(formula: Formula) -> bool:
    numbers: list[float] = []
    for atom in atoms(formula):
        if isinstance(atom, Distance):
            numbers.append(atom.radius)
        elif isinstance(atom, Linear):
            numbers += [atom.bound, *(t.coef for t in atom.terms)]
    return all(math.isfinite(v) for v in numbers)


def _parse_or_error(text: str) -> Formula | None:
    """The property: a tree (that prints back to itself) or a FormulaError, nothing else."""
    try:
        tree = parse(text)
    except FormulaError as error:
        message = str(error)
        assert message.strip(), repr(text)
        if "syntax error" in message:
            assert re.search(r"line \d+, column \d+", message), message
        return None
    if _finite(tree):
        assert parse(to_text(tree)) == tree, (text, to_text(tree))
    return tree


@FUZZ
@given(TOKEN_SOUPS)
def test_token_soup_parses_or_raises_formula_error(text: str) -> None:
    _parse_or_error(text)


@FUZZ
@given(mutated(VALID_FORMULAS))
def test_mutated_formula_parses_or_raises_formula_error(text: str) -> None:
    _parse_or_error(text)


@FUZZ
@given(VALID_FORMULAS)
def test_generated_formulas_parse(text: str) -> None:
    """The generator itself is sound: unmutated formulas parse (or fail only on meaning)."""
    try:
        parse(text)
    except FormulaError as error:
        assert "syntax error" not in str(error), (text, str(error))


def test_deep_formulas_are_refused_cleanly() -> None:
    for text in ("!" * 5000 + "in(p, A)", "G[0,1] " * 2000 + "in(p, A)", "(" * 5000 + "in(p, A)"):
        try:
            parse(text)
        except FormulaError as error:
            assert "line 1, column" in str(error)
        else:  # pragma: no cover - the property is that it never gets here
            raise AssertionError("a 2000-level formula was accepted")


# --- mission documents ----------------------------------------------------------------------


def base_mission() -> dict[str, Any]:
    """A small valid mission like ``missions/sync-pair.yaml``, with horizon 4."""
    return {
        "name": "fuzz",
        "horizon": 4,
        "dynamics": {
            "double_integrator": {
                "A": [[1, 0, 1, 0], [0, 1, 0, 1], [0, 0, 1, 0], [0, 0, 0, 1]],
                "B": [[0.5, 0], [0, 0.5], [1, 0], [0, 1]],
                "position": [0, 1],
                "state_bounds": [[0, 6], [0, 4], [-1.5, 1.5], [-1.5, 1.5]],
                "input_bounds": [[-1, 1], [-1, 1]],
            }
        },
        "agents": [
            {"name": "south", "dynamics": "double_integrator", "capabilities": ["ground"],
             "initial_state": [0.5, 0.5, 0, 0]},
            {"name": "north", "dynamics": "double_integrator", "capabilities": ["ground"],
             "initial_state": [0.5, 3.5, 0, 0]},
        ],
        "regions": {
            "Goal": {"box": [[4, 5.5], [1.25, 2.75]]},
            "Obstacle": {"G": [[1, 0], [-1, 0], [0, 1], [0, -1]], "h": [3, -2, 2.75, -1.25]},
            "Start": {"box": [[0, 1], [0, 4]]},
        },
        "tasks": {
            "meet": {"formula": "in(p, Goal)", "count": 2, "roles": {"p": "ground"},
                     "synchronous": {"within": [1, 2], "hold": 1}},
            "leave": {"formula": "F[0,3] !in(p, Start) & dist(p, q) >= 0.2",
                      "roles": {"p": "ground", "q": {"agent": "north"}}},
        },
        "constraints": {
            "avoid_obstacle": {"formula": "G[0,4] !in(p, Obstacle)", "for_each": "p"},
            "stay_low": {"formula": "G[0,4] p.x[1] <= 4", "roles": {"p": "south"}},
        },
        "separation": 0.1,
        "objective": {"beta": 0.01, "gamma": 4, "effort": "l1", "two_step": True},
        "solver": {"time_limit": 60},
        "sweep": {"initial_region": "Start"},
    }  # fmt: skip


Path_ = tuple[Any, ...]
SPECIAL_NUMBERS = [
    math.nan,
    math.inf,
    -math.inf,
    -1,
    -7.5,
    0,
    10**30,
    -(10**30),
    2**64,
    1e308,
    5e-324,
]
NAMES = [
    "",
    "Goal",
    "Gaol",
    "Start",
    "south",
    "ghost",
    "ground",
    "p",
    "q",
    "double_integrator",
    "G[0,9] in(p, Goal)",
]
DEEP = "__deep_{}__"
SCALARS = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(),
    st.floats(),
    st.sampled_from(SPECIAL_NUMBERS),
    st.sampled_from(NAMES),
    st.text(max_size=8),
)
VALUES = st.recursive(
    SCALARS,
    lambda inner: st.one_of(
        st.lists(inner, max_size=4),
        st.dictionaries(st.sampled_from(NAMES + ["box", "agent"]), inner, max_size=3),
    ),
    max_leaves=6,
)


def _paths(doc: Any, path: Path_ = ()) -> Iterator[Path_]:
    if path:
        yield path
    items = (
        doc.items() if isinstance(doc, dict) else enumerate(doc) if isinstance(doc, list) else ()
    )
    for key, value in items:
        yield from _paths(value, (*path, key))


def _at(doc: Any, path: Path_) -> Any:
    for key in path:
        doc = doc[key]
    return doc


def _rename_region(value: Any, old: str, new: str) -> Any:
    if isinstance(value, str):
        return re.sub(rf"\b{old}\b", new, value)
    if isinstance(value, list):
        return [_rename_region(v, old, new) for v in value]
    if isinstance(value, dict):
        return {k: _rename_region(v, old, new) for k, v in value.items()}
    return value


def _mutate_once(draw: st.DrawFn, doc: dict[str, Any]) -> dict[str, Any]:
    paths = list(_paths(doc))
    if not paths:
        return doc
    path = draw(st.sampled_from(paths))
    parent, key = _at(doc, path[:-1]), path[-1]
    value = parent[key]
    kind = draw(st.sampled_from(["drop", "type", "number", "rename", "empty", "deep", "deep_text"]))
    if kind == "drop":
        del parent[key]
    elif kind == "type":
        parent[key] = draw(VALUES)
    elif kind == "number":
        base = value if isinstance(value, (int, float)) and not isinstance(value, bool) else 1
        parent[key] = draw(
            st.sampled_from([*SPECIAL_NUMBERS, -base, base * 1e300, base + 0.5, str(base)])
        )
    elif kind == "rename":
        old, new = (
            draw(st.sampled_from(["Goal", "Obstacle", "Start"])),
            draw(st.sampled_from(NAMES)),
        )
        doc = _rename_region(doc, old, new)  # the references, in formulas and sweep
        regions = doc.get("regions")
        if draw(st.booleans()) and isinstance(regions, dict) and old in regions:
            regions[new] = regions.pop(old)  # and the definition too
    elif kind == "empty":
        parent[key] = draw(st.sampled_from([[], {}, "", [[]]]))
    elif kind == "deep":
        for _ in range(draw(st.integers(1, 40))):
            value = draw(st.sampled_from([[value], {"k": value}]))
        parent[key] = value
    else:  # nested deeper than yaml.safe_dump could write: spliced into the text later
        parent[key] = DEEP.format(draw(st.integers(1, 3000)))
    return doc


@st.composite
def mission_texts(draw: st.DrawFn) -> str:
    """A mutated copy of :func:`base_mission`, as YAML text."""
    doc = copy.deepcopy(base_mission())
    for _ in range(draw(st.integers(1, 3))):
        doc = _mutate_once(draw, doc)
    text = yaml.safe_dump(doc, sort_keys=False, allow_unicode=True, width=10_000)
    return re.sub(
        r"__deep_(\d+)__", lambda m: "[" * int(m.group(1)) + "1" + "]" * int(m.group(1)), text
    )


def _still_trajectory(problem: Problem) -> Trajectory:
    H = problem.horizon
    states = {
        a.name: np.tile(np.asarray(a.initial_state, float), (H + 1, 1)) for a in problem.agents
    }
    return Trajectory(H, states, {a.name: np.zeros((H, a.m)) for a in problem.agents})


def _load_or_error(text: str, tmp: Path) -> Problem | None:
    """The property: a Problem (that the monitor and the CSV round trip accept) or an error."""
    try:
        problem = problem_from_text(text, SOURCE)
    except StlplanError as error:
        message = str(error)
        assert message.startswith(SOURCE), message
        assert not any(noise in message for noise in NOISE), message
        return None
    trajectory = _still_trajectory(problem)
    assert isinstance(check(problem, trajectory), MonitorReport)
    write_trajectory_csv(problem, trajectory, tmp / "still.csv")
    assert isinstance(
        check(problem, read_trajectory_csv(problem, tmp / "still.csv")), MonitorReport
    )
    return problem


def test_the_base_mission_loads(tmp_path: Path) -> None:
    problem = _load_or_error(yaml.safe_dump(base_mission()), tmp_path)
    assert problem is not None and problem.horizon == 4
    assert [len(t.groups) for t in problem.tasks] == [1, 1]


@pytest.mark.heavy
@FUZZ
@given(mission_texts())
def test_mutated_mission_loads_or_raises_stlplan_error(tmp_path_factory: Any, text: str) -> None:
    _load_or_error(text, tmp_path_factory.mktemp("fuzz"))


@pytest.mark.heavy
@FUZZ
@given(mutated(mission_texts()))
def test_mutated_mission_text_loads_or_raises_stlplan_error(
    tmp_path_factory: Any, text: str
) -> None:
    _load_or_error(text, tmp_path_factory.mktemp("fuzz"))


def test_the_mutations_reach_every_kind_of_outcome(tmp_path: Path) -> None:
    """The generator is not vacuous: some mutants load, others fail in the schema and checks."""
    outcomes: set[str] = set()

    @settings(
        max_examples=60, deadline=None, database=None, suppress_health_check=list(HealthCheck)
    )
    @given(mission_texts())
    def sample(text: str) -> None:
        try:
            problem_from_text(text, SOURCE)
            outcomes.add("loaded")
        except StlplanError as error:
            outcomes.add(type(error).__name__)

    sample()
    assert {"loaded", "MissionError"} <= outcomes, outcomes
