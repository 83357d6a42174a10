"""Jobs sharing the time left: one after another, or side by side on the run's threads.

The parts' first solves (:mod:`stlplan.planner.core.components`) share the time left but a reserve.
Each takes its share when it starts, so what one leaves goes to the next. With ``w`` workers,
``w`` jobs run at the same time, each in a thread of its own (HiGHS releases Python's lock while
it solves, so two solves use two cores). A job starting while ``n`` jobs are not done (itself,
those waiting and those running) gets ``w / n`` of the time left to the reserve, all of it at
most; with one worker that is an equal share of what is left, as one after another.

A stop request ends the loop before the next job. An error in a job stops the others from
starting and is raised once the running ones end.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import Generic, TypeVar

from stlplan.planner.config import PlannerConfig
from stlplan.planner.run.budget import Budget
from stlplan.runtime import signals

Job = TypeVar("Job")
Result = TypeVar("Result")


def part_workers(config: PlannerConfig) -> int:
    """Parts solved at the same time: ``parts.side_by_side``, else the solver's threads (one in
    a deterministic run)."""
    if config.solver.deterministic:
        return 1
    return config.parts.side_by_side or config.solver.threads or 1


def in_shares(
    jobs: Sequence[Job],
    run: Callable[[Job, Budget], Result],
    budget: Budget,
    reserve: float = 0.0,
    workers: int = 1,
) -> list[Result | None]:
    """``run(job, share)`` of every job, in order, ``workers`` at a time, each within its share
    of ``budget`` but ``reserve`` of the time left now (module docstring); None for a job not
    run (a stop request)."""
    queue: _Queue[Job, Result] = _Queue(list(jobs), budget, reserve, max(1, workers))
    if queue.workers == 1 or len(jobs) < 2:  # here, one after another
        while (taken := queue.take()) is not None:
            index, job, share = taken
            queue.results[index] = run(job, share)
            queue.running -= 1
        return queue.results
    threads = min(queue.workers, len(jobs))
    with ThreadPoolExecutor(threads, "stlplan-part") as pool:
        futures = [pool.submit(queue.work, run) for _ in range(threads)]
    for future in futures:
        future.result()
    return queue.results


class _Queue(Generic[Job, Result]):
    """The jobs not started, how many are running, and the results of those done."""

    def __init__(self, jobs: list[Job], budget: Budget, reserve: float, workers: int) -> None:
        self.jobs, self.budget, self.workers = jobs, budget, workers
        self.end = budget.deadline - reserve * max(0.0, budget.remaining())
        """When the jobs' time ends: the reserve of the time left now is kept."""
        self.results: list[Result | None] = [None] * len(jobs)
        self.started = 0
        self.running = 0
        self.failed = False
        self.lock = threading.Lock()

    def take(self) -> tuple[int, Job, Budget] | None:
        """The next job, its index and its share (None: none left, a stop request, or a job
        failed)."""
        with self.lock:
            if self.started == len(self.jobs) or self.failed or signals.requested():
                return None
            index, self.started = self.started, self.started + 1
            unfinished = len(self.jobs) - self.started + self.running + 1
            self.running += 1
            now = time.perf_counter()
            share = max(0.0, self.end - now) * min(1.0, self.workers / unfinished)
            return index, self.jobs[index], self.budget.until(now + share)

    def work(self, run: Callable[[Job, Budget], Result]) -> None:
        """Run jobs until none is left (a worker's thread)."""
        while (taken := self.take()) is not None:
            index, job, share = taken
            try:
                self.results[index] = run(job, share)
            except BaseException:
                self.failed = True
                raise
            finally:
                with self.lock:
                    self.running -= 1
