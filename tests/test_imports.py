"""The package's import graph: its floors, and no circles.

Floors (``FLOORS``, lowest first; docs/development.md draws them): a module imports modules of its own
floor or of a floor below, never above.  Here every import counts: inside functions (lazy) and under
``if TYPE_CHECKING`` too, since a type-only import still means the lower module knows the upper one.
On top of the floors: nothing below ``gdabench.running`` imports it, ``running`` and ``report`` never
import each other, and the built-in plugins (``designers``, ``envs``, ``controllers``) import only the
leaf modules, the contract (``gdabench.sdk`` and the interfaces) and each other, as a third party's must.

A circle (modules that import each other at module level) means an interface knows about the machinery
that runs it.  Importing a submodule is counted as importing it, not its package's ``__init__``.
"""

from __future__ import annotations

import ast
from pathlib import Path

import gdabench

#: circles allowed: none.  Break a new one by moving code (a type both sides need into a module of its
#: own, as ``strategy`` and ``experiment.trial_spec`` were), never by adding it here
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
    assert "gdabench.strategy" in graph["gdabench.running.trial"]  # the reader sees relative imports
    new = circles(graph) - KNOWN_CIRCLES
    gone = KNOWN_CIRCLES - circles(graph)
    assert not new, f"import circles: {[sorted(c) for c in new]} (break them; see this module's docstring)"
    assert not gone, f"circles gone: {[sorted(c) for c in gone]}; remove them from KNOWN_CIRCLES"


#: the floors, lowest first: each names top-level modules and packages of gdabench ("gdabench" is the package's
#: own namespace, ``gdabench/__init__.py``)
FLOORS: tuple[tuple[str, frozenset[str]], ...] = (
    ("leaf", frozenset({"errors", "body", "seeding", "statuses", "names", "cpu", "specs", "torch_runtime", "faults",
                        "params", "spawning", "parquet", "atomic"})),  # fmt: skip
    ("contract", frozenset({"designer", "environment", "strategy", "batched", "sdk"})),
    ("plugins", frozenset({"designers", "envs", "controllers"})),
    ("machinery", frozenset({"execution", "results", "stats"})),
    ("experiment", frozenset({"experiment", "hookspecs", "plugins"})),
    ("running and report", frozenset({"running", "report"})),
    ("front", frozenset({"api", "cli", "replay", "loggers", "testing", "__main__", "gdabench"})),
)
PLUGINS = ("designers", "envs", "controllers")


def part(module: str) -> str:
    """The top-level module or package of gdabench a module belongs to ("gdabench" for the namespace)."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else parts[0]


def floor_of(module: str) -> int:
    return next(i for i, (_, parts) in enumerate(FLOORS) if part(module) in parts)


def every_import() -> dict[str, set[str]]:
    """Module -> the package's modules it imports anywhere (lazy and type-only imports included)."""
    found = modules()
    return {name: all_imports(name, path, package, set(found)) for name, (path, package) in found.items()}


def upward_imports(graph: dict[str, set[str]]) -> list[str]:
    """``a -> b`` for every import of a module on a higher floor."""
    return sorted(
        f"{a} -> {b}" for a, targets in graph.items() for b in targets if floor_of(b) > floor_of(a)
    )


def crossing(graph: dict[str, set[str]], lower: set[str], upper: set[str]) -> list[str]:
    """``a -> b`` for every import of a module of the parts ``upper`` by a module of the parts ``lower``."""
    return sorted(f"{a} -> {b}" for a, targets in graph.items() for b in targets
                  if part(a) in lower and part(b) in upper)  # fmt: skip


def test_the_floor_rules_find_an_import_up_and_only_that():
    graph = {"gdabench.body": {"gdabench.errors"}, "gdabench.results": {"gdabench.running.faults", "gdabench.body"},
             "gdabench.cli": {"gdabench.report.build"}}  # fmt: skip
    assert upward_imports(graph) == ["gdabench.results -> gdabench.running.faults"]
    assert crossing(graph, {"results"}, {"running"}) == ["gdabench.results -> gdabench.running.faults"]


def test_every_module_has_a_floor():
    unplaced = sorted({part(m) for m in modules()} - {p for _, parts in FLOORS for p in parts})
    assert not unplaced, f"place {unplaced} on a floor in FLOORS (and in docs/development.md's map)"


def test_no_import_runs_up_a_floor():
    graph = every_import()
    runner = graph["gdabench.running.runner"]
    assert "gdabench.execution.ray" in runner  # imported inside a function, and counted
    assert "gdabench.experiment.trial_spec" in graph["gdabench.hookspecs"]  # under TYPE_CHECKING, and counted
    wrong = upward_imports(graph)
    assert not wrong, f"imports running up a floor (see FLOORS): {wrong}"


def test_nothing_below_running_imports_it():
    graph = every_import()
    below = {p for _, parts in FLOORS[: floor_of("gdabench.running")] for p in parts}
    wrong = crossing(graph, below, {"running"})
    assert not wrong, f"gdabench.running imported from below it: {wrong}"


def test_running_and_report_never_import_each_other():
    graph = every_import()
    wrong = crossing(graph, {"running"}, {"report"}) + crossing(graph, {"report"}, {"running"})
    assert not wrong, f"running and report import each other: {wrong} (what both need goes in gdabench.stats)"


def test_built_in_plugins_import_only_the_sdk_the_contract_and_the_leaves():
    """What a built-in plugin imports, a third party's can import too: nothing of execution, running, results."""
    graph = every_import()
    allowed = {p for _, parts in FLOORS[: floor_of("gdabench.designers") + 1] for p in parts}
    wrong = crossing(graph, set(PLUGINS), {part(m) for m in graph} - allowed)
    assert not wrong, f"built-in plugins reach into the harness: {wrong} (use gdabench.sdk)"
    assert {"gdabench.sdk"} <= graph["gdabench.designers.gda.designer"]
