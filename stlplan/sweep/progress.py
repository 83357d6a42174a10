"""Terminal display of a sweep (or a simulation): a progress bar with counts and ETA, and the
final table."""

from __future__ import annotations

from collections.abc import Sequence
from types import TracebackType
from typing import Any

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn
from rich.table import Table

from stlplan.sweep.report import COLUMNS


class SweepProgress:
    """A rich progress bar advanced once per finished run, headed ``label``."""

    def __init__(self, console: Console, enabled: bool = True, label: str = "sweep") -> None:
        self._label = label
        self._progress = Progress(
            TextColumn(label),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("{task.fields[last]}"),
            TimeRemainingColumn(),
            console=console,
            transient=False,
            disable=not enabled,
        )
        self._task: Any = None

    def __enter__(self) -> SweepProgress:
        self._progress.__enter__()
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self._progress.__exit__(kind, value, tb)

    def start(self, total: int) -> None:
        """Set the number of runs to do."""
        self._task = self._progress.add_task(self._label, total=total, last="")

    def advance(self, record: dict[str, Any]) -> None:
        """One run finished."""
        if self._task is not None:
            last = f"{record['mission']} #{record['run']}: {record['status']}"
            self._progress.update(self._task, advance=1, last=last)


def print_table(
    console: Console,
    rows: list[dict[str, Any]],
    columns: Sequence[str] = COLUMNS,
    title: str = "Sweep summary (build + solve seconds)",
) -> None:
    """The summary table (a sweep's times are build + solve seconds)."""
    table = Table(title=title, title_justify="left")
    for column in columns:
        table.add_column(column)
    for row in rows:
        table.add_row(*("-" if row[c] is None else str(row[c]) for c in columns))
    console.print(table)
