"""The online planner: inputs step by step, replanning from the executed history."""

from __future__ import annotations

import contextlib
import io
import re

import numpy as np
import pytest

from stlplan.mission.loader import load_problem
from stlplan.monitor.verdicts import check
from stlplan.online import OnlinePlanner
from stlplan.planner.overrides import Overrides
from stlplan.result import Trajectory
from tests.helpers.paths import PAIR, ROOT


def _execute(loop: OnlinePlanner, drift: float = 0.0, seed: int = 0) -> Trajectory:
    problem, rng = loop.problem, np.random.default_rng(seed)
    x = {a.name: a.initial_state.copy() for a in problem.agents}
    for k in range(problem.horizon + 1):
        step = loop.step(k, x)
        for a in problem.agents:
            if k < problem.horizon:
                noise = rng.uniform(-drift, drift, a.n) if drift else 0.0
                x[a.name] = a.A @ x[a.name] + a.B @ step.inputs[a.name] + noise
    return loop.history()


@pytest.fixture(scope="module")
def first():  # type: ignore[no-untyped-def]
    return OnlinePlanner(PAIR, overrides=Overrides(time_limit=60)).current


@pytest.mark.parametrize("policy", ["never", "on-deviation", "every"])
def test_without_drift_the_plan_is_executed_as_it_is(first, policy) -> None:  # type: ignore[no-untyped-def]
    loop = OnlinePlanner(PAIR, first, Overrides(time_limit=60), policy=policy)
    executed = _execute(loop)
    problem = loop.problem
    assert check(problem, executed).satisfied
    assert loop.replans == (problem.horizon - 1 if policy == "every" else 0)
    if policy != "every":
        for a in problem.agents:
            assert np.allclose(executed.states[a.name], first.trajectory.states[a.name], atol=1e-9)


def test_a_drift_is_replanned_from_and_the_history_kept(first) -> None:  # type: ignore[no-untyped-def]
    loop = OnlinePlanner(PAIR, first, Overrides(time_limit=60))
    executed = _execute(loop, drift=0.005, seed=3)
    assert loop.replans >= 1
    final = loop.current.trajectory
    assert final is not None
    for a in loop.problem.agents:  # the last plan keeps every executed state before its step
        assert np.isfinite(executed.states[a.name]).all()


def test_the_documented_example_runs() -> None:
    page = (ROOT / "docs" / "replanning.md").read_text(encoding="utf-8")
    code = re.findall(r"```python\n(.*?)```", page, re.S)[0]
    assert len(code.strip().splitlines()) <= 16
    out = io.StringIO()
    with contextlib.chdir(ROOT), contextlib.redirect_stdout(out):
        exec(compile(code, "docs/replanning.md", "exec"), {})
    replans, satisfied = out.getvalue().split()
    assert int(replans) >= 1 and satisfied == "True"


def test_a_lost_agent_gets_no_inputs_and_the_loop_replans(first) -> None:  # type: ignore[no-untyped-def]
    problem = load_problem(PAIR)
    loop = OnlinePlanner(problem, first, Overrides(time_limit=60))
    x = {a.name: first.trajectory.states[a.name][0] for a in problem.agents}
    loop.step(0, x)
    x = {a.name: first.trajectory.states[a.name][1] for a in problem.agents}
    lost = problem.agents[0].name
    step = loop.step(1, x, lost=[lost])
    assert step.replanned and np.all(step.inputs[lost] == 0)
    assert step.result.replan is not None and f"{lost} lost" in step.result.replan.events
