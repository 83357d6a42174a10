"""Shared fixtures: paths to shipped missions, figure cleanup."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import matplotlib
import pytest

matplotlib.use("Agg")

ROOT = Path(__file__).resolve().parent.parent
MISSIONS = ROOT / "missions"


@pytest.fixture(autouse=True)
def _close_figures() -> Iterator[None]:
    yield
    import matplotlib.pyplot as plt

    plt.close("all")


@pytest.fixture
def missions_dir() -> Path:
    """The folder of shipped missions."""
    return MISSIONS
