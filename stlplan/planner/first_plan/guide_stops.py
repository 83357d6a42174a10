"""The grid of a guide's search (:mod:`stlplan.planner.first_plan.guide`), the requirements as
half-planes in an agent's position, and the moves of the search that they stop.

At each step the search moves from every cell it reached by every displacement the input
bounds allow; a requirement of the step (its alternatives as half-planes ``a . p >= c`` in the
agent's position) stops a move whose segment keeps none of them at both ends (or whose arrival
keeps none, for a step requirement). With axis-parallel alternatives (boxes: obstacles,
separation in the infinity norm) a move can break a requirement only from a cell within one
longest move of the box where every alternative fails: its *window*. Only the cells of the
window that the search reached are examined.

A crowd gives a step hundreds of requirements, one for each agent planned before, each with a
small window: those are examined together, in one numpy evaluation over windows of one size
(a window grown to that size changes nothing: a cell outside the box stops no move). The
others, whose window is the whole grid or large, are examined one by one.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from stlplan.planner.tolerances import ROUND_OFF

BATCH_CELLS = 16
"""Requirements whose window has at most this many cells along each axis are examined
together."""

Window = tuple[slice, slice]
"""Cells along each axis of a grid."""


@dataclass(frozen=True)
class Grid:
    """Positions ``reference(t) + h * (i - n)``, ``i`` in ``0..2n`` along each axis, at each step."""

    reference: np.ndarray  # (H+1, 2)
    h: np.ndarray
    n: np.ndarray
    low: np.ndarray  # the shortest and longest displacement of one step along each axis
    high: np.ndarray

    @property
    def shape(self) -> tuple[int, int]:
        return int(2 * self.n[0] + 1), int(2 * self.n[1] + 1)

    def origin(self, t: int) -> np.ndarray:
        """The position of cell ``(0, 0)`` at step ``t``."""
        return self.reference[t] - self.h * self.n

    def points(self, t: int) -> tuple[np.ndarray, np.ndarray]:
        """The x and y coordinates of the cells at step ``t``, each of ``shape``."""
        o = self.origin(t)
        ix = o[0] + self.h[0] * np.arange(self.shape[0])
        iy = o[1] + self.h[1] * np.arange(self.shape[1])
        return np.meshgrid(ix, iy, indexing="ij")

    def moves(self, t: int) -> tuple[np.ndarray, np.ndarray]:
        """The cell offsets (M, 2) of the moves from step ``t`` within the input bounds, and
        their displacements (M, 2)."""
        along = self.reference[t + 1] - self.reference[t]
        first = np.ceil((self.low - along) / self.h - ROUND_OFF).astype(int)
        last = np.floor((self.high - along) / self.h + ROUND_OFF).astype(int)
        cells = np.array([(i, j) for i in range(first[0], last[0] + 1)
                          for j in range(first[1], last[1] + 1)], dtype=int).reshape(-1, 2)  # fmt: skip
        return cells, along + cells * self.h


@dataclass(frozen=True)
class HalfPlanes:
    """The alternatives of one requirement in the agent's position: ``a_i . p >= c_i(t)``."""

    a: np.ndarray  # (n_alt, 2)
    c: np.ndarray  # (n_alt, n_steps): the requirement's steps, margin and clearance included
    k: int
    span: int
    reads: frozenset[str] = frozenset()
    """The other agents whose states are in ``c``."""


def reached(cost: np.ndarray) -> Window:
    """The least box of cells holding every cell of finite ``cost``."""
    rows = np.flatnonzero(np.isfinite(cost).any(axis=1))
    cols = np.flatnonzero(np.isfinite(cost).any(axis=0))
    if rows.size == 0:
        return slice(0, 0), slice(0, 0)
    return slice(int(rows[0]), int(rows[-1]) + 1), slice(int(cols[0]), int(cols[-1]) + 1)


def windows(a: np.ndarray, c: np.ndarray, grid: Grid, t: int, reach: int) -> np.ndarray:
    """The windows at step ``t`` of requirements of one shape, their alternatives ``a`` (R, A,
    2) and ``c`` (R, A, S): the first and last cell (exclusive) along each axis, (R, 2, 2),
    within ``reach`` cells of the box where every alternative fails (the whole grid when an
    alternative is not parallel to an axis)."""
    nonzero = a != 0
    parallel = nonzero.sum(axis=2) == 1  # (R, A)
    axis = nonzero.argmax(axis=2)
    coef = np.take_along_axis(a, axis[..., None], 2)[..., 0]
    edge = c / np.where(parallel, coef, 1.0)[..., None]  # a p >= c: past the edge when a > 0
    up = np.where(parallel & (coef > 0), edge.max(axis=2), np.inf)
    down = np.where(parallel & (coef < 0), edge.min(axis=2), -np.inf)
    shape, origin = np.array(grid.shape), grid.origin(t)
    out = np.zeros((len(a), 2, 2), dtype=int)
    for i in range(2):
        hi = np.where(axis == i, up, np.inf).min(axis=1)
        lo = np.where(axis == i, down, -np.inf).max(axis=1)
        with np.errstate(invalid="ignore"):
            first = np.floor((lo - origin[i]) / grid.h[i]) - reach
            last = np.ceil((hi - origin[i]) / grid.h[i]) + reach + 1
        start = np.where(np.isinf(first), 0, np.clip(first, 0, shape[i]))
        stop = np.where(np.isinf(last), shape[i], np.maximum(0, last))
        out[:, i, 0], out[:, i, 1] = start, np.maximum(start, np.minimum(stop, shape[i]))
    whole = ~parallel.all(axis=1)
    out[whole, :, 0], out[whole, :, 1] = 0, shape
    return out


