"""Experiment files: a comparison written down next to the paper it belongs to.

``gdabench compare --config experiment.toml`` reads a TOML file (or a run's ``run.json``, so
any run can be repeated exactly); options given on the command line override the file::

    designers = ["ga", "cppn", "gda[epochs=50]"]   # as on the command line, or tables:
    # [[designers]]  name = "ga"  label = "ga-5"  params = { survivors = 5 }
    envs = ["simple", "nk[k=4]"]                    # or env = "simple", or suite = "landscapes"
    controller = "ppo[timesteps=20000]"             # physics environments only
    shape = "5x5"
    population = 25
    budget = 1000
    seeds = "0..9"                                  # or [0, 1, 2], or repetitions = 10
    stop_at_optimum = false
    reevaluate = "3x5"                              # retrain each trial's top 3 bodies under 5 more seeds, or "off"
    out = "results/my-comparison"

    [primary]                                       # one comparison named before the run, tested alone
    a = "gda"
    b = "ga"
    metric = "auto"                                 # reevaluated_best where the run re-evaluates, else best_reward
    alpha = 0.05
    effect = 0.71                                   # smallest effect of interest (A12); without seeds, the seeds
    power = 0.8                                     # the power analysis asks for to detect it this often

    [execution]
    jobs = 2
    workers = 1
    batch = 25                                      # bodies per evaluation call (default: the controller's)
    executor = "local"                              # or "ray", with ray_address
    timeout = 600
    cache = "cache"

Unknown keys and bad values are one-line errors naming the key and the file.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import tomllib

from ..body import parse_shape
from ..errors import ConfigError, GdabenchError
from .config import PluginChoice, Primary, Reevaluation, parse_seeds

KEYS = ("designers", "env", "envs", "suite", "controller", "shape", "population", "budget", "seeds", "repetitions",
        "stop_at_optimum", "reevaluate", "primary", "out", "execution")  # fmt: skip
EXECUTION_KEYS = ("jobs", "workers", "batch", "executor", "timeout", "ray_address", "cache")


@dataclass
class ExperimentFile:
    """What a file sets; each field is None where the file is silent."""

    path: Path | None  # None: no file
    designers: tuple[PluginChoice, ...] | None = None
    envs: tuple[PluginChoice, ...] | None = None
    suite: str | None = None
    controller: PluginChoice | None = None
    shape: tuple[int, int] | None = None
    population: int | None = None
    budget: int | None = None
    seeds: tuple[int, ...] | None = None
    stop_at_optimum: bool | None = None
    #: "off" is kept as ``False`` so that it overrides the default (None: the file is silent)
    reevaluate: Reevaluation | bool | None = None
    primary: Primary | None = None
    out: Path | None = None
    execution: dict[str, Any] = field(default_factory=dict)


def load(path: str | Path) -> ExperimentFile:
    """Read an experiment file (``.toml``) or a run's ``run.json``."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(f"cannot read the experiment file {path}: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        raise ConfigError(f"the experiment file {path} is not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    if path.suffix == ".json":
        try:
            data = json.loads(text)
        except ValueError as exc:
            raise ConfigError(f"{path}: not valid JSON ({exc})") from None
        if not isinstance(data, dict) or not isinstance(data.get("config"), dict):
            raise ConfigError(f"{path}: a JSON experiment must be a run's run.json (with a 'config' table)")
        execution = data.get("execution")
        if not isinstance(execution, dict):
            execution = {}
        return _parse(
            {**data["config"], "execution": {k: v for k, v in execution.items() if k in EXECUTION_KEYS}}, path
        )
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: {exc}") from None
    return _parse(data, path)


def _parse(data: Mapping[str, Any], path: Path) -> ExperimentFile:
    where = str(path)

    def fail(key: str, message: str) -> ConfigError:
        return ConfigError(f"{where}: {key}: {message}")

    unknown = sorted(set(data) - set(KEYS))
    if unknown:
        raise ConfigError(f"{where}: unknown key {unknown[0]!r} (known: {', '.join(KEYS)})")
    found = ExperimentFile(path)
    try:
        if "designers" in data:
            found.designers = _choice_list(data["designers"], f"{where}: designers")
        if "env" in data and "envs" in data:
            raise fail("env", "give env or envs, not both")
        if "env" in data or "envs" in data:
            key = "env" if "env" in data else "envs"
            found.envs = _choice_list(data[key], f"{where}: {key}")
        if "suite" in data:
            if not isinstance(data["suite"], str):
                raise fail("suite", f"expected a suite name, got {data['suite']!r}")
            found.suite = data["suite"]
        if data.get("controller") is not None:
            found.controller = PluginChoice.from_json(data["controller"], f"{where}: controller")
        if "shape" in data:
            found.shape = parse_shape(data["shape"])
        for key in ("population", "budget"):
            if key in data:
                if isinstance(data[key], bool) or not isinstance(data[key], int):
                    raise fail(key, f"expected an integer, got {data[key]!r}")
                setattr(found, key, data[key])
        if "seeds" in data and "repetitions" in data:
            raise fail("seeds", "give seeds or repetitions, not both")
        if "seeds" in data or "repetitions" in data:
            seeds = data.get("seeds")
            found.seeds = tuple(
                parse_seeds(seeds if isinstance(seeds, (str, type(None))) else list(seeds), data.get("repetitions"))
            )
        if "stop_at_optimum" in data:
            if not isinstance(data["stop_at_optimum"], bool):
                raise fail("stop_at_optimum", f"expected true or false, got {data['stop_at_optimum']!r}")
            found.stop_at_optimum = data["stop_at_optimum"]
        if "reevaluate" in data:  # a run.json's null is "off", as the run had it
            found.reevaluate = Reevaluation.parse(False if data["reevaluate"] is None else data["reevaluate"]) or False
        if data.get("primary") is not None:
            found.primary = Primary.from_json(data["primary"])
        if "out" in data:
            found.out = Path(str(data["out"]))  # as --out: relative to the current directory
        execution = data.get("execution", {})
        if not isinstance(execution, Mapping):
            raise fail("execution", "expected a table")
        unknown = sorted(set(execution) - set(EXECUTION_KEYS))
        if unknown:
            raise fail("execution", f"unknown key {unknown[0]!r} (known: {', '.join(EXECUTION_KEYS)})")
        found.execution = dict(execution)
    except GdabenchError as exc:
        message = str(exc)
        raise ConfigError(message if message.startswith(where) else f"{where}: {message}") from None
    except TypeError as exc:
        raise ConfigError(f"{where}: malformed value ({exc})") from None
    return found


def _choice_list(value: Any, where: str) -> tuple[PluginChoice, ...]:
    items = value if isinstance(value, list) else [value]
    choices: list[PluginChoice] = []
    for item in items:
        choices += PluginChoice.parse_list(item) if isinstance(item, str) else [PluginChoice.from_json(item, where)]
    if not choices:
        raise ConfigError(f"{where}: empty")
    return tuple(choices)
