"""Special ordered sets of type 1 (SOS1) written out as linear constraints with binaries.

A vector ``lambda_0..lambda_n`` of continuous entries in ``[0, 1]`` is SOS1 (in the sense of
Kurtz & Lin, the paper's reference on fewer binaries) when

    sum_i lambda_i = 1   and   at most one lambda_i is non-zero,

so exactly one entry equals 1. Pyomo's HiGHS interface has no SOS constraints, so both encodings
below are plain linear rows on a Pyomo block:

* **logarithmic** (Vielma & Nemhauser; Kurtz & Lin): ``m = ceil(log2(n + 1))`` binaries ``y``;
  entry ``i`` gets the reflected Gray code ``g(i) = i xor (i >> 1)`` and, for every bit ``l``,

      sum_{i : g(i)_l = 1} lambda_i <= y_l,      sum_{i : g(i)_l = 0} lambda_i <= 1 - y_l.

  A binary vector ``y`` leaves only the entry whose code equals ``y`` free to be non-zero (codes
  are distinct), and ``sum lambda = 1`` makes it 1; a ``y`` that is nobody's code is infeasible.
* **standard**: one binary ``b_i`` per entry with ``lambda_i <= b_i`` and ``sum_i b_i = 1``.

Disjunctions and task choices use the vector ``{1 - z, z_1, .., z_n}`` whose first entry is the
"off" slot: ``z = 1`` forces one ``z_i = 1``; ``z = 0`` lets every ``z_i`` be 0.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

from pyomo.environ import Binary, Block, ConstraintList, VarList

from stlplan.planner.config import Encoding


def sos1_block() -> Block:
    """A Pyomo block holding every SOS1 of a model: ``binaries`` (VarList) and ``rows``."""
    block = Block(concrete=True)
    block.binaries = VarList(domain=Binary)
    block.rows = ConstraintList()
    return block


def gray_code(index: int) -> int:
    """Reflected binary Gray code of ``index``: consecutive indices differ in one bit."""
    return index ^ (index >> 1)


def code_bits(n_entries: int) -> int:
    """``ceil(log2(n_entries))``: binaries a logarithmic SOS1 over ``n_entries`` needs (>= 1)."""
    return max(1, math.ceil(math.log2(n_entries)))


def log_sos1(block: Block, entries: Sequence[Any]) -> list[Any]:
    """Constrain ``entries`` to be SOS1 with ``ceil(log2(len(entries)))`` binaries.

    Adds, with ``g`` the Gray code and ``y`` new binaries,

        sum_i lambda_i = 1,
        sum_{i : g(i)_l = 1} lambda_i <= y_l,   sum_{i : g(i)_l = 0} lambda_i <= 1 - y_l,

    for every bit ``l``. Entries are linear expressions valued in ``[0, 1]``.

    Returns
    -------
    list
        The binaries ``y_1..y_m``.
    """
    n_bits = code_bits(len(entries))
    codes = [gray_code(i) for i in range(len(entries))]
    block.rows.add(sum(entries) == 1)
    bits = [block.binaries.add() for _ in range(n_bits)]
    for bit, y in enumerate(bits):
        ones = [lam for lam, code in zip(entries, codes, strict=True) if code >> bit & 1]
        zeros = [lam for lam, code in zip(entries, codes, strict=True) if not code >> bit & 1]
        if ones:
            block.rows.add(sum(ones) <= y)
        if zeros:
            block.rows.add(sum(zeros) <= 1 - y)
    return bits


def standard_sos1(block: Block, entries: Sequence[Any]) -> list[Any]:
    """Constrain ``entries`` to be SOS1 with one binary per entry.

    Adds ``sum_i lambda_i = 1``, ``lambda_i <= b_i`` and ``sum_i b_i = 1``.

    Returns
    -------
    list
        The binaries ``b_0..b_n``.
    """
    chosen = [block.binaries.add() for _ in entries]
    block.rows.add(sum(entries) == 1)
    block.rows.add(sum(chosen) == 1)
    for lam, b in zip(entries, chosen, strict=True):
        block.rows.add(lam <= b)
    return chosen


SOS1_ENCODERS: dict[str, Callable[[Block, Sequence[Any]], list[Any]]] = {
    "log": log_sos1,
    "standard": standard_sos1,
}


def sos1(block: Block, entries: Sequence[Any], encoding: Encoding = "standard") -> list[Any]:
    """SOS1 over ``entries`` with the chosen ``encoding``; returns the binaries it added."""
    return SOS1_ENCODERS[encoding](block, entries)
