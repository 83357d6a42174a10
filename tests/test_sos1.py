"""The SOS1 encodings against enumeration: every binary assignment selects exactly one entry."""

from __future__ import annotations

import itertools
import math

import pytest
from pyomo.contrib.solver.common.results import TerminationCondition
from pyomo.contrib.solver.solvers.highs import Highs
from pyomo.environ import ConcreteModel, Objective, VarList, maximize, value

from stlplan.planner.encoding.sos1 import code_bits, gray_code, sos1, sos1_block


def _solver() -> Highs:
    solver = Highs()
    solver.config.load_solutions = False
    solver.config.raise_exception_on_nonoptimal_result = False
    return solver


def _sos1_model(n_entries: int, encoding: str) -> tuple[ConcreteModel, list, list]:
    model = ConcreteModel()
    model.lam = VarList(bounds=(0, 1))
    entries = [model.lam.add() for _ in range(n_entries)]
    model.sos = sos1_block()
    binaries = sos1(model.sos, entries, encoding)  # type: ignore[arg-type]
    return model, entries, binaries


def _max_entry(model: ConcreteModel, entry) -> float | None:
    """Largest value ``entry`` can take, or None when the model is infeasible."""
    if hasattr(model, "goal"):
        model.del_component("goal")
    model.goal = Objective(expr=entry, sense=maximize)
    results = _solver().solve(model)
    if results.termination_condition != TerminationCondition.convergenceCriteriaSatisfied:
        return None
    results.solution_loader.load_vars()
    return float(value(entry))


def _selected(model: ConcreteModel, entries: list) -> int | None:
    """The entry equal to 1 when it is the only one that can be non-zero; None if infeasible."""
    best = _max_entry(model, sum(entries))
    if best is None:
        return None
    assert abs(best - 1) < 1e-9  # the entries sum to 1
    ones = [i for i, lam in enumerate(entries) if float(value(lam)) > 1 - 1e-9]
    assert len(ones) == 1
    others = sum(lam for i, lam in enumerate(entries) if i != ones[0])
    assert abs(_max_entry(model, others) or 0.0) < 1e-9  # no other entry can be non-zero
    return ones[0]


@pytest.mark.parametrize("n", range(1, 10))
def test_log_sos1_selects_exactly_one_entry_per_code(n: int) -> None:
    model, entries, binaries = _sos1_model(n + 1, "log")
    assert len(binaries) == math.ceil(math.log2(n + 1))
    reached = []
    for bits in itertools.product((0, 1), repeat=len(binaries)):
        for y, bit in zip(binaries, bits, strict=True):
            y.fix(bit)
        chosen = _selected(model, entries)
        code = sum(bit << i for i, bit in enumerate(bits))
        carried = [i for i in range(n + 1) if gray_code(i) == code]
        assert chosen == (carried[0] if carried else None)
        if chosen is not None:
            reached.append(chosen)
    assert sorted(reached) == list(range(n + 1))


@pytest.mark.parametrize("n", [1, 2, 4])
def test_standard_sos1_selects_exactly_one_entry(n: int) -> None:
    model, entries, binaries = _sos1_model(n + 1, "standard")
    assert len(binaries) == n + 1
    reached = []
    for bits in itertools.product((0, 1), repeat=len(binaries)):
        for y, bit in zip(binaries, bits, strict=True):
            y.fix(bit)
        chosen = _selected(model, entries)
        assert chosen == (bits.index(1) if sum(bits) == 1 else None)
        if chosen is not None:
            reached.append(chosen)
    assert sorted(reached) == list(range(n + 1))


def test_gray_codes_are_distinct_and_adjacent_codes_differ_in_one_bit() -> None:
    codes = [gray_code(i) for i in range(64)]
    assert len(set(codes)) == 64
    assert all(bin(a ^ b).count("1") == 1 for a, b in itertools.pairwise(codes))
    assert [code_bits(n) for n in (1, 2, 3, 4, 5, 8, 9)] == [1, 1, 2, 2, 3, 3, 4]
