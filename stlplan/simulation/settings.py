"""What a simulation runs: the disturbance bound, the replanning policy and the events.

Every run of a simulation shares its :class:`Simulated`. Values come from the command line as
text (``--disturbance 0.05``, ``--lose vis1@4``, ``--close C@6``) and are checked against the
mission before anything runs or is written: a bound that is not a number ``>= 0``, an event not
written ``NAME@K``, an unknown agent or region, a step outside ``0..H-1``, an agent lost or a
region closed twice, or every agent lost, is bad input (exit 3).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal, NoReturn

from stlplan.deadline import deadline_seconds
from stlplan.errors import EventError, SimulationError
from stlplan.mission.problem import Problem
from stlplan.online import Policy
from stlplan.words import counted

EventKind = Literal["lose", "close"]

POLICIES: tuple[Policy, ...] = ("every", "on-deviation", "never")
"""The replanning policies of :class:`stlplan.online.OnlinePlanner`."""


@dataclass(frozen=True)
class Event:
    """An agent lost (``lose``) or a region closed (``close``) at step ``step``."""

    kind: EventKind
    name: str
    step: int

    def __str__(self) -> str:
        done = "lost" if self.kind == "lose" else "closed"
        return f"{self.name} {done} at step {self.step}"


@dataclass(frozen=True)
class Simulated:
    """One simulation's settings.

    Attributes
    ----------
    disturbance
        ``W``: each state component of each agent not lost gets, at each step, an additive
        disturbance drawn uniformly in ``[-W, W]``.
    policy
        When the loop replans (:data:`stlplan.online.Policy`).
    events
        Agents lost and regions closed, each at its step.
    deadline
        Seconds of wall time each replan may take (None: as long as its search needs;
        :mod:`stlplan.deadline`).
    """

    disturbance: float = 0.0
    policy: Policy = "on-deviation"
    events: tuple[Event, ...] = ()
    deadline: float | None = None

    def at(self, k: int) -> tuple[list[str], list[str]]:
        """The agents lost and the regions closed at step ``k``."""
        lost = [e.name for e in self.events if e.kind == "lose" and e.step == k]
        closed = [e.name for e in self.events if e.kind == "close" and e.step == k]
        return lost, closed

    def lost_at(self) -> dict[str, int]:
        """Each lost agent's step."""
        return {e.name: e.step for e in self.events if e.kind == "lose"}

    def describe(self) -> dict[str, Any]:
        """The settings as a record holds them (``lose`` and ``close`` as ``[name, step]``;
        ``deadline`` only when there is one)."""
        described: dict[str, Any] = {
            "disturbance": self.disturbance,
            "replan": self.policy,
            "lose": [[e.name, e.step] for e in self.events if e.kind == "lose"],
            "close": [[e.name, e.step] for e in self.events if e.kind == "close"],
        }
        if self.deadline is not None:
            described["deadline"] = self.deadline
        return described

    def check(self, problem: Problem) -> None:
        """Raise unless every setting fits ``problem`` (module docstring)."""
        _check_bound(self.disturbance, "--disturbance")
        _check_within_states(problem, self.disturbance)
        if self.policy not in POLICIES:
            raise SimulationError(f"--replan {self.policy}: expected one of {', '.join(POLICIES)}")
        if self.deadline is not None:
            deadline_seconds(self.deadline)
        _check_events(problem, self.events)


def check_runs(runs: int) -> None:
    """Raise :class:`SimulationError` unless ``runs`` is at least 1."""
    if runs < 1:
        raise SimulationError(f"--runs {runs}: expected at least 1 run")


def bound(text: str, option: str) -> float:
    """The disturbance bound given to ``option`` as text.

    Raises
    ------
    SimulationError
        Not a number, not finite, or negative.
    """
    try:
        value = float(text)
    except ValueError:
        raise SimulationError(
            f"{option} {text}: expected a number >= 0 (a bound on each state component's "
            "disturbance per step, in the state's units)"
        ) from None
    _check_bound(value, option)
    return value


def _check_within_states(problem: Problem, disturbance: float) -> None:
    """Raise when one step of ``disturbance`` can exceed an agent's whole state range (no plan
    could stay within its bounds)."""
    for agent in problem.agents:
        widths = agent.state_hi - agent.state_lo
        i = int(widths.argmin())
        if disturbance > widths[i]:
            raise SimulationError(
                f"--disturbance {disturbance:g}: larger than {agent.name}'s whole range of state "
                f"component {i} ({agent.state_lo[i]:g} to {agent.state_hi[i]:g}); expected at "
                f"most {widths[i]:g}"
            )


def _check_bound(value: float, option: str) -> None:
    if not (math.isfinite(value) and value >= 0):
        raise SimulationError(f"{option} {value:g}: expected a finite number >= 0")


def events(lose: Sequence[str], close: Sequence[str]) -> tuple[Event, ...]:
    """The events ``--lose AGENT@K`` and ``--close REGION@K`` (not yet checked against a
    mission: :meth:`Simulated.check`)."""
    read = [_event(text, "lose") for text in lose] + [_event(text, "close") for text in close]
    return tuple(read)


def _event(text: str, kind: EventKind) -> Event:
    name, at, step = text.rpartition("@")
    try:
        return Event(kind, name, int(step)) if at and name else _bad_event(text, kind)
    except ValueError:
        return _bad_event(text, kind)


def _bad_event(text: str, kind: EventKind) -> NoReturn:
    what = "AGENT" if kind == "lose" else "REGION"
    raise EventError(f"--{kind} {text}: expected {what}@K, a name and a step, such as @4")


def _check_events(problem: Problem, events: Sequence[Event]) -> None:
    H = problem.horizon
    names = [a.name for a in problem.agents]
    for event in events:
        option = f"--{event.kind} {event.name}@{event.step}"
        known = names if event.kind == "lose" else list(problem.regions)
        if event.name not in known:
            kind = "agent" if event.kind == "lose" else "region"
            raise EventError(f"{option}: no such {kind}; {kind}s: {', '.join(known)}")
        if not 0 <= event.step <= H - 1:
            raise EventError(f"{option}: expected a step in 0..{H - 1} (the horizon is {H})")
    for kind, what in (("lose", "lost"), ("close", "closed")):
        given = [e.name for e in events if e.kind == kind]
        twice = sorted({n for n in given if given.count(n) > 1})
        if twice:
            raise EventError(f"--{kind} {twice[0]}: {what} twice; name each once")
    lost = {e.name for e in events if e.kind == "lose"}
    if lost and lost == set(names):
        raise EventError(
            f"--lose names every agent ({counted(len(names), 'agent')}): nothing is left to run"
        )
