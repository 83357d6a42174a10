"""Every plan of step 1 credited to the stage that found it (``summary.json``'s ``trace``).

As a portfolio solver names the subsolver behind each improving solution, the run's
:class:`Trace` records, for every incumbent of the whole problem (the points of
:mod:`stlplan.planner.run.convergence` that raise the incumbent), the stage of step 1 that found
it (a key of :data:`stlplan.planner.run.reached.STAGES`), when, with which objective and for which
part of the team; and the seconds each stage took.

* A plan of the whole team's model is credited to the stage of the whole team when it was
  found: its lazy rounds, its one solve up front, a repair between its rounds, a completion.
* A plan assembled from the parts' plans is credited to the ``assembly``, with the stages that
  found the parts' plans (``parts``: how many parts' plans each stage found). A part's plan is
  credited as the whole team's are, to the stage its part was in when its loop kept it.
* A plan improved element by element is credited to the ``improvement by elements``.

A stage's seconds are the wall time of its blocks (a repair, the tightening of a bound, the
assembly, the improvement, a completion), summed over the parts and including the stages run
inside them; the lazy rounds' and the up-front solves' are the seconds of their solves (the
round log's). Parts solved side by side add their seconds up, so the stages may sum to more
than step 1's wall time.
"""

from __future__ import annotations

import threading
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from stlplan.planner.run.convergence import beyond, known

ROUNDS = ("lazy rounds", "up front")
"""Stages whose seconds are their solves' (the round log's), not a block's."""


@dataclass(frozen=True)
class Incumbent:
    """A plan of the whole problem better than every one before it.

    Attributes
    ----------
    at
        Seconds since planning started.
    objective
        Its objective in problem (step1).
    stage
        The stage that found it.
    part
        The part of the team that stage was solving, in a few words.
    parts
        For an assembly: how many of the parts' plans each stage found.
    """

    at: float
    objective: float
    stage: str
    part: str = ""
    parts: Mapping[str, int] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"at": self.at, "objective": self.objective, "stage": self.stage}
        out["part"] = self.part
        if self.parts:
            out["parts"] = dict(self.parts)
        return out


@dataclass
class Trace:
    """The incumbents of step 1, each credited to its stage, and each stage's seconds."""

    incumbents: list[Incumbent] = field(default_factory=list)
    seconds: dict[str, float] = field(default_factory=dict)
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False, compare=False)

    @property
    def best(self) -> float | None:
        """The best objective credited so far (None: no plan yet)."""
        return self.incumbents[-1].objective if self.incumbents else None

    def credit(self, incumbent: Incumbent) -> None:
        """Record ``incumbent`` when it is better than the best so far (beyond round-off)."""
        with self._lock:
            if known(incumbent.objective) and beyond(incumbent.objective, self.best):
                self.incumbents.append(incumbent)

    def spent(self, stage: str, seconds: float) -> None:
        """Add ``seconds`` to ``stage``'s."""
        with self._lock:
            self.seconds[stage] = self.seconds.get(stage, 0.0) + seconds

    def restart(self) -> None:
        """Step 1 is solved again from scratch (a strict retry): its plans are credited anew."""
        with self._lock:
            self.incumbents.clear()

    def record(self, round_log: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
        """The trace as ``summary.json`` holds it: ``incumbents`` in time order, ``stages`` (s,
        the rounds' stages from ``round_log``), ``first_plan`` and ``final_plan`` (the stages
        that found the first plan and the best one; None without a plan)."""
        stages = {stage: s for stage, s in self.seconds.items() if stage not in ROUNDS}
        for entry in round_log:
            if entry["stage"] in ROUNDS:
                stages[entry["stage"]] = stages.get(entry["stage"], 0.0) + float(entry["seconds"])
        found = self.incumbents
        return {
            "incumbents": [incumbent.as_dict() for incumbent in found],
            "stages": dict(sorted(stages.items(), key=lambda kv: -kv[1])),
            "first_plan": found[0].stage if found else None,
            "final_plan": found[-1].stage if found else None,
        }
