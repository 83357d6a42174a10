"""Counted nouns: singular for one, plural otherwise."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from stlplan.cli import app
from stlplan.words import counted
from tests.helpers.paths import MISSIONS


@pytest.mark.parametrize(
    ("n", "expected"), [(0, "0 agents"), (1, "1 agent"), (2, "2 agents"), (31, "31 agents")]
)
def test_counted_is_singular_for_one_only(n: int, expected: str) -> None:
    assert counted(n, "agent") == expected


def test_counted_takes_an_irregular_plural() -> None:
    assert counted(1, "process", "processes") == "1 process"
    assert counted(3, "process", "processes") == "3 processes"


def test_validate_counts_one_agent_and_one_constraint_in_the_singular() -> None:
    found = CliRunner().invoke(app, ["validate", str(MISSIONS / "reach-avoid.yaml")])
    assert found.exit_code == 0, found.output
    assert "(1 agent, 0 tasks, 1 constraint; no tasks)" in found.stdout
