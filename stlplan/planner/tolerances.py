"""The planner's numerical tolerances: what counts as round-off, as met by the solver, and as met
by the monitor. Every comparison of a plan's figures in the planner uses one of them."""

ROUND_OFF = 1e-9
"""Float round-off: a figure better by at most this much (relative, absolute below 1) is no
better; a gap within ``(1 + ROUND_OFF)`` of another is within it; a big-M or a broken side this
small is none (HiGHS drops matrix values at or below it); and HiGHS's integrality tolerance
when step 1 is solved again strictly, its first plan having met its decisions only within
HiGHS's default one."""

FEASIBILITY = 1e-7
"""HiGHS's feasibility tolerance: a lazy requirement a plan breaks by more is violated; a
continuous stage's margins and an effort floor are lowered by it."""

HOLD = 1e-4
"""How far a plan may move and still be that plan: a held agent's state or input in a repair,
room for HiGHS's integrality tolerance (``big-M * 1e-6``; holding exactly, 1e-9, leaves the
turns no plan: docs/dropped.md, the repair in turn); and a continuous point landed on its rows
(``sum |u - u_QP|``), where HiGHS's QP point fails its own check by about 1e-6."""

ROOM = 10 * HOLD
"""The room a plan about to be held or followed keeps from a requirement's boundary, so that
moving within ``HOLD`` cannot break it: the held solve of a prioritized repair takes in the
requirements the turns' plans meet by less (crowd-16's first plan 12.4 to 4.7 s:
docs/measurements.md#the-prioritized-repair), and a guide path keeps this far past each
half-plane."""

MONITOR = 1e-6
"""The monitor's tolerance (its dynamics check): a predicate value above ``-MONITOR`` holds for
a witness, and an effort lower by at most this much is no lower."""
