"""A run that ends without a plan says which part failed, in which stage, and how far it got."""

from __future__ import annotations

import threading
import time

import pytest

from stlplan.mission.loader import load_problem
from stlplan.planner.config import PlannerConfig
from stlplan.planner.core.completion import added_in_time
from stlplan.planner.core.finish import Finish
from stlplan.planner.encoding.model import build_model
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.clock import Clock
from stlplan.planner.run.outcome import Outcome
from stlplan.planner.run.reached import Reached
from stlplan.planner.solve import run_events, step1_message
from stlplan.result import PlanStatus
from stlplan.words import agent_names
from tests.helpers.paths import MISSIONS

CROWD = tuple(f"a{i:02d}" for i in range(1, 17))


@pytest.mark.parametrize(
    ("agents", "words"),
    [
        (CROWD, "16 agents a01..a16"),
        (CROWD[3:9], "6 agents a04..a09"),
        (("a01", "a03", "a07", "a08"), "4 agents a01, a03, a07, ..."),
        (("a16", "a01", "a02", "a03"), "4 agents a16, a01, a02, ..."),
        (("a05", "a02"), "a05, a02"),
    ],
)
def test_a_part_is_named_in_a_few_words(agents: tuple[str, ...], words: str) -> None:
    assert agent_names(agents, CROWD) == words


def _crowd_merged() -> Reached:
    """The 16-agent crowd as the parts strategy reports it: 16 one-agent parts planned, their
    plans collide, the merged part's repairs fail, its own rounds run out of time."""
    reached = Reached(order=CROWD, parts=16)
    for name in CROWD:
        reached.solving([name])
        reached.round_done(5)
        reached.planned += 1
    reached.merges += 1
    reached.solving(CROWD, merged_from=16)
    with reached.within("repair in turn"):
        reached.turns(0, 16)
        reached.turns(14, 16)
        reached.failed("repair in turn")
    with reached.within("held repair"):
        reached.round_done(1_600)
        reached.failed("held repair")
    reached.round_done(1_674)
    return reached


def test_a_merged_part_that_ends_without_a_plan_says_what_it_tried() -> None:
    assert _crowd_merged().describe() == (
        "the part of 16 agents a01..a16 (merged from 16 parts whose plans collided) was in its "
        "own lazy rounds after 2 lazy rounds (1,674 requirements added); before that, no plan "
        "from the repair in turn (14 of 16 agents repaired) and the held repair; 16 of 16 "
        "parts had planned on their own, then 1 merge"
    )


def test_a_team_solved_whole_says_how_far_its_completion_got() -> None:
    reached = Reached(order=CROWD)
    reached.solving(CROWD)
    for held in (0, 88, 165):
        reached.round_done(held)
    reached.enter("completion")
    reached.completing(500, 3_013)
    assert reached.describe() == (
        "the whole team was in the completion of the last round's plan (500 of 3,013 "
        "requirements left out added) after 3 lazy rounds (165 requirements added)"
    )


def test_a_part_of_its_own_that_fails_is_named_with_the_parts_planned() -> None:
    reached = Reached(order=CROWD, parts=3)
    for agents in (CROWD[:1], CROWD[1:2]):
        reached.solving(agents)
        reached.round_done(0)
        reached.planned += 1
    reached.solving(CROWD[2:])
    reached.round_done(12)
    assert reached.describe() == (
        "the part of 14 agents a03..a16 was in its own lazy rounds after 1 lazy round "
        "(12 requirements added); 2 of 3 parts had planned on their own"
    )


@pytest.mark.parametrize(
    "status", [PlanStatus.NO_PLAN, PlanStatus.INTERRUPTED_NO_PLAN, PlanStatus.ERROR]
)
def test_a_run_without_a_plan_says_how_far_it_got_among_its_events(status: PlanStatus) -> None:
    # the message is one short sentence; how far step 1 got is an event (--verbose, summary)
    clock = Clock(0.0, None, reached=_crowd_merged())
    ended = Outcome(status, None, None, None, 60.0, 2, 1_674, "maxTimeLimit")
    message = step1_message(ended, PlannerConfig(), clock)
    assert clock.reached.describe() not in message and len(message) < 140, message
    events = run_events(ended, Finish(), PlannerConfig(), clock, False)
    assert "step 1 ended without a plan: " + clock.reached.describe() in events


