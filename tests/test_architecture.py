"""The package's import structure: no circles, the library never imports the CLI, private stays private.

Read from the source with ``ast`` (nothing is imported), so these run in milliseconds and
name the offending import when they fail.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "exudyn_study"


def _modules() -> dict[str, Path]:
    out = {}
    for path in PACKAGE.rglob("*.py"):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = path
    return out


MODULES = _modules()


def _package_of(module: str) -> str:
    return module if MODULES[module].name == "__init__.py" else module.rsplit(".", 1)[0]


def _imports(module: str):
    """(target module, imported name or None, line) for every exudyn_study import of ``module``."""
    tree = ast.parse(MODULES[module].read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                parts = _package_of(module).split(".")
                base = ".".join(parts[: len(parts) - node.level + 1])
                target = f"{base}.{node.module}" if node.module else base
            else:
                target = node.module or ""
            if target.startswith("exudyn_study"):
                for alias in node.names:
                    yield target, alias.name, node.lineno
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("exudyn_study"):
                    yield alias.name, None, node.lineno


def _edges() -> dict[str, set[str]]:
    edges: dict[str, set[str]] = {m: set() for m in MODULES}
    for module in MODULES:
        for target, name, _ in _imports(module):
            full = f"{target}.{name}" if name else target
            dep = full if full in MODULES else target
            if dep in MODULES and dep != module:
                edges[module].add(dep)
    return edges


def _cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(edges[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return out


def test_the_package_has_no_import_circle():
    assert _cycles(_edges()) == []


def test_the_cycle_finder_finds_a_circle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_the_library_never_imports_the_cli():
    offenders = [f"{m}:{line} imports {target}"
                 for m in MODULES if not m.startswith("exudyn_study.cli")
                 for target, name, line in _imports(m)
                 if target.startswith("exudyn_study.cli") or (target == "exudyn_study" and name == "cli")]
    assert offenders == []


def test_no_private_name_is_imported_from_another_package():
    offenders = []
    for module in MODULES:
        for target, name, line in _imports(module):
            if name and name.startswith("_") and not name.startswith("__"):
                source_package = target if target in MODULES and MODULES[target].name == "__init__.py" \
                    else target.rsplit(".", 1)[0]
                if not _package_of(module).startswith(source_package):
                    offenders.append(f"{module}:{line} imports {target}.{name}")
    assert offenders == []


@pytest.mark.parametrize(
    "heavy, allowed", [("ngsolve", "exudyn_study.bodies.fe"), ("netgen", "exudyn_study.bodies.fe")]
)
def test_only_the_fe_package_imports_ngsolve(heavy, allowed):
    offenders = []
    for module, path in MODULES.items():
        if module.startswith(allowed):
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else \
                [node.module or ""] if isinstance(node, ast.ImportFrom) else []
            offenders += [f"{module}:{node.lineno}" for n in names if n.split(".")[0] == heavy]
    assert offenders == []
