"""How far step 1 got: the part of the team it was solving, in which stage, and the counts.

A run that ends without a plan says which part failed, at which stage and how far it got
(:meth:`Reached.describe`, in the run's message). The strategies and repairs tell the run's
:class:`Reached` what they start and how they end, each unaware of who wraps it:

* the parts (:mod:`stlplan.planner.core.components`): how many parts, how many of them planned, the
  part being solved (its agents, and how many parts it was merged from);
* a stage of that part: its one solve (every requirement up front), its own lazy rounds, a
  repair in turn (:mod:`stlplan.planner.core.in_turn`: agents repaired of those freed), a held
  repair, the tightening of a part's bound, the assembly of the parts' plans, the completion
  of the last round's plan at the time limit;
* every lazy round recorded (:meth:`stlplan.planner.run.clock.Clock.record_round`): the part's
  rounds and the requirements its model held.

A stage that ends without a plan leaves a note on its part, so the message also says what was
tried before the stage the run ended in.
"""

from __future__ import annotations

import contextlib
import threading
import time
from collections import Counter
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field

from stlplan.planner.run.trace import Trace
from stlplan.words import agent_names, counted

STAGES = {
    "up front": "its one solve, every requirement in the model",
    "lazy rounds": "its own lazy rounds",
    "prioritized repair": "the prioritized repair",
    "repair by elements": "the repair by elements",
    "repair in turn": "the repair in turn",
    "repair around later plans": "the repair around the plans of the parts done after it",
    "held repair": "the held repair",
    "tightening": "the tightening of its bound",
    "assembly": "the assembly of the parts' plans",
    "improvement by elements": "the improvement of the first plan element by element",
    "completion": "the completion of the last round's plan",
}
"""Each stage of a part, as the message names it."""


@dataclass
class Track:
    """How far one part got.

    Attributes
    ----------
    part, merged_from
        The part's agents, and how many parts it was merged from (0: none).
    stage, progress
        The part's stage (a key of :data:`STAGES`), and how far that stage got in words
        (``14 of 16 agents repaired``; empty when its rounds say it).
    rounds, held
        The part's lazy rounds so far, and the requirements its model held in the last one.
    notes
        The part's earlier stages that ended without a plan, each with how far it got.
    plan_from
        The stage the part was in when its loop last kept a plan (None: none kept yet).
    """

    part: tuple[str, ...] = ()
    merged_from: int = 0
    stage: str = "lazy rounds"
    progress: str = ""
    rounds: int = 0
    held: int = 0
    notes: list[str] = field(default_factory=list)
    plan_from: str | None = None

    def source(self) -> str:
        """The stage that found the part's plan: a completion, else the stage its loop last kept
        a plan in, else its stage (a model without lazy requirements keeps no plan aside)."""
        if self.stage == "completion" or self.plan_from is None:
            return self.stage
        return self.plan_from


