"""The crowd missions: many agents swap places across a room past four pillars.

``n`` single-integrator agents start evenly spaced on a circle around the centre of a square
room; each must reach the point diametrically opposite its start (the antipodal swap) and stay
there for a few steps before the horizon ends, clear of four pillars around the centre and
pairwise apart. Every straight path crosses the centre, so the agents must agree who passes
where, and when: the classic hard case of multi-agent path planning.

The missions are feasible by construction: the whole circle turning half a turn at constant
speed (:func:`rotation_plan`) keeps every agent on the circle, outside the pillars, as far from
its neighbours as it started, and brings each one to its goal in time.

``python -m stlplan.crowd`` (``make crowd``) writes ``missions/crowd/crowd-16.yaml``,
``crowd-32.yaml`` and ``crowd-64.yaml``; the shipped files are its output, byte for byte.
"""

from __future__ import annotations

import argparse
import math
import random
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

SIZES = (16, 32, 64)
"""The team sizes of the shipped crowd missions."""
PILLARS = {"pillar_sw": (-1, -1), "pillar_se": (1, -1), "pillar_ne": (1, 1), "pillar_nw": (-1, 1)}
"""Pillar name to the signs of its centre's offset from the room's centre."""


@dataclass(frozen=True)
class Room:
    """The layout shared by every crowd mission; only the number of agents varies.

    Attributes
    ----------
    side
        The room is ``[0, side]^2``.
    radius
        Radius of the circle the agents start on, around the room's centre.
    pillar_offset
        Each pillar's centre is ``(±pillar_offset, ±pillar_offset)`` from the room's centre.
    pillar_half
        Half the side of a (square) pillar.
    goal_half
        Half the side of a (square) goal, centred on the antipode of the agent's start.
    horizon
        Steps of the mission.
    hold
        A goal is held for ``hold + 1`` steps: ``F[0, horizon - hold] G[0, hold] in(p, goal)``.
    speed
        Input bound per axis: the largest move per step along either axis.
    separation
        Pairwise separation (infinity norm).
    """

    side: float = 8.0
    radius: float = 3.5
    pillar_offset: float = 1.2
    pillar_half: float = 0.6
    goal_half: float = 0.1
    horizon: int = 20
    hold: int = 3
    speed: float = 0.7
    separation: float = 0.15

    @property
    def centre(self) -> float:
        """Both coordinates of the room's centre."""
        return self.side / 2

    @property
    def arrival(self) -> int:
        """The last step at which an agent may arrive in its goal and still hold it."""
        return self.horizon - self.hold


ROOM = Room()
"""The shipped missions' room."""


def _round(value: float) -> float:
    return round(value, 3) + 0.0  # + 0.0 turns -0.0 into 0.0


def starts(n: int, room: Room = ROOM) -> list[tuple[float, float]]:
    """Initial positions: ``n`` points evenly spaced on the circle, agent ``i`` at angle
    ``2 pi i / n`` (rounded to 3 decimals)."""
    c, r = room.centre, room.radius
    angles = [2 * math.pi * i / n for i in range(n)]
    return [(_round(c + r * math.cos(a)), _round(c + r * math.sin(a))) for a in angles]


def goals(n: int, room: Room = ROOM) -> list[tuple[float, float]]:
    """Goal centres: the reflection of each start through the room's centre."""
    c2 = 2 * room.centre
    return [(_round(c2 - x), _round(c2 - y)) for x, y in starts(n, room)]


def agent_name(i: int, n: int) -> str:
    """``a01``, ``a02``, ...: zero-padded so that the names sort in agent order."""
    return f"a{i + 1:0{len(str(n))}d}"


def _num(value: float) -> str:
    return f"{_round(value):g}"


def _box(x: float, y: float, half: float) -> str:
    xs, ys = (f"[{_num(v - half)}, {_num(v + half)}]" for v in (x, y))
    return f"{{box: [{xs}, {ys}]}}"


def _header(n: int, room: Room) -> list[str]:
    s = _num(room.side)
    return [
        "# yaml-language-server: $schema=../../schemas/mission.schema.json",
        "# Written by `python -m stlplan.crowd` (make crowd): change the generator, not this file.",
        f"name: crowd-{n}",
        "description: >-",
        f"  Antipodal swap of {n} agents: each starts on a circle of radius {_num(room.radius)} around",
        f"  the centre of a square room of side {s}, must reach the diametrically opposite point and",
        f"  stay there {room.hold + 1} steps, past four pillars in the middle, keeping "
        f"{_num(room.separation)} apart",
        f"  (single integrators, at most {_num(room.speed)} per step along each axis).",
        f"horizon: {room.horizon}",
        "",
        "dynamics:",
        "  single:   # x = z, u = velocity: x(k+1) = x(k) + u(k)",
        "    A: [[1, 0], [0, 1]]",
        "    B: [[1, 0], [0, 1]]",
        "    position: [0, 1]",
        f"    state_bounds: [[0, {s}], [0, {s}]]",
        f"    input_bounds: [[-{_num(room.speed)}, {_num(room.speed)}], "
        f"[-{_num(room.speed)}, {_num(room.speed)}]]",
        "",
    ]


