"""How the figures draw the team's counts (:mod:`stlplan.monitor.counts`).

A ``count(R, who)`` of a task or constraint is drawn as a thin bar on each counted agent's row of
the timeline at the steps the agent is inside ``R``; a ``visits[a,b](R, who)`` as a star at each
visit, at the step of its entry on the timeline and at the place of its entry on the map. Both
take ``R``'s colour on the map, darker for the stars; a caption per count and visits lists who was
inside when, and every visit.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from matplotlib.artist import Artist
from matplotlib.colors import to_rgba
from matplotlib.lines import Line2D
from matplotlib.patches import Patch, Rectangle

from stlplan.mission.problem import Problem
from stlplan.monitor.counts import CountPresence, TeamEvent, team_events
from stlplan.outputs.plots.common import region_styles, workspace
from stlplan.result import Trajectory

RGBA = tuple[float, float, float, float]
STAR: dict[str, Any] = dict(marker="*", mec="white", mew=0.7, linestyle="none", zorder=5.6)
"""A visit's mark, on the timeline and on the map (over the paths, under the step labels)."""
_BAND: dict[str, Any] = dict(linewidth=0.8, zorder=2)
_COUNT_LABEL: dict[str, Any] = dict(fontsize=6.5, fontweight="bold", color="white", zorder=6)


@dataclass(frozen=True)
class TeamMark:
    """What one task or constraint counts in one region: who is inside when (a ``count``), or
    who enters when (a ``visits``)."""

    owner: str
    """The task or constraint."""
    region: str
    visits: bool
    steps: Mapping[str, tuple[int, ...]]
    """Agent (the team's order) -> the steps it is inside (a count) or enters (a visits); only
    agents with some step."""
    window: tuple[int, int]
    """The steps the marks may fall on: ``0..H`` for a count, the visits' window for a visits."""
    who: str
    """The counted agents' selector as written (``camera``), empty for every agent."""

    @property
    def label(self) -> str:
        """``in A (watch_A)`` or ``visit to C (visit_C)``: the legend's entry."""
        kind = "visit to" if self.visits else "in"
        return f"{kind} {self.region} ({self.owner})"

    def entries(self) -> list[tuple[str, int]]:
        """Each step as ``(agent, step)``, by step, then in the team's order."""
        order = {a: i for i, a in enumerate(self.steps)}
        return sorted(((a, k) for a, ks in self.steps.items() for k in ks), key=_by_step(order))


def visit_names(mark: TeamMark) -> dict[tuple[str, int], str]:
    """``(agent, step)`` of each visit -> ``visit 3 of 10 to C (visit_C)``."""
    entries = mark.entries()
    return {
        entry: f"visit {i} of {len(entries)} to {mark.region} ({mark.owner})"
        for i, entry in enumerate(entries, start=1)
    }


def notes_at(marks: Sequence[TeamMark], agent: str, k: int) -> list[str]:
    """What the counts find of ``agent`` at step ``k``: ``in A, counted by watch_A``, ``enters:
    visit 3 of 10 to C (visit_C)``."""
    notes = []
    for mark in marks:
        if k in mark.steps.get(agent, ()):
            visit = f"enters: {visit_names(mark)[agent, k]}" if mark.visits else ""
            notes.append(visit or f"in {mark.region}, counted by {mark.owner}")
    return notes


def _by_step(order: Mapping[str, int]):
    return lambda entry: (entry[1], order[entry[0]])


def _mark(owner: str, event: TeamEvent, horizon: int) -> TeamMark:
    atom, who = event.atom, event.atom.who.text()
    if isinstance(event, CountPresence):
        steps = {a: ks for a, ks in event.inside.items() if ks}
        return TeamMark(owner, atom.region, False, steps, (0, horizon), who)
    found: dict[str, tuple[int, ...]] = {}
    for agent, k in event.entries:
        found[agent] = (*found.get(agent, ()), k)
    return TeamMark(owner, atom.region, True, found, event.window, who)


