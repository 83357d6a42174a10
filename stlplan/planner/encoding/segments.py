"""Safety on the path a robot follows: a requirement held on the segment between two steps.

A robot tracking the planned waypoints moves along the straight segment from ``x(k)`` to
``x(k+1)`` (DESIGN 2.9). Every ``alpha_i`` is affine in the states, so along the segment

    alpha_i((1 - s) x(k) + s x(k+1)) = (1 - s) alpha_i(x(k)) + s alpha_i(x(k+1)),  s in [0, 1],

and a half-plane that holds at both ends holds on the whole segment. A safety requirement
``OR_i alpha_i - r >= 0`` (outside a convex region: outside one of its faces; apart from another
agent: apart along one axis and direction) is therefore required on the segment by choosing one
alternative ``i`` for both ends:

    alpha_i(x(k)) - r >= -M_k (1 - z_i),   alpha_i(x(k+1)) - r >= -M_{k+1} (1 - z_i),
    {z_1..z_n} SOS1 with w_i <= z_i  (exactly one alternative enforced),

with the big-M of each end from the reachable box at that step, as for a single step. The
encoding costs the same binaries as the sampled requirement at one step. It is sufficient, not
necessary: a segment may pass a corner outside the region with its ends outside different faces;
the monitor judges segments exactly and so accepts every plan this encoding allows.
"""

from __future__ import annotations

from collections.abc import Sequence

from stlplan.formula.tree import Predicate
from stlplan.planner.encoding.stl import (
    StlContext,
    big_m_of,
    choice,
    indicator,
    predicate_value,
    require_predicate,
)


def require_on_steps(alternatives: Sequence[Predicate], steps: range, ctx: StlContext) -> None:
    """One alternative ``alpha_i - r >= 0`` at every step of ``steps`` (the ends of a segment)."""
    if len(alternatives) == 1:
        for t in steps:
            require_predicate(alternatives[0], t, ctx)
        return
    chosen = [_held_on_steps(alt, steps, ctx) for alt in alternatives]
    choice(ctx, chosen)


def _held_on_steps(node: Predicate, steps: range, ctx: StlContext) -> object:
    # alpha(x(t)) - r >= -M_t (1 - z) for every t in steps, M_t = r_max - alpha_lo(t)
    z = indicator(ctx)
    for t in steps:
        big_m = big_m_of(node, t, ctx)
        ctx.block.rows.add(predicate_value(node, t, ctx) - ctx.margin >= -big_m * (1 - z))
        ctx.ledger.guarded.append((z, (node, t, ctx.binding)))
    return z