def _agents_and_regions(n: int, room: Room, order: int | None) -> list[str]:
    agents = [
        f"  - {{name: {agent_name(i, n)}, dynamics: single, initial_state: [{_num(x)}, {_num(y)}]}}"
        for i, (x, y) in enumerate(starts(n, room))
    ]
    if order is not None:
        random.Random(order).shuffle(agents)
    heading = "agents:" if order is None else f"agents:   # listed in the order of seed {order}"
    lines = [heading, *agents]
    lines += ["", "regions:   # four pillars around the centre; each goal is a start's antipode"]
    c, d = room.centre, room.pillar_offset
    for name, (sx, sy) in PILLARS.items():
        lines.append(f"  {name}: {_box(c + sx * d, c + sy * d, room.pillar_half)}")
    for i, (x, y) in enumerate(goals(n, room)):
        lines.append(f"  goal_{agent_name(i, n)}: {_box(x, y, room.goal_half)}")
    return lines


def _tasks_and_rest(n: int, room: Room) -> list[str]:
    lines = ["", "tasks:   # each agent reaches its own goal and holds it"]
    reach = f"F[0,{room.arrival}] G[0,{room.hold}]"
    for i in range(n):
        name = agent_name(i, n)
        lines.append(
            f"  reach_{name}: {{formula: '{reach} in(p, goal_{name})', "
            f"roles: {{p: {{agent: {name}}}}}}}"
        )
    avoid = " & ".join(f"!in(p, {name})" for name in PILLARS)
    return lines + [
        "",
        "constraints:",
        "  avoid_pillars:",
        f"    formula: G[0,{room.horizon}] ({avoid})",
        "    for_each: p",
        "",
        f"separation: {_num(room.separation)}",
        "",
        "objective: {beta: 0.05, effort: l1, two_step: false}",
    ]


def mission_text(n: int, room: Room = ROOM, order: int | None = None) -> str:
    """The YAML of the crowd mission with ``n`` agents.

    Parameters
    ----------
    n
        Number of agents, even (each has an antipodal partner), at least 2.
    room
        The layout.
    order
        With a seed, the agents are listed in a random order drawn from it (the same mission
        otherwise), to measure how much a plan depends on the listing.

    Returns
    -------
    str
        The mission file's text, one line per agent, region and task.
    """
    if n < 2 or n % 2:
        raise ValueError(f"a crowd needs an even number of agents, at least 2; found {n}")
    lines = _header(n, room) + _agents_and_regions(n, room, order) + _tasks_and_rest(n, room)
    return "\n".join(lines) + "\n"


def rotation_plan(n: int, room: Room = ROOM) -> dict[str, np.ndarray]:
    """A plan that meets the crowd mission: the circle turns half a turn, then stays.

    Agent ``i`` moves along the circle at constant angular speed from its start (step 0) to its
    goal (step ``room.arrival``) and stays there to the horizon; starts and goals are the
    missions' rounded points, the steps between lie on the circle.

    Returns
    -------
    dict
        Agent name to its positions, shape ``(horizon + 1, 2)``.
    """
    c, r, arrival = room.centre, room.radius, room.arrival
    plan = {}
    for i, (start, goal) in enumerate(zip(starts(n, room), goals(n, room), strict=True)):
        angle = 2 * math.pi * i / n + math.pi * np.arange(arrival + 1) / arrival
        path = np.column_stack([c + r * np.cos(angle), c + r * np.sin(angle)])
        path[0], path[-1] = start, goal
        stay = np.repeat(path[-1:], room.horizon - arrival, axis=0)
        plan[agent_name(i, n)] = np.vstack([path, stay])
    return plan


def write(
    out: Path, sizes: Sequence[int] = SIZES, room: Room = ROOM, orders: Sequence[int] = ()
) -> list[Path]:
    """Write ``crowd-<n>.yaml`` for each size into ``out`` (made if missing), or with
    ``orders``, ``crowd-<n>-o<seed>.yaml`` for each size and seed (:func:`mission_text`); the
    paths."""
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for n in sizes:
        for order in orders or (None,):
            suffix = "" if order is None else f"-o{order}"
            path = out / f"crowd-{n}{suffix}.yaml"
            path.write_text(mission_text(n, room, order), encoding="utf-8")
            written.append(path)
    return written


def main(argv: Sequence[str] | None = None) -> int:
    """Write the crowd missions (``python -m stlplan.crowd --help``)."""
    parser = argparse.ArgumentParser(prog="python -m stlplan.crowd", description=__doc__.split(
        "\n\n")[0])  # fmt: skip
    parser.add_argument("--out", type=Path, default=Path("missions/crowd"),
                        help="folder to write into (default: missions/crowd)")  # fmt: skip
    parser.add_argument("--agents", type=int, nargs="+", default=list(SIZES),
                        help="team sizes, even numbers (default: 16 32 64)")  # fmt: skip
    parser.add_argument("--orders", type=int, nargs="+", default=[], metavar="SEED",
                        help="also list the agents in the random order of each seed, one file "
                        "each (crowd-N-oSEED.yaml)")  # fmt: skip
    args = parser.parse_args(argv)
    try:
        paths = write(args.out, args.agents, orders=args.orders)
    except ValueError as error:
        parser.error(str(error))
    for path in paths:
        print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