def _merged(first: TeamMark, then: TeamMark) -> TeamMark:
    names = list(dict.fromkeys([*first.steps, *then.steps]))
    both = {a: tuple(sorted({*first.steps.get(a, ()), *then.steps.get(a, ())})) for a in names}
    window = (min(first.window[0], then.window[0]), max(first.window[1], then.window[1]))
    return replace(first, steps=both, window=window)


def team_marks(problem: Problem, trajectory: Trajectory) -> list[TeamMark]:
    """The marks of every task's, then every constraint's counts, one per owner, region and kind
    (several atoms alike in one formula are merged), in the formulas' order."""
    owners = [(t.name, t.formula) for t in problem.tasks]
    owners += [(c.name, c.formula) for c in problem.constraints]
    marks: list[TeamMark] = []
    for owner, formula in owners:
        merged: dict[tuple[str, bool], TeamMark] = {}
        for event in team_events(problem, trajectory, formula):
            mark = _mark(owner, event, trajectory.horizon)
            key = (mark.region, mark.visits)
            merged[key] = _merged(merged[key], mark) if key in merged else mark
        marks += merged.values()
    team = [a.name for a in problem.agents]
    ordered = [replace(m, steps={a: m.steps[a] for a in team if a in m.steps}) for m in marks]
    return ordered


def marks_of(marks: Sequence[TeamMark], agent: str) -> list[TeamMark]:
    """The marks with some step of ``agent``: its lanes on the timeline after its tasks'."""
    return [m for m in marks if agent in m.steps]


def lane_box(row: float, lane: int, lanes: int) -> tuple[float, float]:
    """``(bottom, height)`` of lane ``lane`` of ``lanes`` in an agent's row centred at ``row``
    on the timeline: the lanes share 0.84 of the row, the first on top."""
    height = 0.84 / max(1, lanes)
    return row + 0.42 - height * (lane + 1), height


def region_colors(problem: Problem) -> dict[str, tuple[RGBA, RGBA]]:
    """Region name -> its colour on the map (opaque: a count's bars) and a darker one (the
    stars, the bars' edges and labels)."""
    styles = region_styles(problem, workspace(problem))
    colors: dict[str, tuple[RGBA, RGBA]] = {}
    for name in problem.regions:
        face = to_rgba(styles[name]["facecolor"]) if name in styles else to_rgba("0.6")
        r, g, b, _ = face
        colors[name] = (face, (0.62 * r, 0.62 * g, 0.62 * b, 1.0))
    return colors


def step_runs(steps: Sequence[int]) -> list[tuple[int, int]]:
    """Increasing ``steps`` as runs of consecutive ones, each ``(first, last)``."""
    runs: list[tuple[int, int]] = []
    for k in steps:
        if runs and runs[-1][1] == k - 1:
            runs[-1] = (runs[-1][0], k)
        else:
            runs.append((k, k))
    return runs


def step_ranges(steps: Sequence[int]) -> str:
    """``5, 7, 10-14``: steps with runs of consecutive ones joined."""
    return ", ".join(str(a) if a == b else f"{a}-{b}" for a, b in step_runs(steps))


def caption(mark: TeamMark) -> str:
    """One line: ``visit_C: 10 visits to C in steps 0-24 (drone2 at 5, 7; rover3 at 18)`` or
    ``watch_A: camera agents in A: rover3 at steps 10-14``."""
    who = f"{mark.who} agents" if mark.who else "agents"
    lists = "; ".join(f"{a} at {step_ranges(ks)}" for a, ks in mark.steps.items())
    if mark.visits:
        count = sum(len(ks) for ks in mark.steps.values())
        lo, hi = mark.window
        head = f"{mark.owner}: {count} visit{'' if count == 1 else 's'} to {mark.region}"
        return f"{head} in steps {lo}-{hi}" + (f" ({lists})" if lists else "")
    if not lists:
        return f"{mark.owner}: no {who[:-1]} in {mark.region}"
    return f"{mark.owner}: {who} in {mark.region}: " + lists.replace(" at ", " at steps ")


