"""MkDocs hooks: the parts of the documentation that are generated from the repository.

Generated so that they cannot drift from the code or the committed data:

* ``<!-- gdabench:columns -->`` in a page becomes the table of result columns,
  :data:`gdabench.results.COLUMNS` (the schema the runner writes);
* ``<!-- gdabench:reference-summary -->`` becomes the per-designer table of the committed reference
  run, taken from ``results/reference/simple/report/summary.md`` (the README shows the same table;
  ``tests/test_docs.py`` checks that);
* ``<!-- gdabench:extras -->`` becomes the table of the optional extras in ``pyproject.toml``.

Files outside ``docs/`` that pages show or link to (the committed reference runs under
``results/reference/``) are published with the site under the same path, so a page links to
``../results/reference/simple/report/best_so_far.png`` and ``mkdocs build --strict`` checks the link
like any other.

Pages that other branches are still writing are listed under ``extra.pending_pages`` in
``mkdocs.yml``: their nav entries are left out while the file is missing, and once it exists the
build warns (so fails in strict mode) until the entry is removed from that list.
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path
from typing import Any

from mkdocs.exceptions import PluginError
from mkdocs.plugins import get_plugin_logger
from mkdocs.structure.files import File, Files

log = get_plugin_logger("gdabench")

#: committed results published with the site (Markdown files there are not pages)
PUBLISHED = "results/reference"
REFERENCE_SUMMARY = "results/reference/simple/report/summary.md"

#: what each optional extra of pyproject.toml is for; an extra missing here fails the build
EXTRAS = {
    "test": "the test suite (`python -m pytest`) and the timed benchmarks under `tests/benchmarks/`",
    "nevergrad": "the `nevergrad` designer: nevergrad's optimizers (NGOpt, DiscreteOnePlusOne, ...) on the voxel codes ([Designers from other ecosystems](designers/ecosystem.md))",
    "bo": "the `bo` designer: Bayesian optimisation on BoTorch (uses the torch already installed)",
    "ribs": "the `ribs-map-elites` and `ribs-cma-me` designers: pyribs' archive, emitters and scheduler",
    "gpu": "the voxel engine on an NVIDIA GPU: `gdabench.envs.voxel.gpu` ([On a GPU](environments/voxel-engine.md#on-a-gpu))",
    "ray": "`--executor ray`: run trials (and their evaluation workers) on a local Ray instance or an existing Ray cluster",
    "tensorboard": "`--log tensorboard`: each generation's figures as TensorBoard event files",
    "bench": "`benchmarks/ppo_vs_sb3.py`, which compares the `ppo` controller with stable-baselines3's PPO",
    "docs": "building this site: `mkdocs build --strict`",
    "lint": "`ruff check gdabench` and `mypy`, as CI runs them ([Development](development.md#lint-and-types))",
}

PLACEHOLDER = re.compile(r"<!-- gdabench:([a-z-]+) -->")


def _root(config: Any) -> Path:
    return Path(config["config_file_path"]).resolve().parent


def _cell(text: str) -> str:
    return str(text).replace("|", "\\|")


def columns_table() -> str:
    from gdabench.results import COLUMNS

    rows = [f"| `{name}` | {_cell(meaning)} |" for name, meaning in COLUMNS.items()]
    return "\n".join(["| column | meaning |", "|---|---|", *rows])


def reference_summary(root: Path) -> str:
    """The table under "Summary per designer" of the reference run's summary.md."""
    path = root / REFERENCE_SUMMARY
    try:
        lines = path.read_text().splitlines()
    except OSError as exc:
        raise PluginError(f"cannot read the reference run's summary {path}: {exc}") from exc
    start = next((i for i, line in enumerate(lines) if line.strip() == "## Summary per designer"), None)
    if start is None:
        raise PluginError(f"{path} has no '## Summary per designer' section")
    table = []
    for line in lines[start + 1 :]:
        if line.startswith("|"):
            table.append(line)
        elif table:
            break
    if not table:
        raise PluginError(f"{path}: no table under '## Summary per designer'")
    return "\n".join(table)


def extras_table(root: Path) -> str:
    with open(root / "pyproject.toml", "rb") as fh:
        extras: dict[str, list[str]] = tomllib.load(fh)["project"].get("optional-dependencies", {})
    missing = sorted(set(extras) - set(EXTRAS))
    if missing:
        raise PluginError(f"pyproject.toml has extras the docs do not describe: {', '.join(missing)} (add them to EXTRAS in docs/hooks/gdabench_docs.py)")
    rows = [f"| `{name}` | {', '.join(f'`{_cell(r)}`' for r in reqs)} | {EXTRAS[name]} |" for name, reqs in extras.items()]
    return "\n".join(["| extra | installs | for |", "|---|---|---|", *rows])


def _prune(nav: list[Any], pending: set[str], docs_dir: Path) -> list[Any]:
    """Drop nav entries that point to a pending page not written yet (and sections left empty)."""
    kept: list[Any] = []
    for item in nav:
        value = next(iter(item.values())) if isinstance(item, dict) and len(item) == 1 else item
        if isinstance(value, list):
            value = _prune(value, pending, docs_dir)
            if not value:
                continue
            item = {next(iter(item)): value}
        elif isinstance(value, str) and value in pending and not (docs_dir / value).exists():
            continue
        kept.append(item)
    return kept


def on_config(config: Any) -> Any:
    pending = set(config["extra"].get("pending_pages", []))
    docs_dir = Path(config["docs_dir"])
    for page in sorted(pending):
        if (docs_dir / page).exists():
            log.warning(f"pending page {page} exists now: remove it from extra.pending_pages in mkdocs.yml")
    if config["nav"]:
        config["nav"] = _prune(config["nav"], pending, docs_dir)
    return config


def on_files(files: Files, config: Any) -> Files:
    root = _root(config)
    published = root / PUBLISHED
    if not published.is_dir():
        raise PluginError(f"{published} is missing: the docs show the committed reference runs")
    for path in sorted(published.rglob("*")):
        if path.is_file() and path.suffix != ".md":
            files.append(File.generated(config, path.relative_to(root).as_posix(), abs_src_path=str(path)))
    return files


def on_page_markdown(markdown: str, page: Any, config: Any, files: Files) -> str:
    root = _root(config)
    generators = {
        "columns": columns_table,
        "reference-summary": lambda: reference_summary(root),
        "extras": lambda: extras_table(root),
    }

    def expand(match: re.Match[str]) -> str:
        name = match.group(1)
        if name not in generators:
            raise PluginError(f"{page.file.src_uri}: unknown placeholder <!-- gdabench:{name} -->")
        return generators[name]()

    return PLACEHOLDER.sub(expand, markdown)
