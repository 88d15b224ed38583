"""``modular-ppo``'s settings: per-body ``ppo``'s (Evolution Gym 2.0's PPO hyperparameters), checked the same way.

A shared policy takes every :class:`~gdabench.controllers.ppo.config.PPOConfig` setting but three: ``init``
(a shared policy is always carried on), ``normalize_obs`` (its inputs are already relative positions and
materials) and ``device`` (it trains on the CPU).  ``batch_size`` counts samples *per body*.  Light: no torch.
"""

from __future__ import annotations

from typing import Any

from ...errors import ConfigError
from ...params import config_signature
from ..ppo.config import PPOConfig

NAME = "modular-ppo"
#: PPOConfig fields that do not apply to one shared policy
NOT_SHARED = ("init", "normalize_obs", "device")


def modular_config(**params: Any) -> PPOConfig:
    """The settings of a ``modular-ppo`` training, or a one-line :class:`ConfigError` naming ``modular-ppo``."""
    for name in NOT_SHARED:
        if name in params:
            raise ConfigError(f"{NAME}: {name} is a ppo setting that a shared policy does not take")
    try:
        return PPOConfig(**params)
    except TypeError as exc:  # an unknown keyword
        raise ConfigError(f"{NAME}: {exc}".replace("PPOConfig.__init__()", "it")) from None
    except ConfigError as exc:
        raise ConfigError(f"{NAME}: {str(exc).removeprefix('ppo: ')}") from None


_FULL = config_signature(PPOConfig)
#: PPOConfig's fields less NOT_SHARED: what the controller takes (``gdabench info`` lists it)
SIGNATURE = _FULL.replace(parameters=[p for p in _FULL.parameters.values() if p.name not in NOT_SHARED])
# the harness checks parameters against the checker's signature before anything runs
modular_config.__signature__ = SIGNATURE.replace(  # type: ignore[attr-defined]
    parameters=list(SIGNATURE.parameters.values())[1:]
)
