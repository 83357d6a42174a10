"""Writing a plan directory whole or not at all."""

from __future__ import annotations

import json
import math
import os
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path

from stlplan.errors import UsageError
from stlplan.runtime import signals

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
    """Write ``data`` as indented, strict JSON: an infinite or undefined number is ``null``."""
    text = json.dumps(strict_json(data), indent=2, default=_plain, allow_nan=False)
    path.write_text(text + "\n", encoding="utf-8")


def write_text(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` in UTF-8."""
    path.write_text(text, encoding="utf-8")


def strict_json(data: object) -> object:
    """``data`` with every non-finite float (``inf``, ``nan``) replaced by None, recursively."""
    if isinstance(data, float):
        return data if math.isfinite(data) else None
    if isinstance(data, dict):
        return {k: strict_json(v) for k, v in data.items()}
    if isinstance(data, (list, tuple)):
        return [strict_json(v) for v in data]
    if hasattr(data, "tolist"):
        return strict_json(data.tolist())  # numpy scalars and arrays
    return data


def _plain(value: object) -> object:
    return str(value)


def write_all(out: Path, files: dict[str, Writer], owned: tuple[str, ...] = ()) -> list[Path]:
    """Write every file into a staging folder inside ``out``, then move them in place.

    A reader of ``out`` sees either the previous files or the complete new set of each name,
    never a partial file; if any writer fails, nothing is moved and the staging folder is removed.
    Files named in ``owned`` that this call does not write (an earlier run's) are removed, so the
    folder holds one run's outputs.
    """
    prepare_directory(out)
    staging = Path(tempfile.mkdtemp(prefix=".stlplan-", dir=out))
    try:
        for name, write in files.items():
            write(staging / name)
        written = []
        with signals.held():  # a stop request waits until every file is in place
            for name in files:
                os.replace(staging / name, out / name)
                written.append(out / name)
            for name in set(owned) - set(files):
                (out / name).unlink(missing_ok=True)
        return written
    finally:
        shutil.rmtree(staging, ignore_errors=True)
