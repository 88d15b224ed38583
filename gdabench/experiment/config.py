"""Experiment configuration: what the user asked for, parsed and bounded before anything runs.

Designers can carry their own parameters inline, so one comparison can hold several settings
of the same algorithm: ``ga,ga[survivors=5],gda[epochs=50]``.  The label (the text as typed)
is what the results' ``designer`` column shows.  Values are read as JSON where they parse
(``5``, ``0.1``, ``true``, ``[1, 2]``) and as text otherwise; :mod:`gdabench.params` then
converts them to the types the plugin's constructor declares.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from typing import Any, Mapping, Sequence

from ..body import DEFAULT_SHAPE
from ..designer import DEFAULT_BUDGET, DEFAULT_POPULATION
from ..errors import ConfigError

#: bounds that keep a run's memory and time finite (documented in the docs' "Limits")
MAX_POPULATION = 10_000
MAX_BUDGET = 10_000_000
MAX_SIDE = 64
MAX_SEED = 2**32 - 1
MAX_SEEDS = 10_000

#: what an experiment is where neither the command line, gdabench.compare nor an experiment file says
DEFAULT_ENV = "simple"
DEFAULT_SEEDS = (0,)


def parse_value(text: str) -> Any:
    """Parse a parameter value: JSON (numbers, true/false/null, lists) or else a plain string.  A whole
    number written with an exponent (``1e5``) is an integer, as its writer meant, and stays one in run.json."""
    lowered = text.strip().lower()
    if lowered in ("true", "false", "none", "null"):
        return {"true": True, "false": False}.get(lowered)
    try:
        value = json.loads(text)
    except ValueError:
        return text
    if isinstance(value, float) and "e" in lowered and value.is_integer() and abs(value) <= 2**53:
        return int(value)
    return value


def parse_params(items: Sequence[str] | None, what: str = "parameter") -> dict[str, Any]:
    """Parse ``["key=value", ...]`` into a dict."""
    params: dict[str, Any] = {}
    for item in items or ():
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep or not key:
            raise ConfigError(f"malformed {what} {item!r}: expected key=value")
        params[key] = parse_value(value)
    return params


def split_top_level(text: str, sep: str = ",") -> list[str]:
    """Split on ``sep`` outside square brackets: ``'a,b[x=1,y=2]'`` -> ``['a', 'b[x=1,y=2]']``."""
    parts: list[str] = []
    current: list[str] = []
    depth = 0
    for ch in text:
        if ch == "[":
            depth += 1
        elif ch == "]":
            depth -= 1
            if depth < 0:
                raise ConfigError(f"malformed list {text!r}: unbalanced ']'")
        if ch == sep and depth == 0:
            parts.append("".join(current))
            current = []
        else:
            current.append(ch)
    if depth != 0:
        raise ConfigError(f"malformed list {text!r}: unbalanced '['")
    parts.append("".join(current))
    parts = [p.strip() for p in parts]
    if "" in parts and any(parts):
        raise ConfigError(f"malformed list {text!r}: an empty item (a {sep!r} too many?)")
    return [p for p in parts if p]


@dataclass(frozen=True)
class PluginChoice:
    """A plugin name with parameters; ``label`` identifies it in results (``name`` or ``name[k=v]``)."""

    name: str
    params: Mapping[str, Any] = field(default_factory=dict)
    label: str = ""

    def __post_init__(self) -> None:
        if not self.label:
            object.__setattr__(self, "label", self.name)

    @classmethod
    def parse(cls, text: str) -> PluginChoice:
        text = text.strip()
        if "[" in text:
            if not text.endswith("]"):
                raise ConfigError(f"malformed choice {text!r}: expected name[key=value,...]")
            name, inner = text[:-1].split("[", 1)
            params = parse_params(split_top_level(inner), what=f"parameter of {name!r}")
        else:
            name, params = text, {}
        if not name.strip():
            raise ConfigError(f"malformed choice {text!r}: missing name")
        return cls(name.strip(), params, text)

    @classmethod
    def parse_list(cls, text: str) -> list[PluginChoice]:
        """``'ga,gda[epochs=50]'`` -> one choice per comma-separated item."""
        return [cls.parse(item) for item in split_top_level(text)]

    def with_params(self, extra: Mapping[str, Any]) -> PluginChoice:
        return PluginChoice(self.name, {**self.params, **extra}, self.label)

    def to_json(self) -> dict[str, Any]:
        return {"name": self.name, "label": self.label, "params": dict(self.params)}

    @classmethod
    def from_json(cls, data: Any, where: str) -> PluginChoice:
        if isinstance(data, str):
            return cls.parse(data)
        if not isinstance(data, Mapping) or not isinstance(data.get("name"), str):
            raise ConfigError(f"{where}: expected a name or a table with 'name', got {data!r}")
        unknown = sorted(set(data) - {"name", "label", "params"})
        if unknown:
            raise ConfigError(f"{where}: unknown key {unknown[0]!r} (known: name, label, params)")
        params = data.get("params", {})
        if not isinstance(params, Mapping):
            raise ConfigError(f"{where}.params: expected a table of key = value, got {params!r}")
        return cls(data["name"], dict(params), str(data.get("label") or ""))


def check_seed(seed: Any, what: str = "seed") -> int:
    """A seed as an int in 0..MAX_SEED, or a one-line error."""
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= MAX_SEED:
        raise ConfigError(f"{what} must be an integer from 0 to {MAX_SEED}, got {seed!r}")
    return seed


def format_seeds(seeds: Sequence[int]) -> str:
    """Seeds as :func:`parse_seeds` reads them, runs of consecutive ones joined: (3, 4, 5, 8) -> '3..5,8'."""
    groups: list[list[int]] = []
    for seed in sorted(seeds):
        if groups and seed == groups[-1][-1] + 1:
            groups[-1].append(seed)
        else:
            groups.append([seed])
    return ",".join(str(g[0]) if len(g) == 1 else f"{g[0]}..{g[-1]}" for g in groups)


def parse_seeds(text: str | Sequence[int] | None, repetitions: int | None = None) -> list[int]:
    """``'0,1,2'``, ``'0..9'`` (inclusive) or ``'4'`` (that seed); ``repetitions=n`` means seeds 0..n-1."""
    if repetitions is not None:
        if text not in (None, ""):
            raise ConfigError("give either --seeds or --repetitions, not both")
        if not 1 <= repetitions <= MAX_SEEDS:
            raise ConfigError(f"repetitions must be from 1 to {MAX_SEEDS}, got {repetitions}")
        return list(range(repetitions))
    if text is None or text == "":
        return list(DEFAULT_SEEDS)
    if not isinstance(text, str):
        seeds = list(text)
    else:
        seeds = []
        for part in text.split(","):
            part = part.strip()
            try:
                lo, hi = (int(v) for v in part.split("..")) if ".." in part else (int(part), int(part))
            except ValueError:
                raise ConfigError(f"malformed seeds {text!r}: expected e.g. 0,1,2 or 0..9") from None
            if hi < lo:
                raise ConfigError(f"malformed seeds {text!r}: a range must not run backwards")
            if hi - lo + 1 > MAX_SEEDS:
                raise ConfigError(f"seeds {text!r} name {hi - lo + 1} seeds; at most {MAX_SEEDS} are allowed")
            seeds.extend(range(lo, hi + 1))
    if len(seeds) > MAX_SEEDS:
        raise ConfigError(f"{len(seeds)} seeds given; at most {MAX_SEEDS} are allowed")
    for s in seeds:
        check_seed(s)
    if len(set(seeds)) != len(seeds):
        raise ConfigError(f"seeds must not repeat, got {seeds}")
    return seeds


#: how each trial's final best bodies are scored again where rewards depend on a training seed (on by default
#: with a controller: ``gdabench.experiment.build``); at most this many bodies and seeds each
REEVALUATE_TOP, REEVALUATE_SEEDS, MAX_REEVALUATE = 3, 5, 100


@dataclass(frozen=True)
class Reevaluation:
    """Retrain each trial's ``top`` best bodies under ``seeds`` further training seeds after its budget.

    A trial's best reward is the largest of many noisy numbers (each body trained once), so it is biased
    upward (the winner's curse); the re-evaluated score, the best of the top bodies' means over fresh
    seeds, is not selected on its own noise (see :mod:`gdabench.running.reevaluation`).
    """

    top: int = REEVALUATE_TOP
    seeds: int = REEVALUATE_SEEDS

    def check(self) -> None:
        for name in ("top", "seeds"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= MAX_REEVALUATE:
                raise ConfigError(f"reevaluate: {name} must be an integer from 1 to {MAX_REEVALUATE}, got {value!r}")

    @property
    def text(self) -> str:
        return f"{self.top}x{self.seeds}"

    @classmethod
    def parse(cls, value: Any, where: str = "reevaluate") -> Reevaluation | None:
        """``"3x5"`` (top 3 bodies, 5 seeds each), ``"off"``/``false`` (None), ``true`` (the defaults), or a
        table ``{top = 3, seeds = 5}``."""
        if value is False or (isinstance(value, str) and value.strip().lower() in ("off", "false", "no", "none")):
            return None
        if value is True or (isinstance(value, str) and value.strip().lower() in ("on", "true", "yes")):
            return cls()
        if isinstance(value, Reevaluation):
            found = value
        elif isinstance(value, str):
            top, sep, seeds = value.strip().lower().partition("x")
            try:
                found = cls(int(top), int(seeds))
            except ValueError:
                raise ConfigError(f"{where}: expected TOPxSEEDS such as 3x5, or off; got {value!r}") from None
            if not sep:
                raise ConfigError(f"{where}: expected TOPxSEEDS such as 3x5, or off; got {value!r}")
        elif isinstance(value, Mapping):
            unknown = sorted(set(value) - {"top", "seeds"})
            if unknown:
                raise ConfigError(f"{where}: unknown key {unknown[0]!r} (known: top, seeds)")
            found = cls(value.get("top", REEVALUATE_TOP), value.get("seeds", REEVALUATE_SEEDS))
        else:
            raise ConfigError(f"{where}: expected TOPxSEEDS such as 3x5, off, or a table; got {value!r}")
        try:
            found.check()
        except ConfigError as exc:
            raise ConfigError(f"{where}: {str(exc).removeprefix('reevaluate: ')}") from None
        return found


#: per-trial scores a primary comparison can test ("auto": reevaluated_best where the run re-evaluates)
PRIMARY_METRICS = ("auto", "best_reward", "reevaluated_best", "mean_best_so_far")
PRIMARY_KEYS = ("a", "b", "metric", "alpha", "effect", "power", "env")


@dataclass(frozen=True)
class Primary:
    """One comparison named before the run: designer ``a`` against ``b`` on ``metric``, tested alone at
    ``alpha``; ``effect`` is the smallest effect of interest (Vargha-Delaney A12, the probability that a
    run of ``a`` beats one of ``b``) that the seeds should detect ``power`` of the time."""

    a: str
    b: str
    metric: str = "auto"
    alpha: float = 0.05
    effect: float = 0.71
    power: float = 0.8
    env: str | None = None

    def check(self) -> None:
        for name in ("a", "b"):
            if not isinstance(getattr(self, name), str) or not getattr(self, name):
                raise ConfigError(f"primary: {name} must be a designer label, got {getattr(self, name)!r}")
        if self.a == self.b:
            raise ConfigError(f"primary: a and b must be two designers, got {self.a!r} twice")
        if self.metric not in PRIMARY_METRICS:
            raise ConfigError(f"primary: metric must be one of {', '.join(PRIMARY_METRICS)}, got {self.metric!r}")
        for name, low, high in (("alpha", 0.0, 0.5), ("effect", 0.0, 1.0), ("power", 0.0, 1.0)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not low < value < high:
                raise ConfigError(f"primary: {name} must be a number between {low:g} and {high:g}, got {value!r}")
        if abs(self.effect - 0.5) < 0.01:
            raise ConfigError(f"primary: effect {self.effect} is no effect (A12 = 0.5 means none); e.g. 0.71, large")
        if self.env is not None and not isinstance(self.env, str):
            raise ConfigError(f"primary: env must be an environment label, got {self.env!r}")

    def to_json(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_json(cls, data: Any, where: str = "primary") -> Primary:
        if isinstance(data, str):  # "gda,ga" or "gda vs ga"
            parts = [p.strip() for p in data.replace(" vs ", ",").split(",")]
            if len(parts) != 2:
                raise ConfigError(f"{where}: expected two designers such as 'gda,ga', got {data!r}")
            data = {"a": parts[0], "b": parts[1]}
        if not isinstance(data, Mapping):
            raise ConfigError(f"{where}: expected a table with a and b, got {data!r}")
        unknown = sorted(set(data) - set(PRIMARY_KEYS))
        if unknown:
            raise ConfigError(f"{where}: unknown key {unknown[0]!r} (known: {', '.join(PRIMARY_KEYS)})")
        missing = [k for k in ("a", "b") if k not in data]
        if missing:
            raise ConfigError(f"{where}: missing {missing[0]!r} (the two designers compared)")
        found = cls(**{k: data[k] for k in PRIMARY_KEYS if k in data})
        try:
            found.check()
        except ConfigError as exc:
            raise ConfigError(f"{where}: {str(exc).removeprefix('primary: ')}") from None
        return found


def _choices(value: PluginChoice | Sequence[PluginChoice]) -> tuple[PluginChoice, ...]:
    return (value,) if isinstance(value, PluginChoice) else tuple(value)


@dataclass(frozen=True)
class Experiment:
    """Everything that defines a comparison; the same Experiment and seeds give the same table.

    ``envs`` may hold several environments (a suite): every designer runs on each of them
    with every seed.  A single :class:`PluginChoice` is accepted for ``designers`` and ``envs``.
    """

    designers: tuple[PluginChoice, ...]
    envs: tuple[PluginChoice, ...]
    controller: PluginChoice | None = None
    shape: tuple[int, int] = DEFAULT_SHAPE
    population: int = DEFAULT_POPULATION
    budget: int = DEFAULT_BUDGET
    seeds: tuple[int, ...] = DEFAULT_SEEDS
    #: end a run once it reaches the environment's optimum (the rest of its budget is not spent)
    stop_at_optimum: bool = False
    #: score each trial's final best bodies again under further training seeds (None: off)
    reevaluate: Reevaluation | None = None
    #: the one comparison named before the run, tested alone (None: every pair is exploratory)
    primary: Primary | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "designers", _choices(self.designers))
        object.__setattr__(self, "envs", _choices(self.envs))
        object.__setattr__(self, "shape", tuple(self.shape))
        object.__setattr__(self, "seeds", tuple(self.seeds))

    def check(self) -> None:
        """Check the numbers and lists (plugin names and parameters are checked when resolved)."""
        if not self.designers:
            raise ConfigError("no designer given")
        if not self.envs:
            raise ConfigError("no environment given")
        for what, choices in (("designers", self.designers), ("environments", self.envs)):
            labels = [c.label for c in choices]
            if len(set(labels)) != len(labels):
                raise ConfigError(f"{what} must not repeat: {', '.join(labels)}")
        if len(self.shape) != 2 or not all(
            isinstance(s, int) and not isinstance(s, bool) and 1 <= s <= MAX_SIDE for s in self.shape
        ):
            raise ConfigError(f"shape must be two sides from 1 to {MAX_SIDE} voxels, got {self.shape}")
        for name, value, high in (("population", self.population, MAX_POPULATION), ("budget", self.budget, MAX_BUDGET)):
            if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= high:
                raise ConfigError(f"{name} must be an integer from 1 to {high:,}, got {value!r}")
        if self.budget < self.population:
            raise ConfigError(f"budget ({self.budget}) must be at least the population ({self.population})")
        if not self.seeds:
            raise ConfigError("no seed given")
        if len(self.seeds) > MAX_SEEDS:
            raise ConfigError(f"{len(self.seeds)} seeds given; at most {MAX_SEEDS} are allowed")
        for s in self.seeds:
            check_seed(s)
        if len(set(self.seeds)) != len(self.seeds):
            raise ConfigError(f"seeds must not repeat, got {list(self.seeds)}")
        if self.reevaluate is not None:
            self.reevaluate.check()
        if self.primary is not None:
            self._check_primary(self.primary)

    def _check_primary(self, primary: Primary) -> None:
        primary.check()
        labels = [d.label for d in self.designers]
        for name in (primary.a, primary.b):
            if name not in labels:
                raise ConfigError(f"primary: designer {name!r} is not in this run ({', '.join(labels)})")
        envs = [e.label for e in self.envs]
        if primary.env is not None and primary.env not in envs:
            raise ConfigError(f"primary: environment {primary.env!r} is not in this run ({', '.join(envs)})")
        if primary.env is None and len(envs) > 1:
            raise ConfigError(f"primary: name the environment it is tested on (env = one of {', '.join(envs)})")
        if primary.metric == "reevaluated_best" and self.reevaluate is None:
            raise ConfigError("primary: metric reevaluated_best needs re-evaluation (reevaluate = '3x5')")

    def to_json(self) -> dict[str, Any]:
        data = asdict(self)
        data["designers"] = [d.to_json() for d in self.designers]
        data["envs"] = [e.to_json() for e in self.envs]
        data["controller"] = self.controller.to_json() if self.controller else None
        data["shape"] = list(self.shape)
        data["seeds"] = list(self.seeds)
        data["reevaluate"] = asdict(self.reevaluate) if self.reevaluate else None
        data["primary"] = self.primary.to_json() if self.primary else None
        return data

    @classmethod
    def from_json(cls, data: Any, where: str = "config") -> Experiment:
        """Read :meth:`to_json`'s form (also the single ``env`` of runs made before suites)."""
        if not isinstance(data, Mapping):
            raise ConfigError(f"{where}: expected a table, got {type(data).__name__}")
        try:
            envs = data["envs"] if "envs" in data else [data["env"]]
            experiment = cls(
                designers=tuple(PluginChoice.from_json(d, f"{where}.designers") for d in data["designers"]),
                envs=tuple(PluginChoice.from_json(e, f"{where}.envs") for e in envs),
                controller=None
                if data.get("controller") is None
                else PluginChoice.from_json(data["controller"], f"{where}.controller"),
                shape=tuple(data["shape"]),
                population=data["population"],
                budget=data["budget"],
                seeds=tuple(data["seeds"]),
                stop_at_optimum=bool(data.get("stop_at_optimum", False)),
                reevaluate=Reevaluation.parse(data.get("reevaluate") or False, f"{where}.reevaluate"),
                primary=None if data.get("primary") is None else Primary.from_json(data["primary"], f"{where}.primary"),
            )
        except KeyError as exc:
            raise ConfigError(f"{where}: missing {exc.args[0]!r}") from None
        except TypeError as exc:
            raise ConfigError(f"{where}: malformed ({exc})") from None
        try:
            experiment.check()
        except ConfigError as exc:
            raise ConfigError(f"{where}: {exc}") from None
        return experiment
