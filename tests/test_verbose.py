"""A successful solve prints its status, figures and the monitor's table; what happened on the
way (lazy rounds, confirmations, retries) goes to summary.json, and to the terminal only with
--verbose."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from stlplan.cli import app
from tests.helpers.paths import MISSIONS

WAREHOUSE = MISSIONS / "warehouse.yaml"


def _solve(out: Path, *extra: str) -> str:
    args = ["solve", str(WAREHOUSE), "--out", str(out), "--no-animation", "--no-html", *extra]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    return result.output


@pytest.fixture(scope="module")
def plain(tmp_path_factory: pytest.TempPathFactory) -> tuple[str, dict[str, Any]]:
    """The warehouse solved once without --verbose (the tests only read it): what the command
    printed and its summary.json."""
    out = tmp_path_factory.mktemp("plain") / "out"
    printed = _solve(out)
    return printed, json.loads((out / "summary.json").read_text())


@pytest.mark.heavy
def test_the_internal_events_go_to_the_summary_and_verbose(
    tmp_path: Path, plain: tuple[str, dict[str, Any]]
) -> None:
    plain_output, summary = plain
    assert summary["rounds"] > 1 and summary["requirements_added"] > 0
    assert any("lazy rounds" in event for event in summary["events"])
    assert "lazy rounds" not in plain_output and "infeasible" not in plain_output
    assert plain_output.splitlines()[0].startswith("status     optimal: optimal plan;")
    verbose = _solve(tmp_path / "verbose", "--verbose")
    events = [line for line in verbose.splitlines() if line.startswith("run ")]
    assert events and "lazy rounds" in events[0]


def test_the_summary_logs_every_lazy_round(plain: tuple[str, dict[str, Any]]) -> None:
    _, summary = plain
    log = summary["round_log"]
    assert len(log) == summary["rounds"] > 1
    assert [r["round"] for r in log] == list(range(1, len(log) + 1))
    assert [r["at"] for r in log] == sorted(r["at"] for r in log)
    assert all(r["seconds"] >= 0 and r["ended"] for r in log)
    # the forklift and the drone apart, then together (their plans collide), held near them
    assert [r["part"] for r in log if r["stage"] == "held repair"][-1] == "forklift, drone"
    assert {r["stage"] for r in log} == {"lazy rounds", "held repair"}
    kinds = {kind for r in log for kind in r["held"]}
    assert kinds <= {
        "separation step",
        "separation segment",
        "constraint step",
        "constraint segment",
    }
    # the merged part, the only one at the end, holds what its last round held
    assert sum(log[-1]["held"].values()) == summary["requirements_added"] > 0
    assert summary["requirements_completed"] == 0
    assert log[-1]["best"] is None or log[-1]["best"] <= summary["bound"] + 1e-6
