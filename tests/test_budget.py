"""One time budget: the time limit bounds the whole run, building included."""

from __future__ import annotations

import json
import time
from pathlib import Path

from stlplan import api
from stlplan.api import Overrides
from stlplan.result import PlanStatus
from tests.helpers.paths import MISSIONS


def _long_mission(tmp_path: Path, horizon: int) -> Path:
    text = (MISSIONS / "reach-avoid.yaml").read_text(encoding="utf-8")
    text = text.replace("horizon: 12", f"horizon: {horizon}")
    text = text.replace("F[0,12]", f"F[0,{horizon}]").replace("G[0,12]", f"G[0,{horizon}]")
    path = tmp_path / "long.yaml"
    path.write_text(text, encoding="utf-8")
    return path


def test_a_small_time_limit_bounds_a_long_horizon_run(tmp_path: Path) -> None:
    mission = _long_mission(tmp_path, 600)  # unbounded, its effort floors alone take a minute
    limit = 4.0
    tick = time.perf_counter()
    result = api.solve(
        mission, out=tmp_path / "out", overrides=Overrides(time_limit=limit, threads=1)
    )
    wall = time.perf_counter() - tick
    assert wall < limit + 4.0, wall  # the grace of finishing solves, loading, writing
    assert result.status in (PlanStatus.NO_PLAN, PlanStatus.FEASIBLE, PlanStatus.OPTIMAL)
    if result.status is PlanStatus.NO_PLAN:
        assert "time limit" in result.message
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert 0.2 < summary["build_seconds"] < wall  # measured, not left at 0
    assert summary["build_seconds"] + summary["solve_seconds"] <= wall
