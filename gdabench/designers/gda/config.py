"""GDA's parameters as one frozen value, checked when it is made (errors belong to the command line).

What each parameter does is described on :class:`~gdabench.designers.gda.GenerationalDiffusion`
(where ``gdabench list`` reads it); this module holds their types, defaults and limits, and the
few settings derived from them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from ...body import CATEGORIES
from ...errors import ConfigError
from ...torch_runtime import resolve_device
from .sampling import SAMPLERS
from .schedule import make_schedule

#: compile='auto' compiles training and sampling, and speculate='auto' trains ahead on a second
#: core, when a run trains at least this many steps: about where the ~1 ms saved per step
#: repays a first-time compilation (under a minute) on a 2-core CPU
AUTO_COMPILE_STEPS = 50_000

_POSITIVE = ("survivors", "epochs", "dataset_size", "max_samples", "sample_steps", "prior_top")
_POSITIVE_OR_NONE = ("batch_size", "sample_batch", "pool")
_SWITCHES = ("compile", "speculate")  # true, false or auto


@dataclass(frozen=True)
class GdaConfig:
    """GDA's parameters (the thesis's defaults; the designer's docstring says what each does)."""

    survivors: int = 5
    epochs: int = 250
    dataset_size: int = 64
    batch_size: int | None = None
    lr: float = 1e-3
    steps: int = 500
    beta_start: float = 1e-4
    beta_end: float = 0.02
    schedule: str = "linear"
    sampler: str = "ddpm"
    sample_steps: int = 50
    sample_batch: int | None = None
    temperature: float = 1.0
    pool: int | None = None
    max_samples: int = 1000
    crossover: float = 0.0
    crossover_t: int = 150
    categories: str | None = None
    hybrid: int = 0
    target_mse: float | None = None
    warm_start: bool = False
    published_reencoding: bool = False
    prior: str | None = None
    prior_top: int = 5
    device: str = "cpu"
    threads: int | None = 1
    compile: bool | str = "auto"
    speculate: bool | str = "auto"

    def __post_init__(self) -> None:
        for name in _POSITIVE + _POSITIVE_OR_NONE:
            value = getattr(self, name)
            if not (value is None and name in _POSITIVE_OR_NONE) and not _positive_int(value):
                raise ConfigError(f"gda: {name} must be a positive integer, got {value!r}")
        if not self.lr > 0:
            raise ConfigError(f"gda: lr must be positive, got {self.lr!r}")
        if self.target_mse is not None and not self.target_mse > 0:
            raise ConfigError(f"gda: target_mse must be positive, got {self.target_mse!r}")
        if self.sampler not in SAMPLERS:
            raise ConfigError(f"gda: unknown sampler {self.sampler!r}; choose one of {', '.join(SAMPLERS)}")
        make_schedule(*self.schedule_args)
        if not self.temperature >= 0:
            raise ConfigError(f"gda: temperature must be at least 0, got {self.temperature!r}")
        resolve_device(self.device, "gda")
        if self.threads is not None and not _positive_int(self.threads):
            raise ConfigError(f"gda: threads must be at least 1, got {self.threads!r}")
        for name in _SWITCHES:
            if getattr(self, name) not in (True, False, "auto"):
                raise ConfigError(f"gda: {name} must be true, false or auto, got {getattr(self, name)!r}")
        if not 0.0 <= self.crossover <= 1.0:
            raise ConfigError(f"gda: crossover must be a share between 0 and 1, got {self.crossover!r}")
        if self.crossover and not 1 <= self.crossover_t < self.steps:
            raise ConfigError(
                f"gda: crossover_t must be a timestep between 1 and steps - 1 = {self.steps - 1}, got "
                f"{self.crossover_t!r}"
            )
        if not isinstance(self.hybrid, int) or isinstance(self.hybrid, bool) or self.hybrid < 0 or self.hybrid == 1:
            raise ConfigError(
                f"gda: hybrid must be 0 (never) or at least 2 (every hybrid-th generation), got {self.hybrid!r}"
            )
        if self.categories is not None:
            parse_shares(self.categories)
            if self.pool is not None:
                raise ConfigError("gda: categories and pool both choose among samples; give one of them")
        if self.speculate is True and not self.may_train_ahead:
            raise ConfigError(
                "gda: speculate=true needs device=cpu and none of warm_start, published_reencoding, hybrid"
            )

    def check_population(self, population: int) -> None:
        """Refuse settings that do not fit a generation of ``population`` bodies."""
        if self.pool is not None and self.pool < population:
            raise ConfigError(f"gda: pool must be at least the population ({population}), got {self.pool}")

    @property
    def schedule_args(self) -> tuple[str, int, float, float]:
        """:func:`.make_schedule`'s arguments."""
        return self.schedule, int(self.steps), float(self.beta_start), float(self.beta_end)

    @property
    def batch(self) -> int:
        """The training batch: ``batch_size``, or the thesis's one batch per survivor count."""
        return self.batch_size or self.survivors

    @property
    def shares(self) -> tuple[float, float, float] | None:
        """``categories`` as numbers, or None."""
        return None if self.categories is None else parse_shares(self.categories)

    @property
    def may_train_ahead(self) -> bool:
        """Whether the next model can be trained before this generation is told: it must not
        depend on this generation's weights, re-encodings or schedule."""
        on_cpu = resolve_device(self.device, "gda").type == "cpu"
        return on_cpu and not (self.warm_start or self.published_reencoding or self.hybrid)

    def trains_long(self, population: int, budget: int) -> bool:
        """Whether a run of ``budget`` evaluations trains enough steps on the CPU for compiling
        and training ahead to repay their start-up cost."""
        generations = -(-budget // population)
        steps = (generations - 1) * self.epochs * -(-self.dataset_size // self.batch)
        return resolve_device(self.device, "gda").type == "cpu" and steps >= AUTO_COMPILE_STEPS

    def compiles(self, population: int, budget: int) -> bool:
        return self.trains_long(population, budget) if self.compile == "auto" else bool(self.compile)


def _positive_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and value >= 1


def parse_shares(text: str) -> tuple[float, float, float]:
    """``'0.3/0.3/0.4'`` -> the target shares of near-copies, new materials and novel shapes (summing to 1)."""
    names = "/".join(c.replace(" ", "-") for c in CATEGORIES[1:])
    try:
        shares = tuple(float(part) for part in str(text).split("/"))
    except ValueError:
        shares = ()
    if len(shares) != 3 or any(not v >= 0 for v in shares) or not math.isclose(sum(shares), 1.0, abs_tol=1e-6):
        raise ConfigError(f"gda: categories must be three shares {names} summing to 1, e.g. 0.3/0.3/0.4; got {text!r}")
    return shares[0], shares[1], shares[2]
