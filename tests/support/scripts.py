"""Scripts of benchmarks/ loaded as modules, with their sibling modules importable as when they run."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"


def load_script(script: str) -> ModuleType:
    """``benchmarks/<folder>/<name>.py`` as the module ``<name>``, given ``"<folder>/<name>"``."""
    path = BENCHMARKS / f"{script}.py"
    if str(path.parent) not in sys.path:
        sys.path.insert(0, str(path.parent))  # python benchmarks/<folder>/<name>.py puts it first too
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
