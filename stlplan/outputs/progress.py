"""A one-line live progress display for long solves."""

from __future__ import annotations

import sys
import time
from types import TracebackType
from typing import Any

from rich.console import Console
from rich.live import Live
from rich.text import Text

from stlplan.runtime import signals


class ProgressLine:
    """Shows phase, elapsed time, incumbent, bound and gap while the solver works."""

    def __init__(self, console: Console, enabled: bool = True) -> None:
        # The solver's wrapper swaps sys.stderr while HiGHS runs; write to the process's own stderr.
        self._console = Console(file=sys.__stderr__) if console.is_terminal else console
        self._enabled = enabled and console.is_terminal
        self._live: Live | None = None
        self._start = time.monotonic()

    def __enter__(self) -> ProgressLine:
        if self._enabled:
            self._live = Live(
                Text("building the model..."),
                console=self._console,
                refresh_per_second=4,
                transient=True,
            )
            self._live.__enter__()
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if self._live is not None:
            self._live.__exit__(kind, value, tb)

    def update(self, progress: Any) -> None:
        """Callback for :func:`stlplan.api.solve`: takes a ``Progress`` record."""
        if self._live is None:
            return
        parts = [str(getattr(progress, "phase", "solving"))]
        parts.append(f"{getattr(progress, 'elapsed', time.monotonic() - self._start):.1f} s")
        for name in ("incumbent", "bound"):
            value = getattr(progress, name, None)
            if value is not None:
                parts.append(f"{name} {value:.4g}")
        gap = getattr(progress, "gap", None)
        if gap is not None:
            parts.append(f"gap {100 * gap:.2f}%")
        if signals.requested():
            parts.append("stopping: keeping the best plan so far (press Ctrl-C again to abort)")
        self._live.update(Text(" | ".join(parts)))
