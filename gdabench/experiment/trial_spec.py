"""A trial as resolved: what a worker needs to run one designer on one environment with one seed.

Plain data (and the one function that builds a plugin object from its recipe), apart from
:mod:`gdabench.experiment.plan`, which resolves an experiment through the plugin registry: the hook
specifications and the trial name these types without importing the registry.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping

from .. import seeding
from ..designer import Designer
from ..errors import ConfigError, GdabenchError, PluginError, one_line
from ..specs import Factory


def build_plugin(kind: str, label: str, recipe: Factory, **harness: Any) -> Any:
    """Build a plugin object; a constructor's refusal of its parameters is a one-line input error."""
    try:
        return recipe.build(**harness)
    except GdabenchError:
        raise
    except (ValueError, TypeError) as exc:
        raise ConfigError(f"{kind} {label!r}: bad parameter: {one_line(exc)}") from None
    except Exception as exc:  # noqa: BLE001 - a plugin that cannot even be built is the plugin's fault
        raise PluginError(f"{kind} {label!r} could not be built: {one_line(exc)}") from None


@dataclass(frozen=True)
class DesignerRecipe:
    """A designer as resolved: label, registered name, factory and its converted parameters."""

    label: str
    name: str
    factory: Factory

    @property
    def params(self) -> dict[str, Any]:
        return dict(self.factory.params)

    def build(self, shape: tuple[int, int], population: int, budget: int, seed: int) -> Designer:
        """The designer of one trial, seeded from the run's seed as every trial is."""
        harness = {
            "shape": tuple(shape),
            "population": population,
            "budget": budget,
            "seed": seeding.designer_seed(seed),
        }
        designer = build_plugin("designer", self.label, self.factory, **harness)
        if not isinstance(designer, Designer):
            raise PluginError(
                f"designer {self.label!r}: factory returned {type(designer).__name__}, not a gdabench.Designer"
            )
        return designer


@dataclass(frozen=True)
class EnvRecipe:
    """An environment as resolved, with what the harness reads from it once."""

    label: str
    name: str
    factory: Factory  # includes the body shape
    version: str | None
    optimum: float | None
    deterministic: bool
    package: tuple[str, str]


@dataclass(frozen=True)
class TrialSpec:
    """One designer on one environment with one seed: everything a worker needs to run it."""

    index: int  # position in the experiment's order (seed, environment, designer)
    name: str  # file-system name of its checkpoint, pending rows and artifacts
    designer: DesignerRecipe
    env: EnvRecipe
    controller: Factory | None
    seed: int
    repetition: int
    shape: tuple[int, int]
    population: int
    budget: int
    stop_at_optimum: bool
    title: str  # how progress lines and messages name the trial
    constants: Mapping[str, Any] = field(default_factory=dict)  # result columns every row of the trial shares
    #: what an evaluation cache entry depends on besides body and seed; None: not cacheable
    cache_context: Mapping[str, Any] | None = None

    @property
    def key(self) -> tuple[str, str, int]:
        """(environment, designer, seed) labels: how the results table identifies the trial."""
        return (self.env.label, self.designer.label, self.seed)
