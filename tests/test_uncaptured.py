"""The planner's solves leave the process's output streams alone."""

from __future__ import annotations

import contextlib
import sys
import threading

import pyomo.contrib.solver.solvers.highs as pyomo_highs

from stlplan.planner.backend import uncaptured
from stlplan.planner.config import PlannerConfig
from stlplan.planner.run.clock import Progress
from stlplan.planner.solve import plan
from tests.helpers.missions import swap_problem


def test_pyomos_capture_is_off_within_solves_in_this_thread_only() -> None:
    outside = pyomo_highs.capture_output()
    assert not isinstance(outside, contextlib.nullcontext)
    elsewhere: list[object] = []
    with uncaptured.solves():
        assert isinstance(pyomo_highs.capture_output(), contextlib.nullcontext)
        thread = threading.Thread(target=lambda: elsewhere.append(pyomo_highs.capture_output()))
        thread.start()
        thread.join()
    assert not isinstance(elsewhere[0], contextlib.nullcontext)
    assert not isinstance(pyomo_highs.capture_output(), contextlib.nullcontext)


def test_progress_reported_during_a_solve_sees_the_processs_own_streams() -> None:
    # the whole team's model reports each plan HiGHS finds from inside the solve
    streams: list[tuple[object, object]] = []

    def progress(report: Progress) -> None:
        if report.phase == "step1" and report.incumbent is not None:
            streams.append((sys.stdout, sys.stderr))

    out, err = sys.stdout, sys.stderr
    config = PlannerConfig().with_overrides({"parts.enabled": False, "solver.time_limit": 60.0})
    result = plan(swap_problem(0.5), config, progress=progress)
    assert result.status.has_plan
    assert streams and all(seen == (out, err) for seen in streams)
