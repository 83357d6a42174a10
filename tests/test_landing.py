"""Step 2 landed by an LP: when the landed plan counts as step 2 done."""

from __future__ import annotations

import pytest

from stlplan.planner.core.finish import effort_kept
from stlplan.planner.encoding.model import build_model
from tests.helpers.configs import paper_model
from tests.helpers.missions import mission


def _model(effort: str):  # type: ignore[no-untyped-def]
    problem = mission(
        horizon=2,
        agents=[{"name": "a", "dynamics": "si", "initial_state": [0, 0]}],
        regions={"R": {"box": [[0.5, 1.5], [-0.5, 0.5]]}},
        tasks={"reach": {"formula": "F[2,2] in(p, R)", "roles": {"p": {"agent": "a"}}}},
        objective={"beta": 1.0, "effort": effort},
    )
    return build_model(
        problem,
        paper_model(lazy__enabled=True, model__encoding="standard"),
    )


@pytest.mark.parametrize(
    ("landed", "kept"),
    [(0.5, True), (0.5 + 1e-6, True), (0.5 + 1e-3, False)],
)
def test_a_landing_within_the_gap_of_the_qp_point_completes_step_2(
    landed: float, kept: bool
) -> None:
    # HiGHS's point: u = 0.5 along x at both steps (sum u^2 = 0.5); the landed plan moves the
    # first input to ``landed``
    pm = _model("l2")
    target = {key: (0.5 if key[2] == 0 else 0.0) for key in pm.model.u}
    for key, u in pm.model.u.items():
        u.set_value(target[key])
    pm.model.u["a", 0, 0].set_value(landed)
    assert effort_kept(pm, target, gap=1e-4) is kept


def test_only_the_l2_effort_is_judged_by_its_value() -> None:
    pm = _model("l1")
    target = {key: 0.0 for key in pm.model.u}
    for u in pm.model.u.values():
        u.set_value(0.0)
    assert not effort_kept(pm, target, gap=1e-4)
