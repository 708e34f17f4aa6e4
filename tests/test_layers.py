"""The package's layers: every module imports, no two modules import each other through a circle (the import
graph is read from the source, function-level imports included), and no function is longer than
MAX_FUNCTION_LINES."""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SOURCES = {"hertzian": ROOT / "ensemble", "hertzian.kernels": ROOT / "kernels"}
"""Where each package's modules live (``pyproject.toml``'s package-dir)."""
MAX_FUNCTION_LINES = 150
ALLOWED_CIRCLES: list[set[str]] = []
ALLOWED_LONG: set[tuple[str, str]] = set()
"""(module path under ensemble/, function name) allowed over MAX_FUNCTION_LINES."""


def module_files() -> dict[str, Path]:
    """Every module of the package: dotted name → source file (a package's name → its ``__init__.py``)."""
    modules = {}
    for package, folder in SOURCES.items():
        for path in sorted(folder.rglob("*.py")):
            parts = path.relative_to(folder).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            modules[".".join((package, *parts))] = path
    return modules


def runtime_nodes(tree: ast.AST):
    """Every node of ``tree`` except those under ``if TYPE_CHECKING:`` (imports for annotations only)."""
    for node in ast.iter_child_nodes(tree):
        if isinstance(node, ast.If) and isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING":
            yield from (n for child in node.orelse for n in [child, *runtime_nodes(child)])
            continue
        yield node
        yield from runtime_nodes(node)


def imported_modules(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """The package's modules that module ``name`` imports anywhere in its source (function level included)."""
    is_package = path.name == "__init__.py"
    found = set()
    for node in runtime_nodes(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = name.split(".")[: len(name.split(".")) - node.level + is_package]
                base = ".".join([*anchor, base] if base else anchor)
            # ``from a import b`` imports the module a.b when there is one, else a name of a
            targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else base for alias in node.names]
        else:
            continue
        found |= {target for target in targets if target in modules and target != name}
    return found


def import_graph() -> dict[str, set[str]]:
    modules = module_files()
    return {name: imported_modules(name, path, modules) for name, path in modules.items()}


def circles(graph: dict[str, set[str]]) -> list[set[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, edges = work[-1]
            child = next(edges, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = set()
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.add(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(component)
    return found


def test_circle_finder_finds_a_circle_and_only_circles():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a", "d"}, "d": set(), "e": {"d", "f"}, "f": {"e"}}
    assert sorted(sorted(c) for c in circles(graph)) == [["a", "b", "c"], ["e", "f"]]
    assert circles({"a": {"b"}, "b": {"c"}, "c": set()}) == []


def test_import_graph_reads_function_level_and_relative_imports(tmp_path):
    source = tmp_path / "module.py"
    source.write_text("def f():\n    from hertzian.core import scene\n    from . import runner\n")
    modules = {"hertzian.core.scene": source, "hertzian.core.runner": source, "hertzian.core.module": source}
    assert imported_modules("hertzian.core.module", source, modules) == {"hertzian.core.scene", "hertzian.core.runner"}


def test_no_import_circle_between_modules():
    graph = import_graph()
    assert {"hertzian.core.runner", "hertzian.studies.detection.library"} <= set(graph)
    found = [sorted(c) for c in circles(graph) if c not in ALLOWED_CIRCLES]
    assert not found, f"import circles: {found}"


@pytest.mark.parametrize("name", sorted(name for name in module_files() if not name.endswith(".__main__")))
def test_every_module_imports(name):
    importlib.import_module(name)


def test_no_function_is_longer_than_the_limit():
    long = []
    for path in sorted((ROOT / "ensemble").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                lines = node.end_lineno - node.lineno + 1
                where = path.relative_to(ROOT / "ensemble").as_posix()
                if lines > MAX_FUNCTION_LINES and (where, node.name) not in ALLOWED_LONG:
                    long.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name} ({lines} lines)")
    assert not long, "functions over the limit: " + ", ".join(long)


LAYERS = (
    ("hertzian.kernels",),
    ("hertzian.core",),
    ("hertzian.sweeping",),
    ("hertzian.studies", "hertzian.plotting", "hertzian.api"),
    ("hertzian.cli",),
)
"""The package's layers, lowest first: a module imports its own layer and the ones before it. The studies draw
their figures and the figures read the studies' analysis, so those two (and ``hertzian.api``, the one-import
namespace) share a layer."""


def layer(name: str) -> int | None:
    """The index in LAYERS of module ``name``'s layer (None for the package's root modules)."""
    for i, prefixes in enumerate(LAYERS):
        if any(name == prefix or name.startswith(prefix + ".") for prefix in prefixes):
            return i
    return None


def upward_imports(graph: dict[str, set[str]]) -> list[tuple[str, str]]:
    """(module, imported module) pairs where a module imports a layer above its own, lazily or not."""
    found = []
    for name, targets in graph.items():
        own = layer(name)
        found += [(name, t) for t in sorted(targets) if own is not None and (layer(t) or 0) > own]
    return found


def test_the_layer_check_finds_an_import_upward():
    graph = {"hertzian.core.runner": {"hertzian.sweeping.sweep_store", "hertzian.kernels.step"}}
    assert upward_imports(graph) == [("hertzian.core.runner", "hertzian.sweeping.sweep_store")]


def test_no_layer_imports_a_layer_above_it():
    """kernels → core → sweeping → studies, plotting and api → cli: core never imports sweeping, studies,
    plotting or cli, inside a function or not."""
    found = upward_imports(import_graph())
    assert not found, f"imports upward: {found}"
