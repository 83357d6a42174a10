"""Shared fixtures: paths to shipped missions, figure cleanup."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import matplotlib
import pytest
from hypothesis import settings

from tests.helpers.browser import CHROMIUM, CHROMIUM_ARGS
from tests.helpers.examples import PROFILE
from tests.helpers.paths import MISSIONS

matplotlib.use("Agg")

# Property tests draw the same examples on every run (no example database, no randomness), so a
# green suite stays green; STLPLAN_HYPOTHESIS=explore draws fresh examples to look for new bugs.
settings.register_profile("deterministic", derandomize=True, database=None)
settings.register_profile("explore", derandomize=False)
settings.load_profile(PROFILE)


@pytest.fixture(autouse=True)
def _close_figures() -> Iterator[None]:
    yield
    import matplotlib.pyplot as plt

    plt.close("all")


@pytest.fixture
def missions_dir() -> Path:
    """The folder of shipped missions."""
    return MISSIONS


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    """A headless chromium shared by a module's page tests."""
    if not CHROMIUM.exists():
        pytest.skip(f"no browser at {CHROMIUM} (apt-get install chromium)")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as driver:
        launched = driver.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
        yield launched
        launched.close()
