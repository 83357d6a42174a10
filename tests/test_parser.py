"""The formula parser: known parses, precedence, negation normal form, errors, round trip."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stlplan.errors import FormulaError
from stlplan.formula.parser import RESERVED, parse, to_text
from stlplan.formula.tree import (
    Always,
    And,
    Distance,
    Eventually,
    Formula,
    InRegion,
    Interval,
    Linear,
    Not,
    Or,
    Term,
    Until,
)

A, B, C = InRegion("p", "A"), InRegion("p", "B"), InRegion("p", "C")


@pytest.mark.parametrize(
    ("text", "tree"),
    [
        # precedence: the unary temporal operators bind tighter than '&'
        (
            "F[0,2] in(p, A) & F[7,9] in(p, B)",
            And((Eventually(Interval(0, 2), A), Eventually(Interval(7, 9), B))),
        ),
        ("in(p, A) & in(p, B) | in(p, C)", Or((And((A, B)), C))),
        ("in(p, A) | in(p, B) & in(p, C)", Or((A, And((B, C))))),
        ("in(p, A) & in(p, B) & in(p, C)", And((A, B, C))),
        ("(in(p, A) & in(p, B)) & in(p, C)", And((And((A, B)), C))),
        ("G[0,3] (in(p, A) | in(p, B))", Always(Interval(0, 3), Or((A, B)))),
        ("G[0,3] in(p, A) | in(p, B)", Or((Always(Interval(0, 3), A), B))),
        # until: looser than G/F/!, tighter than '&'
        ("in(p, A) U[1,4] in(p, B)", Until(Interval(1, 4), A, B)),
        ("in(p, A) U*[1,4] in(p, B)", Until(Interval(1, 4), A, B, strict=True)),
        # RTAMT's spellings; its until is the strict one; implication is !a | b, pushed down
        ("eventually[0:4] in(p, A)", Eventually(Interval(0, 4), A)),
        ("always[1,2] not in(p, A)", Always(Interval(1, 2), Not(A))),
        ("in(p, A) and in(p, B) or in(p, C)", Or((And((A, B)), C))),
        ("in(p, A) until[0:3] in(p, B)", Until(Interval(0, 3), A, B, strict=True)),
        ("in(p, A) -> in(p, B)", Or((Not(A), B))),
        ("in(p, A) & in(p, B) implies in(p, C)", Or((Or((Not(A), Not(B))), C))),
        ("in(p, A) U* [0,2] in(p, B) | in(p, C)", Or((Until(Interval(0, 2), A, B, True), C))),
        ("in(p, A) U[0,2] in(p, B) & in(p, C)", And((Until(Interval(0, 2), A, B), C))),
        ("G[0,1] in(p, A) U[0,2] in(p, B)", Until(Interval(0, 2), Always(Interval(0, 1), A), B)),
        # negation is pushed to the atoms
        ("!in(p, A)", Not(A)),
        ("!!in(p, A)", A),
        ("!(in(p, A) & in(p, B))", Or((Not(A), Not(B)))),
        ("!(in(p, A) | !in(p, B))", And((Not(A), B))),
        ("!G[0,3] in(p, A)", Eventually(Interval(0, 3), Not(A))),
        ("!F[1,2] G[0,3] in(p, A)", Always(Interval(1, 2), Eventually(Interval(0, 3), Not(A)))),
        # atoms
        ("dist(p, q) <= 0.25", Distance("p", "q", "<=", 0.25)),
        ("dist(p, q) >= 1", Distance("p", "q", ">=", 1.0)),
        (
            "2*p.x[0] - q.x[1] >= -3",
            Linear((Term(2.0, "p", 0), Term(-1.0, "q", 1)), ">=", -3.0),
        ),
        ("-p.x[2] <= 1.5e-1", Linear((Term(-1.0, "p", 2),), "<=", 0.15)),
        ("!(p.x[0] <= 1)", Not(Linear((Term(1.0, "p", 0),), "<=", 1.0))),
        ("in(p,\n   A)", A),
    ],
)
def test_known_parse(text: str, tree: Formula) -> None:
    assert parse(text) == tree


def test_farm_crop_b_formula_is_a_conjunction_of_three() -> None:
    text = (
        "F[0,2] (in(p, B_start) & in(q, B_start)) & F[7,9] (in(p, B_end) & in(q, B_end))"
        " & G[2,7] (in(p, B) & in(q, B) & dist(p, q) <= 0.25)"
    )
    tree = parse(text)
    assert isinstance(tree, And)
    assert [type(c) for c in tree.children] == [Eventually, Eventually, Always]


@pytest.mark.parametrize(
    ("text", "line", "column"),
    [
        ("F[0,2 in(p, A)", 1, 7),
        ("in(p A)", 1, 6),
        ("in(p, A) &", 1, 11),
        ("in(p, A) &\n  in(p B)", 2, 8),
        ("in(p, A) U[0,1] in(p, B) U[0,1] in(p, C)", 1, 26),
        ("G in(p, A)", 1, 3),
        ("in(p, A) $ in(p, B)", 1, 10),
    ],
)
def test_syntax_error_has_line_column_and_caret(text: str, line: int, column: int) -> None:
    with pytest.raises(FormulaError) as caught:
        parse(text, source="m.yaml", where="tasks.t.formula")
    error = caught.value
    assert f"line {line}, column {column}" in error.message
    assert error.source == "m.yaml" and error.where == "tasks.t.formula"
    shown, caret = error.message.splitlines()[-2:]
    assert shown.strip() == text.splitlines()[line - 1].strip()
    # the caret sits under the offending column of the echoed line (both indented by 2)
    assert caret == " " * (column + 1) + "^"
    assert shown[2:] == text.splitlines()[line - 1]


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        ("!(in(p, A) U[0,2] in(p, B))", "until"),
        ("!(in(p, A) U*[0,2] in(p, B))", "until"),
        ("F[3,1] in(p, A)", "[3,1]"),
        ("dist(p, q) <= -1", ">= 0"),
        ("in(x, A)", "reserved"),
        # other tools' spellings are refused with stlplan's
        ("next in(p, A)", "F[1,1] phi"),
        ("X[0,12] in(p, A)", "if X means 'next'"),
        ("historically[0:2] in(p, A)", "past-time"),
        ("p.x[0] > 1", "'<=' or '>='"),
        ("in(p, A) xor in(p, B)", "(a & !b) | (!a & b)"),
        ("always in(p, A)", "always[a,b]"),
    ],
)
def test_semantic_formula_errors(text: str, fragment: str) -> None:
    with pytest.raises(FormulaError) as caught:
        parse(text)
    assert fragment in caught.value.message


# --- round trip: parse(to_text(t)) == t for random trees in negation normal form -------------

NAMES = st.from_regex(r"[A-Za-z_][A-Za-z0-9_]{0,4}", fullmatch=True).filter(
    lambda n: n not in RESERVED
)
NUMBERS = st.one_of(
    st.integers(-50, 50).map(float),
    st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False),
)
INTERVALS = st.tuples(st.integers(0, 12), st.integers(0, 6)).map(
    lambda t: Interval(t[0], t[0] + t[1])
)
TERMS = st.builds(Term, NUMBERS, NAMES, st.integers(0, 5))
COMPARISONS = st.sampled_from(["<=", ">="])
ATOMS = st.one_of(
    st.builds(InRegion, NAMES, NAMES),
    st.builds(Distance, NAMES, NAMES, COMPARISONS, NUMBERS.map(abs)),
    st.builds(Linear, st.lists(TERMS, min_size=1, max_size=3).map(tuple), COMPARISONS, NUMBERS),
)
LITERALS = st.one_of(ATOMS, ATOMS.map(Not))


def _compound(inner: st.SearchStrategy[Formula]) -> st.SearchStrategy[Formula]:
    children = st.lists(inner, min_size=2, max_size=3).map(tuple)
    return st.one_of(
        children.map(And),
        children.map(Or),
        st.builds(Always, INTERVALS, inner),
        st.builds(Eventually, INTERVALS, inner),
        st.builds(Until, INTERVALS, inner, inner, st.booleans()),
    )


FORMULAS = st.recursive(LITERALS, _compound, max_leaves=10)


@pytest.mark.heavy
@settings(max_examples=300, deadline=None)
@given(FORMULAS)
def test_round_trip(tree: Formula) -> None:
    text = to_text(tree)
    assert parse(text) == tree, text
