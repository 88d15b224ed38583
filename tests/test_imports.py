"""Import circles in the package, and the direction between its layers.

A circle (modules that import each other, type-checking imports included) means an interface knows
about the machinery that runs it.  Imports inside functions (deliberately lazy) are left out of the
circles; importing a submodule is counted as importing it, not its package's ``__init__``.

Layers: ``gdabench.running`` (running an experiment) may import ``gdabench.execution`` (evaluating
bodies), never the other way round; there every import counts, lazy ones included.
"""

from __future__ import annotations

import ast
from pathlib import Path

import gdabench

#: circles allowed: none.  Break a new one by moving code (a type both sides need into a module of its
#: own, as ``execution.tasks`` and ``trial_spec`` were), never by adding it here
KNOWN_CIRCLES: set[frozenset[str]] = set()


def modules() -> dict[str, tuple[Path, bool]]:
    """Every module of the package: name -> (file, whether it is a package's ``__init__``)."""
    root = Path(gdabench.__file__).parent
    found = {}
    for path in root.rglob("*.py"):
        parts = list(path.relative_to(root.parent).with_suffix("").parts)
        package = parts[-1] == "__init__"
        found[".".join(parts[:-1] if package else parts)] = (path, package)
    return found


def imported(s: ast.Import | ast.ImportFrom, name: str, package: bool, known: set[str]) -> set[str]:
    """The package's modules one import statement of module ``name`` imports."""
    if isinstance(s, ast.Import):
        return {a.name for a in s.names if a.name in known}
    if s.level:
        base = name.split(".") if package else name.split(".")[:-1]
        base = base[: len(base) - s.level + 1]
        target = ".".join(base + ([s.module] if s.module else []))
    else:
        target = s.module or ""
    found = set()
    for alias in s.names:
        sub = f"{target}.{alias.name}"
        if sub in known or target in known:
            found.add(sub if sub in known else target)
    return found


def imports(name: str, path: Path, package: bool, known: set[str]) -> set[str]:
    """The package's modules that ``name`` imports at module level (``if`` and ``try`` blocks included)."""
    found: set[str] = set()

    def visit(statements: list[ast.stmt]) -> None:
        for s in statements:
            if isinstance(s, (ast.Import, ast.ImportFrom)):
                found.update(imported(s, name, package, known))
            elif isinstance(s, ast.If):
                visit(s.body)
                visit(s.orelse)
            elif isinstance(s, ast.Try):
                visit(s.body)
                for handler in s.handlers:
                    visit(handler.body)

    visit(ast.parse(path.read_text()).body)
    return found


def all_imports(name: str, path: Path, package: bool, known: set[str]) -> set[str]:
    """The package's modules that ``name`` imports anywhere, inside functions too."""
    found: set[str] = set()
    for s in ast.walk(ast.parse(path.read_text())):
        if isinstance(s, (ast.Import, ast.ImportFrom)):
            found.update(imported(s, name, package, known))
    return found


def upward(found: dict[str, tuple[Path, bool]], lower: str, upper: str) -> dict[str, set[str]]:
    """Modules of the package ``lower`` that import modules of the package ``upper`` (anywhere)."""
    known = set(found)
    wrong = {}
    for name, (path, package) in found.items():
        if name == lower or name.startswith(lower + "."):
            reached = {m for m in all_imports(name, path, package, known) if m == upper or m.startswith(upper + ".")}
            if reached:
                wrong[name] = reached
    return wrong


def circles(graph: dict[str, set[str]]) -> set[frozenset[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: set[frozenset[str]] = set()

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = set()
            while True:
                w = stack.pop()
                component.add(w)
                if w == v:
                    break
            if len(component) > 1:
                found.add(frozenset(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_circles_finds_a_circle_and_only_a_circle():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}, "e": set()}
    assert circles(graph) == {frozenset({"a", "b", "c"})}


def test_no_new_import_circles():
    found = modules()
    graph = {name: imports(name, path, package, set(found)) for name, (path, package) in found.items()}
    assert "gdabench.execution.tasks" in graph["gdabench.running.trial"]  # the reader sees relative imports
    new = circles(graph) - KNOWN_CIRCLES
    gone = KNOWN_CIRCLES - circles(graph)
    assert not new, f"import circles: {[sorted(c) for c in new]} (break them; see this module's docstring)"
    assert not gone, f"circles gone: {[sorted(c) for c in gone]}; remove them from KNOWN_CIRCLES"


def test_execution_does_not_import_running():
    """Evaluating bodies (``execution``) knows nothing of running experiments (``running``)."""
    found = modules()
    runner = ("gdabench.running.runner", *found["gdabench.running.runner"], set(found))
    lazy = "gdabench.execution.ray"  # imported inside a function: counted here, not in the circles
    assert lazy in all_imports(*runner) and lazy not in imports(*runner)
    wrong = upward(found, "gdabench.execution", "gdabench.running")
    assert not wrong, f"gdabench.execution imports gdabench.running: {wrong} (see the two packages' docstrings)"