@dataclass
class Reached:
    """Where step 1 is (module docstring). Parts solved side by side each report from a
    thread of their own: every thread follows its own part (:class:`Track`), and what a
    thread reads is its part's.

    Attributes
    ----------
    order
        The mission's agents, in order.
    parts, planned, merges
        Parts the team was split into, how many of them planned on their own, and the merges
        of parts whose plans collided (1, 0 and 0 for a team solved whole).
    trace
        Every incumbent credited to its stage, and each stage's seconds
        (:mod:`stlplan.planner.run.trace`).
    """

    order: tuple[str, ...] = ()
    parts: int = 1
    planned: int = 0
    merges: int = 0
    trace: Trace = field(default_factory=Trace)
    _tracks: dict[tuple[str, ...], Track] = field(default_factory=dict, repr=False)
    _local: threading.local = field(default_factory=threading.local, repr=False)
    _first: Track = field(default_factory=Track, repr=False)

    @property
    def track(self) -> Track:
        """The part the calling thread is solving (or last followed)."""
        return getattr(self._local, "track", None) or self._first

    @property
    def stage(self) -> str:
        """The calling thread's part's stage."""
        return self.track.stage

    @property
    def progress(self) -> str:
        """How far the calling thread's part's stage got, in words."""
        return self.track.progress

    def solving(self, agents: Sequence[str], merged_from: int = 0) -> None:
        """A part's solve starts in the calling thread (the whole team's when ``agents`` are
        all of them); its counts start again when the thread was solving another part."""
        key = tuple(agents)
        track = self._tracks.setdefault(key, Track(key))
        if track is not self.track:
            track.rounds, track.held, track.notes, track.plan_from = 0, 0, [], None
        self._local.track = track
        track.merged_from, track.stage, track.progress = merged_from, "lazy rounds", ""

    def follow(self, agents: Sequence[str]) -> None:
        """The calling thread reports (and describes) the part of ``agents`` from now on, as
        it was left (a part solved in another thread that found no plan)."""
        track = self._tracks.get(tuple(agents))
        if track is not None:
            self._local.track = track

    def round_done(self, held: int) -> None:
        """A lazy round of the part ended, its model holding ``held`` requirements."""
        track = self.track
        track.rounds, track.held = track.rounds + 1, held

    def enter(self, stage: str) -> None:
        """The part's last stage starts (the completion: nothing follows it)."""
        self.track.stage, self.track.progress = stage, ""

    @contextlib.contextmanager
    def within(self, stage: str) -> Iterator[None]:
        """The block is ``stage`` of the part; the stage before it resumes afterwards."""
        track = self.track
        before = track.stage, track.progress
        self.enter(stage)
        try:
            with self.timed(stage):
                yield
        finally:
            track.stage, track.progress = before

    @contextlib.contextmanager
    def timed(self, stage: str) -> Iterator[None]:
        """Add the block's wall time to ``stage``'s seconds in the trace."""
        tick = time.perf_counter()
        try:
            yield
        finally:
            self.trace.spent(stage, time.perf_counter() - tick)

    def kept(self) -> None:
        """The calling thread's part kept a plan in its current stage."""
        self.track.plan_from = self.track.stage

    def sources(self, parts: Sequence[Sequence[str]]) -> dict[str, int]:
        """How many of the plans of ``parts`` (each its agents) each stage found."""
        tracks = [self._tracks.get(tuple(agents)) for agents in parts]
        return dict(Counter(track.source() for track in tracks if track is not None))

    def turns(self, repaired: int, freed: int) -> None:
        """A repair in turn has repaired ``repaired`` of the ``freed`` agents."""
        self.track.progress = f"{repaired} of {_count(freed, 'agent')} repaired"

    def ordered(self, planned: int, parts: int, orders: int) -> None:
        """A prioritized repair planned ``planned`` of ``parts`` parts in its ``orders``-th
        order."""
        self.track.progress = f"order {orders}: {planned} of {_count(parts, 'part')} planned"

    def completing(self, added: int, pending: int) -> None:
        """A completion has added ``added`` of the ``pending`` requirements left out."""
        self.track.progress = f"{added:,} of {_count(pending, 'requirement')} left out added"

    def failed(self, stage: str) -> None:
        """``stage``, just ended, found no plan (a note for the message, with its progress)."""
        self.track.notes.append(_stage_words(stage, self.track.progress))

    def _part_words(self, track: Track) -> str:
        if set(track.part) == set(self.order) and not track.merged_from:
            return "the whole team"
        words = f"the part of {agent_names(track.part, self.order)}"
        if track.merged_from:
            words += f" (merged from {track.merged_from} parts whose plans collided)"
        return words

    def describe(self) -> str:
        """Which part step 1 was solving (the calling thread's), in which stage, and how far it
        got, in words."""
        track = self.track
        if not track.part:
            return "no part of the team was solved"
        text = f"{self._part_words(track)} was in {_stage_words(track.stage, track.progress)}"
        if track.stage != "up front":
            text += f" after {_count(track.rounds, 'lazy round')}"
            text += f" ({_count(track.held, 'requirement')} added)"
        if track.notes:
            text += "; before that, no plan from " + _listed(track.notes)
        if self.parts > 1:
            text += f"; {self.planned} of {self.parts} parts had planned on their own"
            if self.merges:
                text += f", then {_count(self.merges, 'merge')}"
        return text


def _listed(items: Sequence[str]) -> str:
    """``a``, ``a and b``, ``a, b and c``."""
    return items[0] if len(items) == 1 else f"{', '.join(items[:-1])} and {items[-1]}"


def _stage_words(stage: str, progress: str) -> str:
    return STAGES[stage] + (f" ({progress})" if progress else "")


def _count(n: int, noun: str) -> str:
    """``counted`` with thousands separated: ``1,674 requirements``."""
    return counted(n, noun).replace(str(n), f"{n:,}", 1)
