"""Robustness of lowered formulas: known answers and a brute-force oracle over every step."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from stlplan.errors import FormulaError
from stlplan.formula.tree import (
    Always,
    And,
    Eventually,
    Formula,
    InRegion,
    Interval,
    Or,
    Predicate,
    Term,
    Until,
    horizon,
)
from stlplan.monitor.robustness import robustness


def above(bound: float, role: str = "p", component: int = 0) -> Predicate:
    """``x_role[component] - bound >= 0``."""
    return Predicate((Term(1.0, role, component),), bound)


def below(bound: float, role: str = "p", component: int = 0) -> Predicate:
    """``-x_role[component] + bound >= 0``."""
    return Predicate((Term(-1.0, role, component),), -bound)


def signal(values: list[float]) -> dict[str, np.ndarray]:
    return {"p": np.array(values, dtype=float)[:, None]}


X = signal([0.0, 1.0, 3.0, 2.0, 5.0, 4.0])  # H = 5


def test_predicate_is_alpha_at_every_step() -> None:
    assert robustness(above(2.0), X, 5).tolist() == [-2.0, -1.0, 1.0, 0.0, 3.0, 2.0]


def test_predicate_over_two_roles() -> None:
    # 2 x_p[1] - x_q[0] - 1 >= 0
    signals = {"p": np.array([[0, 1], [0, 3]], float), "q": np.array([[1, 0], [4, 0]], float)}
    pred = Predicate((Term(2.0, "p", 1), Term(-1.0, "q", 0)), 1.0)
    assert robustness(pred, signals, 1).tolist() == [0.0, 1.0]


def test_and_or_are_min_max() -> None:
    band = And((above(1.0), below(4.0)))
    assert robustness(band, X, 5).tolist() == [-1.0, 0.0, 1.0, 1.0, -1.0, 0.0]
    outside = Or((below(1.0), above(4.0)))
    assert robustness(outside, X, 5).tolist() == [1.0, 0.0, -1.0, -1.0, 1.0, 0.0]


def test_always_and_eventually_windows() -> None:
    # x - 2: -2, -1, 1, 0, 3, 2
    assert robustness(Always(Interval(1, 2), above(2.0)), X, 5).tolist() == [-1.0, 0.0, 0.0, 2.0]
    assert robustness(Eventually(Interval(0, 3), above(2.0)), X, 5).tolist() == [1.0, 3.0, 3.0]


def test_length_follows_the_horizon_of_each_child() -> None:
    # the conjunction is defined where both children are: k + 3 <= 5
    f = And((above(0.0), Always(Interval(0, 3), above(-1.0))))
    assert len(robustness(f, X, 5)) == 3
    assert len(robustness(Always(Interval(0, 6), above(0.0)), X, 5)) == 0


def test_until_includes_both_ends() -> None:
    # left x <= 3.5: 3.5, 2.5, 0.5, 1.5, -1.5, -0.5; right x >= 4.5: -4.5, -3.5, -1.5, -2.5, 0.5, -0.5
    f = Until(Interval(1, 4), below(3.5), above(4.5))
    # k = 0: right holds only at k' = 4, where left is -1.5, so the best is max over k' of
    # min(right(k'), min left[0..k']): k'=1 -3.5, k'=2 -1.5, k'=3 -2.5, k'=4 -1.5
    assert robustness(f, X, 5).tolist() == [-1.5, -1.5]


def test_until_with_zero_lower_bound() -> None:
    f = Until(Interval(0, 1), above(-10.0), above(2.5))
    # right x - 2.5: -2.5, -1.5, 0.5, -0.5, 2.5, 1.5; left is 10 + x (always positive)
    assert robustness(f, X, 5).tolist() == [-1.5, 0.5, 0.5, 2.5, 2.5]


def test_unlowered_nodes_are_rejected() -> None:
    with pytest.raises(FormulaError, match="InRegion"):
        robustness(InRegion("p", "R"), X, 5)


# --- property: every step against a brute-force evaluator ------------------------------------


def brute(f: Formula, x: dict[str, np.ndarray], k: int) -> float:
    """Robustness at ``k`` straight from the definitions, with plain loops."""
    if isinstance(f, Predicate):
        return sum(t.coef * float(x[t.role][k][t.component]) for t in f.terms) - f.bound
    if isinstance(f, And):
        return min(brute(c, x, k) for c in f.children)
    if isinstance(f, Or):
        return max(brute(c, x, k) for c in f.children)
    if isinstance(f, Always):
        return min(brute(f.child, x, j) for j in range(k + f.interval.lo, k + f.interval.hi + 1))
    if isinstance(f, Eventually):
        return max(brute(f.child, x, j) for j in range(k + f.interval.lo, k + f.interval.hi + 1))
    assert isinstance(f, Until)
    best = -float("inf")
    for j in range(k + f.interval.lo, k + f.interval.hi + 1):
        left = min(brute(f.left, x, i) for i in range(k, j + 1))
        best = max(best, min(brute(f.right, x, j), left))
    return best


def lowered_formulas() -> st.SearchStrategy[Formula]:
    term = st.builds(
        Term,
        st.sampled_from([-1.5, -1.0, 1.0, 2.0]),
        st.sampled_from(["p", "q"]),
        st.integers(0, 1),
    )
    leaf = st.builds(
        Predicate,
        st.lists(term, min_size=1, max_size=2).map(tuple),
        st.floats(-3, 3, allow_nan=False),
    )
    interval = st.tuples(st.integers(0, 3), st.integers(0, 3)).map(
        lambda t: Interval(min(t), max(t))
    )

    def extend(inner: st.SearchStrategy[Formula]) -> st.SearchStrategy[Formula]:
        many = st.lists(inner, min_size=2, max_size=3).map(tuple)
        return st.one_of(
            many.map(And),
            many.map(Or),
            st.builds(Always, interval, inner),
            st.builds(Eventually, interval, inner),
            st.builds(Until, interval, inner, inner),
        )

    return st.recursive(leaf, extend, max_leaves=6)


@settings(max_examples=150, deadline=None)
@given(formula=lowered_formulas(), data=st.data())
def test_robustness_matches_brute_force_at_every_step(
    formula: Formula, data: st.DataObject
) -> None:
    H = horizon(formula) + data.draw(st.integers(0, 3))
    values = arrays(float, (H + 1, 2), elements=st.floats(-5, 5, allow_nan=False))
    x = {"p": data.draw(values), "q": data.draw(values)}
    rho = robustness(formula, x, H)
    assert len(rho) == H + 1 - horizon(formula)
    expected = [brute(formula, x, k) for k in range(len(rho))]
    assert rho.tolist() == pytest.approx(expected, abs=1e-9)
