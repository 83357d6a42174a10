"""The simulation benchmark: its rows are the simulations' own figures, its targets judged."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from stlplan import sim_bench
from stlplan.errors import EventError

MISSION = "missions/sync-pair.yaml"


def _records(folder: Path) -> list[dict[str, object]]:
    lines = (folder / "runs.jsonl").read_text(encoding="utf-8").splitlines()
    return [json.loads(line) for line in lines if line.strip()]


@pytest.mark.heavy
def test_each_row_counts_its_simulations_records(tmp_path: Path) -> None:
    sim_bench.main(
        ["--mission", MISSION, "--runs", "2", "--disturbance", "0.05", "--lose", "north@3",
         "--threads", "1", "--out", str(tmp_path)]
    )  # fmt: skip
    with (tmp_path / "simulation.csv").open(encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    chosen = sim_bench.configurations(["north@3"])
    assert [r["configuration"] for r in rows] == [c.name for c in chosen]
    for row, c in zip(rows, chosen, strict=True):
        records = _records(tmp_path / "targets" / "W0.05" / c.folder())
        assert len(records) == int(row["runs"]) == 2
        assert int(row["satisfied"]) == sum(1 for r in records if r["satisfied"])
        assert {r["replan"] for r in records} == {c.policy}
        assert {r["robust_to"] for r in records} == {0.05 if c.robust else 0.0}
        replans = sum(len(r["replan_seconds"]) for r in records)  # type: ignore[arg-type]
        assert int(row["replans"]) == replans
        smaller = sum(len(r["reduced_margins"]) for r in records)  # type: ignore[arg-type]
        assert int(row["smaller_margins"]) == smaller
        assert (replans == 0) == (c.policy == "never")
    text = (tmp_path / "simulation.md").read_text(encoding="utf-8")
    assert "| robust to 0.05 | optimal |" in text and "| nominal | optimal |" in text


def test_a_target_is_met_only_when_both_figures_meet_it() -> None:
    c = sim_bench.Configuration("x", "every", True, (), 0.95, 1.0)
    found = {"satisfied_fraction": 0.95, "replan_median_s": 1.0}
    assert c.met(found) is True
    assert c.met({**found, "satisfied_fraction": 0.9}) is False
    assert c.met({**found, "replan_median_s": 1.01}) is False
    assert c.met({**found, "replan_median_s": None}) is False
    assert sim_bench.Configuration("y", "never", False).met(found) is None


def test_a_deadline_target_asks_every_replan_to_answer_within_its_lateness() -> None:
    c = sim_bench.Configuration("x", "every", True, (), 0.95, deadline=1.0)
    assert c.target() == ">= 95% satisfied, max <= 1.2 s"
    assert c.folder() == "every-robust-deadline-1"
    found = {"satisfied_fraction": 0.95, "replan_median_s": 0.9, "replan_max_s": 1.2}
    assert c.met(found) is True
    assert c.met({**found, "replan_max_s": 1.21}) is False
    assert c.met({**found, "satisfied_fraction": 0.94}) is False


def test_an_unknown_agent_is_refused_before_anything_runs(tmp_path: Path) -> None:
    with pytest.raises(EventError, match="no such agent"):
        sim_bench.main(
            ["--mission", MISSION, "--runs", "1", "--lose", "r9@3", "--out", str(tmp_path)]
        )
    assert not any(tmp_path.iterdir())
