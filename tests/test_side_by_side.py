"""Jobs sharing the time left, one after another or side by side."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import pytest

from stlplan.planner.core.side_by_side import in_shares
from stlplan.planner.run.budget import Budget


def _budget(seconds: float) -> Budget:
    end = time.perf_counter() + seconds
    return Budget(end, end)


def test_two_workers_run_two_jobs_at_the_same_time() -> None:
    # each job waits for the other at a barrier: one after another, the first would time out
    meet = threading.Barrier(2, timeout=10.0)
    names: list[str] = []

    def run(job: str, share: Budget) -> None:
        meet.wait()
        names.append(threading.current_thread().name)

    in_shares(["a", "b"], run, _budget(100.0), workers=2)
    assert len(names) == 2 and len(set(names)) == 2


def test_one_worker_runs_the_jobs_in_order_in_equal_shares_of_what_is_left() -> None:
    shares: list[tuple[str, float]] = []

    def run(job: str, share: Budget) -> None:
        shares.append((job, share.remaining()))

    in_shares(["a", "b", "c", "d"], run, _budget(100.0), reserve=0.2, workers=1)
    assert [job for job, _ in shares] == ["a", "b", "c", "d"]
    # the jobs take no time: each gets a share of 80 s over the jobs left
    assert [s for _, s in shares] == pytest.approx([20.0, 80.0 / 3, 40.0, 80.0], abs=0.5)


def test_a_job_starting_beside_others_gets_its_workers_share_of_the_unfinished_jobs() -> None:
    started: dict[str, float] = {}
    first, second = threading.Event(), threading.Event()

    def run(job: str, share: Budget) -> None:
        started[job] = share.remaining()
        {"a": first, "b": second}.get(job, threading.Event()).wait(10.0 if job in "ab" else 0)

    worker = threading.Thread(
        target=in_shares, args=(["a", "b", "c", "d"], run, _budget(100.0), 0.0, 2)
    )
    worker.start()
    _wait_for(lambda: len(started) == 2)
    first.set()  # a ends while b runs
    _wait_for(lambda: len(started) == 4)
    second.set()
    worker.join(10.0)
    # a and b start with four jobs unfinished: half the time each; c starts with three (c, d,
    # b): two thirds of what is left; d with two (d, b): all of it
    assert started["a"] == pytest.approx(50.0, abs=0.5)
    assert started["b"] == pytest.approx(50.0, abs=0.5)
    assert started["c"] == pytest.approx(100.0 * 2 / 3, abs=0.5)
    assert started["d"] == pytest.approx(100.0, abs=0.5)


def _wait_for(condition: Callable[[], bool]) -> None:
    deadline = time.perf_counter() + 10.0
    while not condition() and time.perf_counter() < deadline:
        time.sleep(0.01)
    assert condition()


def test_an_error_in_a_job_stops_the_jobs_not_started_and_is_raised() -> None:
    ran: list[str] = []

    def run(job: str, share: Budget) -> None:
        ran.append(job)
        if job == "a":
            raise ValueError("broken part")
        time.sleep(0.2)  # the others take a while: the error comes first

    with pytest.raises(ValueError, match="broken part"):
        in_shares(["a", "b", "c", "d", "e"], run, _budget(100.0), workers=2)
    assert "a" in ran and len(ran) < 5
