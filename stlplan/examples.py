"""The shipped missions and the mission JSON Schema, in a checkout or an installed wheel.

In the repository they live in ``missions/`` and ``schemas/``; a wheel carries the same files as
``stlplan/missions/`` and ``stlplan/schemas/`` (the build copies them, so there is one source).
An example written elsewhere gets its ``# yaml-language-server: $schema=`` line rewritten to
point at this installation's schema from where it is written.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import yaml

from stlplan.errors import UsageError, did_you_mean

PACKAGE = Path(__file__).resolve().parent
SCHEMA_LINE = "# yaml-language-server: $schema="


def _installed_or_checkout(packaged: Path, checkout: Path) -> Path:
    """``packaged`` (inside an installed wheel) if present, else ``checkout`` (the repository)."""
    for place in (packaged, checkout):
        if place.exists():
            return place
    raise UsageError(
        f"this installation of stlplan has neither {packaged} nor {checkout}; reinstall stlplan "
        "(the wheel carries the shipped missions and the schema)"
    )


def missions_dir() -> Path:
    """The folder of shipped missions."""
    return _installed_or_checkout(PACKAGE / "missions", PACKAGE.parent / "missions")


def schema_file() -> Path:
    """The mission JSON Schema shipped with stlplan."""
    name = "mission.schema.json"
    return _installed_or_checkout(PACKAGE / "schemas" / name, PACKAGE.parent / "schemas" / name)


@dataclass(frozen=True)
class Example:
    """A shipped mission."""

    name: str
    """The file's name without ``.yaml`` (unique among the shipped missions)."""
    description: str
    """The mission's ``description``, on one line (empty when it has none)."""
    path: Path
    file: str
    """Where it is among the shipped missions: ``farm.yaml``, ``stl/dwell.yaml``."""

    @property
    def summary(self) -> str:
        """The description's first sentence."""
        first, _, rest = self.description.partition(". ")
        return first + "." if rest else self.description


def _order(path: Path) -> tuple[int, str, str]:
    """The missions at the top first, then each folder's, by name."""
    return len(path.parts), path.parent.as_posix(), path.stem


def examples() -> list[Example]:
    """Every shipped mission, in ``missions/`` and its folders."""
    root = missions_dir()
    found = []
    for relative in sorted((p.relative_to(root) for p in root.rglob("*.yaml")), key=_order):
        path = root / relative
        data = yaml.safe_load(path.read_text(encoding="utf-8")) or {}
        text = " ".join(str(data.get("description", "")).split())
        found.append(Example(path.stem, text, path, relative.as_posix()))
    return found


def example(name: str) -> Example:
    """The shipped mission called ``name`` (``farm``, ``farm.yaml``, ``dwell``,
    ``stl/dwell.yaml``)."""
    shipped = examples()
    wanted = name.removesuffix(".yaml")
    for item in shipped:
        if wanted in (item.name, item.file.removesuffix(".yaml")):
            return item
    names = [e.name for e in shipped]
    raise UsageError(
        f"no shipped mission '{name}'{did_you_mean(wanted, names)}; shipped: {', '.join(names)}"
    )


def schema_pointer(target: Path | None) -> str:
    """Where a mission written to ``target`` finds the schema: a relative path inside the
    folder that holds the schema's folder (a checkout), else (or for stdout) the absolute one."""
    schema = schema_file()
    if target is None:
        return str(schema)
    folder = target.resolve().parent
    if not folder.is_relative_to(schema.parent.parent):
        return str(schema)
    return Path(os.path.relpath(schema, folder)).as_posix()


def example_text(name: str, target: Path | None = None) -> str:
    """The text of a shipped mission with its schema line made valid at ``target``."""
    lines = example(name).path.read_text(encoding="utf-8").splitlines(keepends=True)
    pointer = f"{SCHEMA_LINE}{schema_pointer(target)}\n"
    if lines and lines[0].startswith(SCHEMA_LINE):
        lines[0] = pointer
    else:
        lines.insert(0, pointer)
    return "".join(lines)
