"""Writing a plan directory whole or not at all."""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path

from stlplan.errors import UsageError
from stlplan.planner import stops

Writer = Callable[[Path], None]


def prepare_directory(out: Path) -> None:
    """Create ``out`` (and parents) or fail with a clear message before any work is done."""
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(
            f"cannot create the output directory: {exc.strerror or exc}", source=str(out)
        ) from None
    if not os.access(out, os.W_OK):
        raise UsageError("the output directory is not writable", source=str(out))


def write_json(data: object, path: Path) -> None:
    """Write ``data`` as indented JSON."""
    path.write_text(json.dumps(data, indent=2, default=_plain) + "\n", encoding="utf-8")


def _plain(value: object) -> object:
    if hasattr(value, "tolist"):
        return value.tolist()  # numpy scalars and arrays
    return str(value)


def write_all(out: Path, files: dict[str, Writer]) -> list[Path]:
    """Write every file into a staging folder inside ``out``, then move them in place.

    A reader of ``out`` sees either the previous files or the complete new set of each name,
    never a partial file; if any writer fails, nothing is moved and the staging folder is removed.
    """
    prepare_directory(out)
    staging = Path(tempfile.mkdtemp(prefix=".stlplan-", dir=out))
    try:
        for name, write in files.items():
            write(staging / name)
        written = []
        with stops.held():  # a stop request waits until every file is in place
            for name in files:
                os.replace(staging / name, out / name)
                written.append(out / name)
        return written
    finally:
        shutil.rmtree(staging, ignore_errors=True)
