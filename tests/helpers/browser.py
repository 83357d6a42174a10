"""plan.html in a real browser: Debian's chromium, headless, driven by Playwright."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]
"""The browser the page tests open (skipped where it is not installed)."""


class Page:
    """plan.html open in the browser, with every console error and request it made."""

    def __init__(self, browser: Any, path: Path) -> None:
        self.errors: list[str] = []
        self.requests: list[str] = []
        self.page = browser.new_page(viewport={"width": 1400, "height": 800})
        self.page.on("console", lambda m: m.type == "error" and self.errors.append(m.text))
        self.page.on("pageerror", lambda e: self.errors.append(str(e)))
        self.page.on("request", lambda r: self.requests.append(r.url))
        self.page.goto(path.as_uri())
        self.page.wait_for_function("() => document.getElementById('plan')?._fullLayout")

    def js(self, body: str) -> Any:
        """The value of ``body``, a function body with ``gd`` the plot's element."""
        return self.page.evaluate(f"() => {{ const gd = document.getElementById('plan'); {body} }}")

    def markers(self) -> dict[str, tuple[float, float]]:
        """Where each agent's marker is: the traces the frames move, as the page holds them."""
        found = self.js(
            "const moving = gd._transitionData._frames[0].traces;"
            "return moving.map(i => [gd._fullData[i].name, gd._fullData[i].x[0], gd._fullData[i].y[0]]);"
        )
        return {name: (x, y) for name, x, y in found}

    def fills_drawn(self) -> int:
        """How many filled shapes the page draws: the regions, the bars, the runs."""
        return self.js(
            "return [...gd.querySelectorAll('path.js-fill')].filter(p => p.getAttribute('d')).length;"
        )

    def slider_active(self) -> int:
        return self.js("return gd._fullLayout.sliders[0].active;")

    def click_slider(self, k: int) -> None:
        """A click on the slider's rail above the label of step ``k``."""
        label = self.page.locator(".slider-label", has_text=re.compile(rf"^{k}$")).bounding_box()
        rail = self.page.locator(".slider-rail-touch-rect").bounding_box()
        assert label is not None and rail is not None
        self.page.mouse.click(label["x"] + label["width"] / 2, rail["y"] + rail["height"] / 2)

    def close(self) -> None:
        self.page.close()
