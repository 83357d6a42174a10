"""Witnesses: the predicates, and their steps, by which a plan meets a formula."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stlplan.formula.normal import lower
from stlplan.formula.parser import parse
from stlplan.monitor.robustness import robustness
from stlplan.planner.first_plan.witness import witness

BOX = [[1, 0], [-1, 0], [0, 1], [0, -1]]
REGIONS = {  # [0,1] x [0,1], [2,3] x [0,1] and [0,3] x [0,1]
    "a": (BOX, [1, 0, 1, 0]),
    "b": (BOX, [3, -2, 1, 0]),
    "c": (BOX, [3, 0, 1, 0]),
}
H = 8


def _formula(text: str):  # type: ignore[no-untyped-def]
    return lower(parse(text), REGIONS, {"p": (0, 1)})


def _path(xs: list[float]) -> np.ndarray:
    """A path along ``y = 0.5`` through the given x, one a step."""
    return np.array([[x, 0.5] for x in xs])


def test_an_eventually_is_witnessed_at_its_latest_step_that_holds() -> None:
    path = _path([5, 0.5, 0.5, 0.5, 5, 5, 5, 5, 5])
    kept = witness(_formula("F[0,6] in(p, a)"), {"p": path})
    assert kept is not None and {w.step for w in kept} == {3}


def test_an_always_is_witnessed_at_every_step_of_its_window() -> None:
    path = _path([5, 0.5, 0.5, 0.5, 0.5, 0.5, 5, 5, 5])
    kept = witness(_formula("F[0,6] G[0,2] in(p, a)"), {"p": path})
    assert kept is not None and sorted({w.step for w in kept}) == [3, 4, 5]


def test_an_or_is_witnessed_by_the_child_met_with_most_to_spare() -> None:
    path = _path([0.9] * (H + 1))  # in a, 0.1 from its edge; in c, 0.5 from its nearest edge
    kept = witness(_formula("in(p, a) | in(p, c)"), {"p": path})
    assert kept is not None and len(kept) == 4
    values = [sum(t.coef * path[w.step, t.component] for t in w.predicate.terms)
              - w.predicate.bound for w in kept]  # fmt: skip
    assert min(values) == pytest.approx(0.5)


def test_a_formula_the_plan_breaks_has_no_witness() -> None:
    path = _path([5.0] * (H + 1))
    assert witness(_formula("F[0,6] in(p, a)"), {"p": path}) is None


FORMULAS = [
    "F[0,5] G[0,2] in(p, a)",
    "G[0,3] (in(p, a) | in(p, b))",
    "(in(p, b) U[1,6] in(p, a)) & F[0,8] in(p, b)",
    "F[0,4] (in(p, a) & F[1,3] in(p, b))",
]


@settings(max_examples=60, deadline=None)
@given(
    which=st.sampled_from(FORMULAS),
    xs=st.lists(st.sampled_from([0.5, 0.0, 2.5, 3.0, 5.0]), min_size=H + 1, max_size=H + 1),
    noise=st.lists(st.floats(-4, 8), min_size=H + 1, max_size=H + 1),
)
def test_any_path_keeping_a_witness_meets_the_formula(
    which: str, xs: list[float], noise: list[float]
) -> None:
    formula = _formula(which)
    plan = _path(xs)
    kept = witness(formula, {"p": plan})
    if kept is None:
        assert robustness(formula, {"p": plan}, H)[0] < 0
        return
    other = _path(noise)  # anywhere, except at the witness's steps, where it is the plan
    for w in kept:
        other[w.step] = plan[w.step]
    assert robustness(formula, {"p": other}, H)[0] >= 0


@pytest.mark.parametrize("which", FORMULAS)
def test_a_plan_meeting_the_formula_has_a_witness(which: str) -> None:
    formula = _formula(which)
    for xs in ([0.5] * (H + 1), [2.5] * (H + 1), [0.5, 2.5] * 4 + [0.5]):
        plan = _path(xs)
        if robustness(formula, {"p": plan}, H)[0] >= 0:
            assert witness(formula, {"p": plan}) is not None
