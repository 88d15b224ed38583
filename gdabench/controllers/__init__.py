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
            description="PPO on TorchRL with Evolution Gym 2.0's settings; reward = best evaluation (timesteps=1e6 is "
                        "faithful)",
        ),
    ]