def test_a_plan_needs_no_account_of_how_far_step_one_got() -> None:
    clock = Clock(0.0, None, reached=_crowd_merged())
    ended = Outcome(PlanStatus.FEASIBLE, -7.0, -6.9, 0.01, 60.0, 2, 1_674, "maxTimeLimit")
    assert "merged" not in step1_message(ended, PlannerConfig(), clock)


def test_a_completion_loads_each_batch_and_stops_when_the_time_is_up(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # loading requirements into HiGHS is not bounded by its time limit: each batch is loaded
    # before the clock is read again, so a completion overruns its budget by one batch at most
    problem = load_problem(MISSIONS / "crowd" / "crowd-16.yaml")
    pm = build_model(problem, PlannerConfig().with_overrides({"model.floors": False}))
    pending = len(pm.pending())
    now = [0.0]
    loads: list[int] = []

    class Session:
        clock = Clock(0.0, None)

        def load_changes(self) -> None:
            loads.append(len(pm.added))
            now[0] += 5.0  # each batch takes 5 s to load

    monkeypatch.setattr(time, "perf_counter", lambda: now[0])
    session = Session()
    assert not added_in_time(pm, session, Budget(9.0, 9.0))  # type: ignore[arg-type]
    assert loads == [500, 1000] and pending > 1000
    assert session.clock.reached.progress == f"1,000 of {pending:,} requirements left out added"


def test_a_team_solved_up_front_names_its_one_solve() -> None:
    from stlplan.planner.solve import plan
    from tests.helpers.missions import swap_problem

    config = PlannerConfig().with_overrides({"lazy.enabled": False})
    result = plan(swap_problem(0.5, horizon=3, inter_sample=True), config)
    assert result.rounds == len(result.round_log) == 1
    assert result.round_log[0]["stage"] == "up front"
    reached = Reached(order=("a", "b"))
    reached.solving(["a", "b"])
    reached.enter("up front")
    reached.round_done(0)
    assert reached.describe() == (
        "the whole team was in its one solve, every requirement in the model"
    )


def test_parts_side_by_side_each_report_their_own_stage_and_rounds() -> None:
    # two threads, as parts solved side by side: one part in a repair in turn while the other
    # records its lazy rounds; each round is labelled with its own part's stage
    clock = Clock(0.0, None, reached=Reached(order=CROWD, parts=2))
    reached = clock.reached
    in_repair, recorded = threading.Event(), threading.Event()

    def first() -> None:
        reached.solving(CROWD[:8])
        with reached.within("repair in turn"):
            reached.turns(3, 8)
            in_repair.set()
            assert recorded.wait(10)
            clock.record_round(CROWD[:8], 1.0, "optimal", None, None, {"separation": 4})
            reached.failed("repair in turn")

    def second() -> None:
        reached.solving(CROWD[8:])
        assert in_repair.wait(10)
        clock.record_round(CROWD[8:], 1.0, "optimal", None, None, {"separation": 7})
        reached.planned += 1
        recorded.set()

    threads = [threading.Thread(target=first), threading.Thread(target=second)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    stages = {record["part"]: record["stage"] for record in clock.round_log}
    assert stages == {"8 agents a01..a08": "repair in turn", "8 agents a09..a16": "lazy rounds"}
    # the run's thread names the part that found no plan, as that part's thread left it
    reached.follow(CROWD[:8])
    assert reached.describe() == (
        "the part of 8 agents a01..a08 was in its own lazy rounds after 1 lazy round "
        "(4 requirements added); before that, no plan from the repair in turn (3 of 8 agents "
        "repaired); 1 of 2 parts had planned on their own"
    )


def test_a_part_solved_again_in_the_same_thread_starts_its_counts_again() -> None:
    reached = Reached(order=CROWD, parts=2)
    reached.solving(CROWD[:8])
    reached.round_done(5)
    reached.solving(CROWD[8:])
    reached.solving(CROWD[:8])  # (the tightening of a part's bound, after the other part)
    reached.round_done(6)
    assert "after 1 lazy round (6 requirements added)" in reached.describe()
