"""Paths to the shipped missions and to the tests' own files."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
"""The repository."""
MISSIONS = ROOT / "missions"
"""The shipped missions."""
PAIR = MISSIONS / "sync-pair.yaml"
"""The smallest shipped mission with a synchronous task: solved in about a second."""
FARM = MISSIONS / "farm.yaml"
"""The paper's Case I."""

TESTS = ROOT / "tests"
BROKEN = TESTS / "broken"
"""Broken missions, one mistake each (tests/test_checks.py)."""
BASE = BROKEN / "_base.yaml"
"""The valid mission every broken file is derived from."""
DATA = TESTS / "data"
"""Missions and models the tests read (tests/data/README.md)."""
