"""Experiment configuration: parsing what the user typed and checking it before anything runs.

Designers can carry their own parameters inline, so one comparison can hold several settings
of the same algorithm: ``ga,ga[survivors=5],gda[epochs=50]``.  The label (the text as typed)
is what the results' ``designer`` column shows.
"""

from __future__ import annotations

import inspect
import json
from dataclasses import asdict, dataclass, field
from typing import Any, Mapping, Sequence

from .body import DEFAULT_SHAPE
from .errors import ConfigError
from .plugins import Kind, Registry, registry
from .specs import Spec

#: keyword arguments the harness itself passes to designer factories
HARNESS_DESIGNER_ARGS = ("shape", "population", "budget", "seed")
HARNESS_ENV_ARGS = ("shape",)


def parse_value(text: str) -> Any:
    """Parse a parameter value: JSON (numbers, true/false/null, lists) or else a plain string."""
    lowered = text.strip().lower()
    if lowered in ("true", "false", "none", "null"):
        return {"true": True, "false": False}.get(lowered)
    try:
        return json.loads(text)
    except ValueError:
        return text


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
    parts, depth, current = [], 0, []
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
    return [p.strip() for p in parts if p.strip()]


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

    def with_params(self, extra: Mapping[str, Any]) -> PluginChoice:
        return PluginChoice(self.name, {**self.params, **extra}, self.label)

    def to_json(self) -> dict[str, Any]:
        return {"name": self.name, "label": self.label, "params": dict(self.params)}


def parse_seeds(text: str | Sequence[int] | None, repetitions: int | None = None) -> list[int]:
    """``'0,1,2'``, ``'0..9'`` (inclusive) or ``'4'`` (that seed); ``repetitions=n`` means seeds 0..n-1."""
    if repetitions is not None:
        if text not in (None, ""):
            raise ConfigError("give either --seeds or --repetitions, not both")
        if repetitions < 1:
            raise ConfigError(f"repetitions must be at least 1, got {repetitions}")
        return list(range(repetitions))
    if text is None or text == "":
        return [0]
    if not isinstance(text, str):
        seeds = [int(s) for s in text]
    else:
        seeds = []
        for part in text.split(","):
            part = part.strip()
            try:
                if ".." in part:
                    lo, hi = (int(v) for v in part.split(".."))
                    if hi < lo:
                        raise ValueError
                    seeds.extend(range(lo, hi + 1))
                else:
                    seeds.append(int(part))
            except ValueError:
                raise ConfigError(f"malformed seeds {text!r}: expected e.g. 0,1,2 or 0..9") from None
    if any(s < 0 for s in seeds):
        raise ConfigError(f"seeds must be non-negative, got {seeds}")
    if len(set(seeds)) != len(seeds):
        raise ConfigError(f"seeds must not repeat, got {seeds}")
    return seeds


def accepted_params(factory: Any) -> set[str] | None:
    """Keyword parameters a factory accepts (following ``**kwargs`` up the MRO); None if unknowable."""
    targets = [c.__init__ for c in inspect.getmro(factory) if "__init__" in vars(c)] if inspect.isclass(factory) else [factory]
    names: set[str] = set()
    for fn in targets:
        try:
            sig = inspect.signature(fn)
        except (TypeError, ValueError):
            return None
        has_var_kw = False
        for p in sig.parameters.values():
            if p.kind is inspect.Parameter.VAR_KEYWORD:
                has_var_kw = True
            elif p.kind in (inspect.Parameter.KEYWORD_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD) and p.name != "self":
                names.add(p.name)
        if not has_var_kw:
            return names
    return None


def check_params(kind: Kind, spec: Spec, params: Mapping[str, Any], reserved: Sequence[str] = ()) -> None:
    """Raise a one-line error for parameters the factory does not accept."""
    for key in params:
        if key in reserved:
            raise ConfigError(f"{kind} {spec.name!r}: {key!r} is set by the harness (use the --{key} option)")
    accepted = accepted_params(spec.load())
    if accepted is None:
        return
    unknown = sorted(set({**spec.defaults, **params}) - accepted)
    if unknown:
        choices = ", ".join(sorted(accepted - set(reserved))) or "(none)"
        raise ConfigError(f"{kind} {spec.name!r} has no parameter {unknown[0]!r}; its parameters: {choices}")


@dataclass(frozen=True)
class Experiment:
    """Everything that defines a comparison; the same Experiment and seeds give the same table."""

    designers: tuple[PluginChoice, ...]
    env: PluginChoice
    controller: PluginChoice | None = None
    shape: tuple[int, int] = DEFAULT_SHAPE
    population: int = 25
    budget: int = 1000
    seeds: tuple[int, ...] = (0,)
    #: end a run once it reaches the environment's optimum (the rest of its budget is not spent)
    stop_at_optimum: bool = False

    def validate(self, reg: Registry | None = None) -> None:
        """Check names, numbers and parameters; raises :class:`ConfigError` with one line."""
        reg = reg or registry()
        if not self.designers:
            raise ConfigError("no designer given")
        labels = [d.label for d in self.designers]
        if len(set(labels)) != len(labels):
            raise ConfigError(f"designers must not repeat: {', '.join(labels)}")
        if self.population < 1:
            raise ConfigError(f"population must be at least 1, got {self.population}")
        if self.budget < self.population:
            raise ConfigError(f"budget ({self.budget}) must be at least the population ({self.population})")
        if not self.seeds:
            raise ConfigError("no seed given")
        env_reg = reg.get("environment", self.env.name)
        check_params("environment", env_reg.spec, self.env.params, HARNESS_ENV_ARGS)
        needs_controller = bool(getattr(env_reg.spec, "requires_controller", False))
        if needs_controller and self.controller is None:
            known = ", ".join(reg.names("controller")) or "(none installed)"
            raise ConfigError(f"environment {self.env.name!r} needs a controller: add --controller NAME (known: {known})")
        if self.controller is not None:
            if not needs_controller:
                raise ConfigError(f"environment {self.env.name!r} scores bodies directly and takes no controller")
            ctrl_reg = reg.get("controller", self.controller.name)
            check_params("controller", ctrl_reg.spec, self.controller.params)
        for d in self.designers:
            check_params("designer", reg.get("designer", d.name).spec, d.params, HARNESS_DESIGNER_ARGS)

    def to_json(self) -> dict[str, Any]:
        data = asdict(self)
        data["designers"] = [d.to_json() for d in self.designers]
        data["env"] = self.env.to_json()
        data["controller"] = self.controller.to_json() if self.controller else None
        data["shape"] = list(self.shape)
        data["seeds"] = list(self.seeds)
        return data

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> Experiment:
        def choice(d: Mapping[str, Any] | None) -> PluginChoice | None:
            return None if d is None else PluginChoice(d["name"], dict(d.get("params", {})), d.get("label", d["name"]))

        return cls(
            designers=tuple(choice(d) for d in data["designers"]),  # type: ignore[misc]
            env=choice(data["env"]),  # type: ignore[arg-type]
            controller=choice(data.get("controller")),
            shape=tuple(data["shape"]),  # type: ignore[arg-type]
            population=int(data["population"]),
            budget=int(data["budget"]),
            seeds=tuple(int(s) for s in data["seeds"]),
            stop_at_optimum=bool(data.get("stop_at_optimum", False)),
        )
