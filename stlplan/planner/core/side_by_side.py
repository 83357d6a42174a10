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


def part_workers(config: PlannerConfig) -> int:
    """Parts solved at the same time: ``parts.side_by_side``, else the solver's threads (one in
    a deterministic run)."""
    if config.solver.deterministic:
        return 1
    return config.parts.side_by_side or config.solver.threads or 1


def in_shares(
    jobs: Sequence[Job],
    run: Callable[[Job, Budget], None],
    budget: Budget,
    reserve: float = 0.0,
    workers: int = 1,
) -> None:
    """Run ``run(job, share)`` for every job, in order, ``workers`` at a time, each within its
    share of ``budget`` but ``reserve`` of the time left now (module docstring)."""
    queue: _Queue[Job] = _Queue(list(jobs), budget, reserve, max(1, workers))
    if queue.workers == 1 or len(jobs) < 2:
        queue.work(run)
        return
    threads = min(queue.workers, len(jobs))
    with ThreadPoolExecutor(threads, "stlplan-part") as pool:
        futures = [pool.submit(queue.work, run) for _ in range(threads)]
    for future in futures:
        future.result()


class _Queue(Generic[Job]):
    """The jobs not started, and how many are running."""

    def __init__(self, jobs: list[Job], budget: Budget, reserve: float, workers: int) -> None:
        self.jobs, self.budget, self.workers = jobs, budget, workers
        self.end = budget.deadline - reserve * max(0.0, budget.remaining())
        """When the jobs' time ends: the reserve of the time left now is kept."""
        self.running = 0
        self.failed = False
        self.lock = threading.Lock()

    def take(self) -> tuple[Job, Budget] | None:
        """The next job and its share (None: none left, a stop request, or a job failed)."""
        with self.lock:
            if not self.jobs or self.failed or signals.requested():
                return None
            job = self.jobs.pop(0)
            unfinished = len(self.jobs) + self.running + 1
            self.running += 1
            now = time.perf_counter()
            share = max(0.0, self.end - now) * min(1.0, self.workers / unfinished)
            return job, self.budget.until(now + share)

    def work(self, run: Callable[[Job, Budget], None]) -> None:
        """Run jobs until none is left."""
        while (taken := self.take()) is not None:
            job, share = taken
            try:
                run(job, share)
            except BaseException:
                self.failed = True
                raise
            finally:
                with self.lock:
                    self.running -= 1
