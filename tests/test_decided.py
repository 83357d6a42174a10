"""The upper bound of robustness over reachable boxes: exact on a trajectory, above it on boxes."""

from __future__ import annotations

import numpy as np
import pytest

from stlplan.analysis.decided import upper_robustness
from stlplan.mission.loader import load_problem
from stlplan.monitor.robustness import robustness
from tests.helpers.paths import MISSIONS

CASES = [MISSIONS / "farm.yaml", *sorted((MISSIONS / "stl").glob("*.yaml"))]


@pytest.mark.parametrize("path", CASES, ids=lambda p: p.stem)
def test_the_bound_is_the_robustness_on_a_point_and_above_it_on_a_box(path) -> None:  # type: ignore[no-untyped-def]
    problem = load_problem(path)
    rng = np.random.default_rng(0)
    H = problem.horizon
    states = {
        a.name: rng.uniform(a.state_lo, a.state_hi, size=(H + 1, a.n)) for a in problem.agents
    }
    for task in problem.tasks:
        for element in task.elements[:3]:
            binding = task.binding(element)
            formula = problem.lowered(task.formula, binding)
            signals = {role: states[name] for role, name in binding.items()}
            exact = robustness(formula, signals, H)
            points = {r: (x, x) for r, x in signals.items()}
            assert np.allclose(upper_robustness(formula, points, H), exact)
            wide = {r: (x - 0.3, x + 0.3) for r, x in signals.items()}
            assert np.all(upper_robustness(formula, wide, H) >= exact - 1e-12)
