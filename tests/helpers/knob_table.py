"""The knob table of docs/planner.md, generated from the code: each knob's default, the modules
that read or set it, and its docstring.

``python -m tests.helpers.knob_table`` writes the table into docs/planner.md;
``tests/test_config.py`` checks that the page holds the table the code gives.
"""

from __future__ import annotations

import ast
import sys
from collections import defaultdict

from stlplan.planner.config import PlannerConfig, knob_docs
from tests.helpers.paths import ROOT

PACKAGE = ROOT / "stlplan"
PAGE = ROOT / "docs" / "planner.md"
HEADER = "| knob | default | acts in | what it does |"
SKIPPED = {"planner/config.py", "bench.py"}
"""Where the knobs are declared, and the benchmark's formulations (not where they act)."""


def _knobs() -> set[tuple[str, str]]:
    return {tuple(name.split(".", 1)) for name, *_ in knob_docs()}  # type: ignore[misc]


def _aliases(tree: ast.AST) -> dict[str, str]:
    """Names that stand for a section in a module: ``m = config.model``, ``settings: Budget...``
    (a parameter annotated with the section's class)."""
    classes = {
        field.annotation.__name__: section
        for section, field in PlannerConfig.model_fields.items()
        if isinstance(field.annotation, type)
    }
    out = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Assign):
            for target in node.targets:
                pairs = [(target, node.value)]
                if isinstance(target, ast.Tuple) and isinstance(node.value, ast.Tuple):
                    pairs = list(zip(target.elts, node.value.elts, strict=False))
                for name, value in pairs:
                    if not (isinstance(name, ast.Name) and isinstance(value, ast.Attribute)):
                        continue
                    if value.attr in PlannerConfig.model_fields:
                        out[name.id] = value.attr
        if isinstance(node, ast.arg) and node.annotation is not None:
            named = ast.unparse(node.annotation).split(" | ")[0].strip("'\"")
            if named in classes:
                out[node.arg] = classes[named]
    return out


def _read(node: ast.AST, knobs: set[tuple[str, str]], aliases: dict[str, str]) -> str | None:
    """The knob ``node`` reads (``<...>.section.name``, ``section.name``, or through a name that
    stands for the section) or names in a dotted string (``"section.name"``, an override)."""
    if isinstance(node, ast.Attribute):
        value = node.value
        section = value.attr if isinstance(value, ast.Attribute) else getattr(value, "id", None)
        section = aliases.get(section or "", section)
        if (section, node.attr) in knobs:
            return f"{section}.{node.attr}"
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        parts = tuple(node.value.split(".", 1))
        if len(parts) == 2 and parts in knobs:
            return node.value
    return None


def readers() -> dict[str, list[str]]:
    """The modules (paths under ``stlplan/``) that read or set each knob."""
    knobs, found = _knobs(), defaultdict(set)
    for path in sorted(PACKAGE.rglob("*.py")):
        where = path.relative_to(PACKAGE).as_posix()
        if where in SKIPPED:
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        aliases = _aliases(tree)
        for node in ast.walk(tree):
            knob = _read(node, knobs, aliases)
            if knob is not None:
                found[knob].add(where)
    return {knob: sorted(modules) for knob, modules in found.items()}


def table() -> str:
    """The knob table, a row per knob in the tree's order."""
    acting = readers()
    rows = [HEADER, "|---|---|---|---|"]
    for name, _, default, doc in knob_docs():
        where = ", ".join(acting.get(name, [])) or "(none)"
        text = " ".join(doc.split())
        rows.append(f"| `{name}` | `{default!r}` | {where} | {text} |")
    return "\n".join(rows) + "\n"


def page_table(page: str) -> str:
    """The knob table as the page holds it."""
    start = page.index(HEADER)
    end = page.find("\n\n", start)
    return page[start:] if end < 0 else page[start : end + 1]


def main() -> int:
    page = PAGE.read_text(encoding="utf-8")
    PAGE.write_text(page.replace(page_table(page), table()), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
