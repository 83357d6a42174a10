"""The half-planes of step requirements evaluated on a trajectory, one by one or many at once.

A requirement (:class:`stlplan.planner.encoding.deferred.Requirement`) holds when one of its
half-planes ``alpha_i`` is at least the margin at each of its steps. Its :class:`Flat` form lays
those half-planes out as arrays, so that the thousands of requirements of a large team are
checked against a plan in one numpy evaluation (:func:`alpha_maxima`, :func:`violated`).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from stlplan.formula.tree import Predicate


@dataclass(frozen=True)
class Flat:
    """A requirement's half-planes at its steps as arrays: slot ``i * steps + s`` holds
    ``alpha_i`` at its step ``s``, the constant ``const[slot]`` plus ``coef`` times the state
    ``component`` of agent ``names[who]`` at ``step``, summed over the terms of that slot."""

    names: tuple[str, ...]
    alternatives: int
    steps: int
    const: np.ndarray
    slot: np.ndarray
    who: np.ndarray
    step: np.ndarray
    component: np.ndarray
    coef: np.ndarray


class Requirement(Protocol):
    """What is read of a step requirement
    (:class:`stlplan.planner.encoding.deferred.Requirement`)."""

    @property
    def alternatives(self) -> tuple[Predicate, ...]: ...
    @property
    def steps(self) -> range: ...
    @property
    def binding(self) -> Mapping[str, str]: ...
    @property
    def tightening(self) -> Callable[[Predicate, int], float]: ...
    @property
    def flat(self) -> Flat: ...


def flatten(requirement: Requirement) -> Flat:
    """``requirement`` as arrays (:class:`Flat`)."""
    alts, steps = requirement.alternatives, requirement.steps
    names = tuple(dict.fromkeys(requirement.binding[t.role] for a in alts for t in a.terms))
    rows = [
        (
            i * len(steps) + s,
            names.index(requirement.binding[term.role]),
            t,
            term.component,
            term.coef,
        )
        for i, alt in enumerate(alts)
        for s, t in enumerate(steps)
        for term in alt.terms
    ]
    columns = list(zip(*rows, strict=True)) or [()] * 5
    slot, who, step, component = (np.array(c, dtype=int) for c in columns[:4])
    coef = np.array(columns[4], dtype=float)
    const = np.array([-a.bound - requirement.tightening(a, t) for a in alts for t in steps])
    return Flat(names, len(alts), len(steps), const, slot, who, step, component, coef)


def alpha_values(requirement: Requirement, states: Mapping[str, np.ndarray]) -> np.ndarray:
    """``min_t alpha_i(x(t))`` over the requirement's steps, for every half-plane, on a trajectory
    (agent name to (H+1, n) states): what the encoding demands of the alternative ``i``."""
    flat = requirement.flat
    values = flat.const.copy()
    for n, agent in enumerate(flat.names):
        mine = flat.who == n
        read = states[agent][flat.step[mine], flat.component[mine]]
        values += np.bincount(flat.slot[mine], flat.coef[mine] * read, minlength=len(values))
    return values.reshape(flat.alternatives, flat.steps).min(axis=1)


def alpha_maxima(
    requirements: Sequence[Requirement], states: Mapping[str, np.ndarray]
) -> np.ndarray:
    """``max_i alpha_values(req, states)[i]`` for every requirement, evaluated at once."""
    if not requirements:
        return np.empty(0)
    values, firsts = half_plane_values(requirements, states)
    return np.maximum.reduceat(values, firsts)


def half_plane_values(
    requirements: Sequence[Requirement], states: Mapping[str, np.ndarray]
) -> tuple[np.ndarray, np.ndarray]:
    """``alpha_values`` of every requirement, one after the other, and where each
    requirement's first half-plane is in them (requirements not empty)."""
    table = _table(tuple(requirements))
    offset, cols, start = {}, {}, 0
    for agent, x in states.items():
        offset[agent], cols[agent], start = start, x.shape[1], start + x.size
    values = np.concatenate([np.asarray(x, float).ravel() for x in states.values()])
    at = np.array([offset[a] for a in table.agents])[table.who]
    width = np.array([cols[a] for a in table.agents])[table.who]
    read = values[at + table.step * width + table.component]
    alpha = table.const + np.bincount(table.slot, table.coef * read, len(table.const))
    return np.minimum.reduceat(alpha, table.alternatives), table.firsts