def block(
    hp: HalfPlanes, grid: Grid, t: int, shifts: np.ndarray, out: np.ndarray, window: Window
) -> None:
    """Mark in ``out`` (M, nx, ny) the moves from the cells of ``window`` at step ``t``
    (displacements ``shifts``) that break ``hp``."""
    wx, wy = window
    if wx.start >= wx.stop or wy.start >= wy.stop:
        return
    fails = moves_failed(hp.a[None], hp.c[None], grid, t, shifts, wx.start, wy.start,
                   (wx.stop - wx.start, wy.stop - wy.start))  # fmt: skip
    out[:, wx, wy] |= fails[0]


def stopped(
    hps: Sequence[HalfPlanes], grid: Grid, t: int, shifts: np.ndarray, near: Window, reach: int
) -> np.ndarray:
    """The moves (M, nx, ny) from the cells of ``near`` at step ``t`` that a requirement of
    ``hps`` (all of the step) breaks (maybe some from other cells too, never one that breaks
    none)."""
    out = np.zeros((len(shifts), *grid.shape), dtype=bool)
    shapes: dict[tuple[int, ...], list[HalfPlanes]] = {}
    for hp in hps:
        shapes.setdefault(hp.c.shape, []).append(hp)
    for group in shapes.values():
        a, c = np.stack([hp.a for hp in group]), np.stack([hp.c for hp in group])
        found = windows(a, c, grid, t, reach)
        for i in range(2):
            found[:, i, 0] = np.maximum(found[:, i, 0], near[i].start)
            found[:, i, 1] = np.maximum(found[:, i, 0], np.minimum(found[:, i, 1], near[i].stop))
        sizes = found[:, :, 1] - found[:, :, 0]
        small = (sizes <= BATCH_CELLS).all(axis=1) & (sizes > 0).all(axis=1)
        for n in np.flatnonzero(~small & (sizes > 0).all(axis=1)):
            block(group[n], grid, t, shifts, out, (slice(*found[n, 0]), slice(*found[n, 1])))
        if small.any():
            _batch(a[small], c[small], found[small], grid, t, shifts, out)
    return out


def _batch(
    a: np.ndarray,
    c: np.ndarray,
    found: np.ndarray,
    grid: Grid,
    t: int,
    shifts: np.ndarray,
    out: np.ndarray,
) -> None:
    """Mark in ``out`` what the requirements ``a``, ``c`` stop within their windows ``found``,
    each grown to the largest window's size (kept within the grid)."""
    largest = (found[:, :, 1] - found[:, :, 0]).max(axis=0)
    size = (min(int(largest[0]), grid.shape[0]), min(int(largest[1]), grid.shape[1]))
    starts = [np.clip(found[:, i, 0], 0, grid.shape[i] - size[i]) for i in range(2)]
    fails = moves_failed(a, c, grid, t, shifts, starts[0], starts[1], size)
    for n, (x, y) in enumerate(zip(*starts, strict=True)):
        out[:, x : x + size[0], y : y + size[1]] |= fails[n]


def moves_failed(
    a: np.ndarray,
    c: np.ndarray,
    grid: Grid,
    t: int,
    shifts: np.ndarray,
    x0: int | np.ndarray,
    y0: int | np.ndarray,
    size: tuple[int, int],
) -> np.ndarray:
    """For requirements ``a`` (R, A, 2), ``c`` (R, A, S), whether each move (M) from each cell
    of the windows starting at cells ``x0``, ``y0`` (of ``size``) keeps none of the
    alternatives: (R, M, size)."""
    origin = grid.origin(t)
    px = origin[0] + grid.h[0] * (np.reshape(x0, (-1, 1)) + np.arange(size[0]))  # (R, wx)
    py = origin[1] + grid.h[1] * (np.reshape(y0, (-1, 1)) + np.arange(size[1]))
    value = (
        a[:, :, 0, None, None] * px[:, None, :, None]
        + a[:, :, 1, None, None] * py[:, None, None, :]
    )
    along = a[:, :, 0, None] * shifts[:, 0] + a[:, :, 1, None] * shifts[:, 1]  # (R, A, M): a . d
    if c.shape[2] == 1:  # a step requirement: the arrival p + d keeps one alternative
        need = c[:, :, 0, None] - along
    else:  # a segment: p keeps it at k, p + d at k + 1
        need = np.maximum(c[:, :, 0, None], c[:, :, 1, None] - along)
    return (value[:, :, None] < need[..., None, None]).all(axis=1)
