"""The package's layers: no import circles, and every import points down the layers."""

from __future__ import annotations

import ast
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

from tests.helpers.paths import ROOT

PACKAGE = ROOT / "stlplan"

LAYERS = (
    (
        "stlplan.errors",
        "stlplan.words",
        "stlplan.result",
        "stlplan.runtime",
        "stlplan.native_output",
    ),
    ("stlplan.formula",),
    ("stlplan.mission", "stlplan.examples"),
    (
        "stlplan.monitor",
        "stlplan.analysis",
        "stlplan.planner.config",
        "stlplan.planner.run.budget",
        "stlplan.planner.tolerances",
    ),
    ("stlplan.planner.encoding",),
    ("stlplan.planner.run",),
    ("stlplan.planner.backend",),
    ("stlplan.planner.core",),
    ("stlplan.planner.first_plan",),
    ("stlplan.planner",),
    (
        "stlplan.verify",
        "stlplan.degraded",
        "stlplan.pipeline",
        "stlplan.replanning",
        "stlplan.shifted",
        "stlplan.deadline",
        "stlplan.online",
    ),
    ("stlplan.outputs",),
    ("stlplan.sweep",),
    ("stlplan.simulation",),
    ("stlplan.api",),
    ("stlplan.bench", "stlplan.crowd", "stlplan.cli", "stlplan.__main__", "stlplan"),
)
"""From the bottom up: a module may import its own layer's modules and those below."""


def _modules() -> dict[str, Path]:
    out = {}
    for path in PACKAGE.rglob("*.py"):
        parts = path.relative_to(ROOT).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = path
    return out


def _imported(name: str, path: Path, known: dict[str, Path]) -> Iterator[str]:
    """The package's modules ``name`` imports, at module level or inside functions."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(up + ([base] if base else []))
            targets = [f"{base}.{alias.name}" for alias in node.names] + [base]
        else:
            continue
        for target in targets:
            while target and target not in known:
                target = target.rpartition(".")[0]
            if target.startswith("stlplan") and target != name:
                yield target


def _graph() -> dict[str, set[str]]:
    known = _modules()
    return {name: set(_imported(name, path, known)) for name, path in known.items()}


def _layer(name: str) -> int:
    best = max(
        ((len(prefix), i) for i, layer in enumerate(LAYERS) for prefix in layer
         if name == prefix or name.startswith(prefix + ".")),
        default=None,
    )  # fmt: skip
    assert best is not None, f"{name} is in no layer"
    return best[1]


def test_every_import_points_down_the_layers() -> None:
    upward = [
        f"{name} -> {target}"
        for name, targets in _graph().items()
        for target in targets
        if _layer(target) > _layer(name)
    ]
    assert not upward


def test_no_module_imports_itself_through_others() -> None:
    graph, circles = _graph(), []
    for start in graph:
        seen, stack = set(), list(graph[start])
        while stack:
            name = stack.pop()
            if name == start:
                circles.append(start)
                break
            if name not in seen:
                seen.add(name)
                stack.extend(graph.get(name, ()))
    assert not circles


def test_the_api_loads_no_solver() -> None:
    code = "import sys, stlplan.api; print(sorted({'pyomo', 'highspy'} & set(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def _private_uses(path: Path) -> Iterator[str]:
    """The project's private names a test file imports, reads or patches by name."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    project = {alias.asname or alias.name.split(".")[-1] for node in ast.walk(tree)
               if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("stlplan")
               for alias in node.names}  # fmt: skip
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("stlplan"):
            yield from (a.name for a in node.names if _private(a.name))
        elif isinstance(node, ast.Attribute) and _private(node.attr):
            root = node.value
            while isinstance(root, ast.Attribute):
                root = root.value
            if isinstance(root, ast.Name) and root.id in project:
                yield f"{root.id}...{node.attr}"
        elif isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "setattr":
            name = node.args[1] if len(node.args) > 1 else None
            if isinstance(name, ast.Constant) and isinstance(name.value, str):
                yield from [name.value] if _private(name.value) else []


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def test_no_test_reaches_into_private_names() -> None:
    found = {
        path.name: sorted(set(_private_uses(path)))
        for path in sorted((ROOT / "tests").glob("test_*.py"))
    }
    assert not {name: uses for name, uses in found.items() if uses}


def _any_parameters(path: Path) -> Iterator[str]:
    """The named parameters of ``path``'s functions typed ``Any`` (``*args`` and ``**kwargs``
    passed through are not counted)."""
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            arguments = node.args
            for arg in (*arguments.posonlyargs, *arguments.args, *arguments.kwonlyargs):
                if arg.annotation is not None and ast.unparse(arg.annotation) == "Any":
                    yield f"{path.name}:{node.lineno} {node.name}({arg.arg})"


def test_the_planners_parameters_name_their_types() -> None:
    """A parameter typed ``Any`` where a planner type is meant hides an import circle; the
    strategy code (the planner without its encoding) names every parameter's type."""
    planner = PACKAGE / "planner"
    found = [use for path in sorted(planner.rglob("*.py"))
             if "encoding" not in path.relative_to(planner).parts
             for use in _any_parameters(path)]  # fmt: skip
    assert not found