def best_sides(requirements: Sequence[Requirement], states: Mapping[str, np.ndarray]) -> np.ndarray:
    """For every requirement, the index of its half-plane with the largest ``alpha_i`` on a
    trajectory (the first of equals, as ``best_side``), evaluated at once."""
    if not requirements:
        return np.empty(0, dtype=int)
    values, firsts = half_plane_values(requirements, states)
    counts = np.diff(np.append(firsts, len(values)))
    best = np.repeat(np.maximum.reduceat(values, firsts), counts)
    hits = np.flatnonzero(values == best)
    return hits[np.searchsorted(hits, firsts)] - firsts


@dataclass(frozen=True)
class InPosition:
    """Requirements' half-planes in one agent's state, the other agents' states as numbers:
    ``sum_j a[h, j] x(t)[j] >= c[slot]`` for half-plane ``h`` at each of its steps."""

    a: np.ndarray
    """(half-planes, the agent's state components): the agent's coefficients."""
    c: np.ndarray
    """Per slot: ``-alpha`` at the agent's zero state (bound, tightening, others' terms)."""
    readable: np.ndarray
    """Per requirement: whether it reads no agent but the one and those given."""
    firsts: np.ndarray
    """Per requirement: its first half-plane."""
    alternatives: np.ndarray
    """Per half-plane: its first slot."""


def in_position(
    requirements: Sequence[Requirement], agent: str, fixed: Mapping[str, np.ndarray], n: int
) -> InPosition:
    """Every requirement's half-planes in ``agent``'s ``n`` state components, with the states
    of ``fixed`` (agent name to (H+1, n) states) as numbers (requirements not empty)."""
    table = _table(tuple(requirements))
    mine = np.array([a == agent for a in table.agents], dtype=bool)[table.who]
    known = np.array([a in fixed for a in table.agents], dtype=bool)[table.who] & ~mine
    values = np.zeros(len(table.coef))
    for index, name in enumerate(table.agents):
        if name in fixed:
            rows = known & (table.who == index)
            values[rows] = np.asarray(fixed[name], float)[table.step[rows], table.component[rows]]
    c = -(table.const + np.bincount(table.slot, table.coef * values, len(table.const)))
    half = np.searchsorted(table.alternatives, table.slot, side="right") - 1
    own = mine & (table.slot == table.alternatives[half])  # a half-plane's terms at its first step
    a = np.zeros((len(table.alternatives), n))
    np.add.at(a, (half[own], table.component[own]), table.coef[own])
    owner = np.searchsorted(table.firsts, half, side="right") - 1
    unread = np.bincount(owner[~mine & ~known], minlength=len(table.firsts))
    return InPosition(a, c, unread == 0, table.firsts, table.alternatives)


@dataclass(frozen=True)
class _Table:
    """Many requirements' :class:`Flat` forms, one after the other: ``who`` indexes ``agents``;
    ``alternatives`` holds the first slot of every half-plane, ``firsts`` the first half-plane
    of every requirement."""

    agents: tuple[str, ...]
    who: np.ndarray
    step: np.ndarray
    component: np.ndarray
    slot: np.ndarray
    coef: np.ndarray
    const: np.ndarray
    alternatives: np.ndarray
    firsts: np.ndarray


@functools.lru_cache(maxsize=32)
def _table(requirements: tuple[Requirement, ...]) -> _Table:
    flats = [r.flat for r in requirements]
    agents = tuple(dict.fromkeys(a for f in flats for a in f.names))
    index = {a: n for n, a in enumerate(agents)}
    slots = np.cumsum([0] + [len(f.const) for f in flats])
    sizes = [f.steps for f in flats for _ in range(f.alternatives)]
    return _Table(
        agents,
        np.concatenate([np.array([index[a] for a in f.names], int)[f.who] for f in flats]),
        np.concatenate([f.step for f in flats]),
        np.concatenate([f.component for f in flats]),
        np.concatenate([f.slot + b for f, b in zip(flats, slots, strict=False)]),
        np.concatenate([f.coef for f in flats]),
        np.concatenate([f.const for f in flats]),
        np.cumsum([0] + sizes[:-1]),
        np.cumsum([0] + [f.alternatives for f in flats[:-1]]),
    )


def violated(
    requirements: Sequence[Requirement],
    states: Mapping[str, np.ndarray],
    margin: float,
    tolerance: float,
) -> list[int]:
    """Indices of the requirements with ``max_i alpha_i(x(k)) - r < -tolerance``."""
    return np.flatnonzero(alpha_maxima(requirements, states) - margin < -tolerance).tolist()
