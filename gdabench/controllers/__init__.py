"""Built-in controllers (registered through the ``gdabench_controllers`` hook)."""

from __future__ import annotations

from ..specs import ControllerSpec, hookimpl


@hookimpl
def gdabench_controllers() -> list[ControllerSpec]:
    return [
        ControllerSpec(
            name="open-loop",
            factory="gdabench.controllers.open_loop:OpenLoop",
            description="Periodic actuation: a sinusoid whose phase depends on the actuator's position (no learning)",
        ),
        ControllerSpec(
            name="ppo",
            factory="gdabench.controllers.ppo.controller:PPO",
            settings="gdabench.controllers.ppo.config:PPOConfig",  # checked before torch is imported
            description="PPO with Evolution Gym 2.0's settings, one policy per body; reward = best evaluation "
            "(timesteps=1e6 is faithful)",
        ),
        ControllerSpec(
            name="modular-ppo",
            factory="gdabench.controllers.modular.controller:ModularPPO",
            settings="gdabench.controllers.modular.config:modular_config",  # checked before torch is imported
            description="One per-voxel policy (ModularEvoGym's observations) learnt by a whole generation with PPO "
            "and carried to the next; reward = best evaluation",
        ),
    ]