def handles(marks: Sequence[TeamMark], colors) -> list[Artist]:
    """The legend's entries of the marks drawn (a mark no agent has is left out)."""
    out: list[Artist] = []
    for mark in (m for m in marks if m.steps):
        face, dark = colors[mark.region]
        if mark.visits:
            out.append(Line2D([], [], color=dark, markersize=11, label=mark.label, **STAR))
        else:
            out.append(Patch(facecolor=face, edgecolor=dark, label=mark.label, **_BAND))
    return out


def draw_lane(ax, mark: TeamMark, agent: str, lane: tuple[float, float], colors) -> None:
    """One agent's lane of ``mark`` on the timeline: the window faintly in the region's colour;
    a thin bar per run of steps inside (a count), or a star at each entry (a visits)."""
    (y0, height), (face, dark) = lane, colors[mark.region]
    first, last = mark.window
    ax.add_patch(Rectangle((first - 0.5, y0), last - first + 1, height, color=face, alpha=0.15))
    middle, steps = y0 + height / 2, mark.steps[agent]
    if mark.visits:
        size = float(np.clip(40 * height, 7, 12))
        ax.plot(steps, [middle] * len(steps), color=dark, markersize=size, **STAR)
        order = {entry: i for i, entry in enumerate(mark.entries(), start=1)}
        for k in steps:  # the visit's number among all the mark's visits
            at = dict(xytext=(size / 2, 0), textcoords="offset points", va="center")
            ax.annotate(str(order[agent, k]), (k, middle), color=dark, fontsize=6.5, **at)
        return
    for start, end in step_runs(steps):
        corner, width = (start - 0.45, middle - 0.22 * height), end - start + 0.9
        ax.add_patch(Rectangle(corner, width, 0.44 * height, fc=face, ec=dark, **_BAND))


def draw_on_map(ax, problem: Problem, trajectory: Trajectory, pt_per_unit: float):
    """The marks of the counts on the map (:func:`draw_entries`): their legend entries and
    their captions, one per count and visits."""
    marks, colors = team_marks(problem, trajectory), region_colors(problem)
    draw_entries(ax, problem, trajectory, marks, colors, pt_per_unit)
    return handles([m for m in marks if m.visits], colors), [caption(m) for m in marks]


def draw_entries(ax, problem: Problem, trajectory: Trajectory, marks, colors, pt_per_unit) -> None:
    """A star at the place of each visit on the map; where several visits fall on one spot (less
    than a star apart), their number beside it (``x8``)."""
    for mark in (m for m in marks if m.visits):
        dark = colors[mark.region][1]
        places = np.array(
            [trajectory.position(a, problem.agent(a).position)[k] for a, k in mark.entries()]
        ).reshape(-1, 2)
        ax.plot(places[:, 0], places[:, 1], color=dark, markersize=12, **STAR)
        for spot, count in _clusters(places, 7.0 / pt_per_unit):
            if count > 1:
                text = f"\u00d7{count}"
                box = dict(boxstyle="round,pad=0.2", fc=dark, ec="none", alpha=0.9)
                ax.annotate(
                    text,
                    spot,
                    xytext=(-9, -9),
                    textcoords="offset points",
                    ha="right",
                    va="top",
                    bbox=box,
                    **_COUNT_LABEL,
                )


def _clusters(points: np.ndarray, radius: float) -> list[tuple[np.ndarray, int]]:
    """Points grouped greedily: each joins the first group whose first point is within
    ``radius`` (max-norm); each group as its first point and its size."""
    groups: list[list[np.ndarray]] = []
    for point in points:
        home = next((g for g in groups if np.max(np.abs(g[0] - point)) <= radius), None)
        if home is None:
            groups.append([point])
        else:
            home.append(point)
    return [(g[0], len(g)) for g in groups]
