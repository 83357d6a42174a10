"""What the outputs show of the team's counts: who a ``count`` finds inside its region when, and
each visit a ``visits`` counts (:mod:`stlplan.monitor.counts`), on ``timeline.png``, ``plan.png``
and ``plan.html``.

The trajectories are walked by hand on the 10 x 10 map of :mod:`tests.helpers.maps` (boxes R and
C): ``a`` stays inside C throughout, ``b`` goes through R into C, out, through R and back into C,
``c`` (not counted by ``x``) reaches C over its edge.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from matplotlib.colors import to_rgba
from matplotlib.lines import Line2D
from matplotlib.patches import Rectangle

from stlplan.mission.problem import Problem
from stlplan.monitor.counts import CountPresence, VisitEntries, entry_steps, team_events
from stlplan.monitor.verdicts import check
from stlplan.outputs.plots import plan_figure, plot_plan, plot_timeline, timeline_figure
from stlplan.outputs.plots.team import region_colors
from stlplan.outputs.viewer import hover_texts, viewer_figure, write_viewer
from tests.helpers.browser import Page
from tests.helpers.maps import make_problem, walk

PATHS = {
    "a": [(7.5, 6.5)] * 7,
    "b": [(1, 1), (3, 3), (7, 7), (5, 5), (3, 3), (7, 7), (7, 7)],
    "c": [(1, 1), (4.5, 4.5), (6, 7), (7, 7), (7, 7), (7, 7), (7, 7)],
}
"""Steps 0..6: a in C at every step; b in R at 1 and 4, in C at 2, 5 and 6; c on C's left edge
at 2 (neither inside nor outside), inside from 3."""
CAPABILITIES = {"a": "x", "b": "x", "c": "y"}
TASKS = {
    "count_R": {"formula": "F[0,6] count(R, x) >= 1"},
    "visit_C": {"formula": "visits[0,5](C, x) >= 3"},
    "reach_C": {"formula": "F[0,6] in(p, C)", "roles": {"p": {"agent": "b"}}},
}
"""A count, a visits, and a task served by a role (b's lane beside its counted ones)."""


def _problem(tasks: dict[str, Any]) -> Problem:
    return make_problem(PATHS, CAPABILITIES, tasks=tasks)


def _events(formula: str) -> list:
    problem = _problem({"t": {"formula": formula}})
    return team_events(problem, walk(PATHS), problem.tasks[0].formula)


@pytest.fixture(scope="module")
def plan() -> tuple[Problem, Any, Any]:
    problem = _problem(TASKS)
    trajectory = walk(PATHS)
    return problem, trajectory, check(problem, trajectory)


# ---------------------------------------------------------------------------- the counts module
def test_an_entry_is_outside_then_inside_or_inside_at_the_windows_first_step() -> None:
    inside = np.array([1, 1, 0, 1, 1, 0], dtype=bool)
    assert entry_steps(inside, 0, 5) == [0, 3]
    assert entry_steps(inside, 1, 5) == [1, 3]  # inside at the window's first step
    assert entry_steps(inside, 2, 3) == [3]
    assert entry_steps(inside, 4, 9) == [4]  # the window cut at the last step


def test_visits_list_each_entry_in_the_window_and_a_stay_once() -> None:
    (visits,) = _events("visits[0,5](C, x) >= 3")
    assert isinstance(visits, VisitEntries)
    assert visits.window == (0, 5)
    # a, inside throughout, enters once (step 0); b's entry at 6 would be past the window
    assert visits.entries == (("a", 0), ("b", 2), ("b", 5))


def test_a_window_from_a_later_step_counts_who_is_inside_at_its_first_step() -> None:
    (visits,) = _events("visits[2,4](C, x) >= 2")
    assert visits.window == (2, 4)
    assert visits.entries == (("a", 2), ("b", 2))


def test_visits_under_a_temporal_operator_cover_the_whole_horizon() -> None:
    (visits,) = _events("F[0,1] visits[0,2](C, x) >= 1")
    assert visits.window == (0, 6)
    assert visits.entries == (("a", 0), ("b", 2), ("b", 5))


def test_an_agent_on_the_edge_is_not_inside_so_it_enters_a_step_later() -> None:
    (visits,) = _events("visits[0,6](C) >= 1")  # every agent, c among them
    assert ("c", 2) not in visits.entries
    assert visits.entries == (("a", 0), ("b", 2), ("c", 3), ("b", 5))


def test_a_count_gives_the_steps_each_counted_agent_is_inside() -> None:
    (count,) = _events("F[0,6] count(R, x) >= 1")
    assert isinstance(count, CountPresence)
    assert count.inside == {"a": (), "b": (1, 4)}  # c is not counted by x


@pytest.mark.parametrize("n", [3, 4])
def test_the_entries_are_those_the_monitor_counts(n: int) -> None:
    problem = _problem({"t": {"formula": f"visits[0,5](C, x) >= {n}"}})
    trajectory = walk(PATHS)
    (visits,) = team_events(problem, trajectory, problem.tasks[0].formula)
    assert isinstance(visits, VisitEntries)
    assert check(problem, trajectory).verdict("t").satisfied == (len(visits.entries) >= n)


# -------------------------------------------------------------------------------- timeline.png
def _stars_on_row(ax, row: int) -> list[float]:
    """The steps of the visit stars drawn on the agent's row ``row``."""
    return sorted(
        float(x)
        for line in ax.get_lines()
        if isinstance(line, Line2D) and line.get_marker() == "*"
        for x, y in zip(line.get_xdata(), line.get_ydata(), strict=True)
        if abs(y - row) < 0.5
    )


def test_the_timeline_marks_the_steps_counted_inside_and_each_visit(plan) -> None:
    problem, trajectory, report = plan
    fig = timeline_figure(problem, trajectory, report)
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert {"reach_C", "in R (count_R)", "visit to C (visit_C)"} <= set(labels)
    assert "visit_C" not in labels and "count_R" not in labels  # no bars of their own
    ax = fig.axes[0]
    ticks = zip(ax.get_yticks(), ax.get_yticklabels(), strict=True)
    rows = {label.get_text().split(" ")[0]: y for y, label in ticks}  # "b (x)" -> its row
    assert _stars_on_row(ax, rows["b"]) == [2, 5]
    assert _stars_on_row(ax, rows["a"]) == [0]
    assert _stars_on_row(ax, rows["c"]) == []
    face = region_colors(problem)["R"][0]
    bands = [
        p.get_x() + p.get_width() / 2
        for p in ax.patches
        if isinstance(p, Rectangle) and np.allclose(p.get_facecolor(), to_rgba(face))
    ]
    assert sorted(bands) == pytest.approx([1, 4])
    assert {"1", "2", "3"} <= {t.get_text() for t in ax.texts}  # the visits, numbered


def test_the_map_marks_where_each_visit_enters(plan) -> None:
    problem, trajectory, report = plan
    fig = plan_figure(problem, trajectory, report)
    ax = fig.axes[0]
    assert "visit to C (visit_C)" in [t.get_text() for t in ax.get_legend().get_texts()]
    (stars,) = [line for line in ax.get_lines() if line.get_marker() == "*"]
    assert np.allclose(np.column_stack(stars.get_data()), [(7.5, 6.5), (7, 7), (7, 7)])
    texts = [t.get_text() for t in ax.texts]
    assert "\u00d72" in texts  # b's two visits at one place
    assert "visit_C: 3 visits to C in steps 0-5 (a at 0; b at 2, 5)" in texts
    assert "count_R: x agents in R: b at steps 1, 4" in texts


def test_the_figures_of_a_plan_with_visits_are_written(plan, tmp_path: Path) -> None:
    problem, trajectory, report = plan
    for name, draw in (("timeline.png", plot_timeline), ("plan.png", plot_plan)):
        draw(problem, trajectory, report, tmp_path / name)
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# ----------------------------------------------------------------------------------- plan.html
def test_the_viewer_marks_each_visit_on_the_map_and_the_timeline(plan) -> None:
    problem, trajectory, report = plan
    fig = viewer_figure(problem, trajectory, report)
    found = [t for t in fig.data if t.name == "visit to C (visit_C)"]
    on_map = next(t for t in found if t.legend is None)
    on_timeline = next(t for t in found if t.legend == "legend2")
    assert np.allclose(np.column_stack([on_map.x, on_map.y]), [(7.5, 6.5), (7, 7), (7, 7)])
    assert sorted(on_timeline.x) == [0, 2, 5] and sorted(on_timeline.text) == ["1", "2", "3"]
    assert any(t.name == "in R (count_R)" and t.legend == "legend2" for t in fig.data)
    assert "visit_C: 3 visits to C in steps 0-5 (a at 0; b at 2, 5)" in (
        fig.layout.title.subtitle.text
    )
    hover = hover_texts(problem, trajectory, report)
    assert "enters: visit 3 of 3 to C (visit_C)" in hover["b"][5]
    assert "in R, counted by count_R" in hover["b"][1]
    assert "counted" not in hover["b"][0] and "enters" not in hover["b"][0]


def test_the_page_shows_the_visits(browser: Any, plan, tmp_path: Path) -> None:
    problem, trajectory, report = plan
    write_viewer(problem, trajectory, report, tmp_path / "plan.html")
    page = Page(browser, tmp_path / "plan.html")
    try:
        drawn = page.js(
            "return gd._fullData.map((t, i) => [t.name, t.visible, gd.calcdata[i].length])"
            ".filter(([name]) => name === 'visit to C (visit_C)');"
        )
        legends = page.js(
            "return ['legendtext', 'legend2text'].map("
            "c => [...gd.querySelectorAll('text.' + c)].map(t => t.textContent));"
        )
        subtitle = page.js("return gd.querySelector('.gtitle-subtitle')?.textContent ?? '';")
    finally:
        page.close()
    assert page.errors == []
    assert drawn == [["visit to C (visit_C)", True, 3]] * 2  # on the map and on the timeline
    on_map, on_timeline = legends  # the agents' legend, the tasks' legend
    assert "visit to C (visit_C)" in on_map
    assert {"visit to C (visit_C)", "in R (count_R)"} <= set(on_timeline)
    assert "3 visits to C in steps 0-5" in subtitle
