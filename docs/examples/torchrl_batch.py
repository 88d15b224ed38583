"""PPO with TorchRL's own parts on a batch of bodies: one ``GymEnv`` per body, a ``SerialEnv`` over them,
a collector, GAE and ``ClipPPOLoss``.

    python docs/examples/torchrl_batch.py --frames 20000

The bodies share their voxels and differ in actuator directions, so their observations and actions have
the same sizes and one policy (shared by the batch, unlike gdabench's ``ppo``, which trains one per body)
steps them all.  Prints each iteration's mean reward per step and the losses.
"""

from __future__ import annotations

import argparse
import functools

import torch
from tensordict.nn import NormalParamExtractor, TensorDictModule
from torch import nn
from torchrl.collectors import Collector
from torchrl.envs import DoubleToFloat, GymEnv, SerialEnv, TransformedEnv
from torchrl.modules import MLP, ProbabilisticActor, TanhNormal, ValueOperator
from torchrl.objectives import ClipPPOLoss
from torchrl.objectives.value import GAE

import gdabench  # noqa: F401 - registers gdabench/Walker-v2 (the voxel engine's walker) with Gymnasium

BODIES = ["44444/44444/44444/40004/40004", "33333/44444/44444/40004/40004", "44444/34443/44444/30003/40004"]


def make_env(bodies: list[str]) -> TransformedEnv:
    """The bodies' walkers side by side, float32 for the networks."""
    walkers = [functools.partial(GymEnv, "gdabench/Walker-v2", body=body) for body in bodies]
    return TransformedEnv(SerialEnv(len(bodies), walkers), DoubleToFloat())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=20_000, help="environment steps in all")
    parser.add_argument("--per-batch", type=int, default=1_024, help="steps collected per iteration")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    torch.manual_seed(args.seed)
    env = make_env(BODIES)
    env.set_seed(args.seed)
    n_obs = env.observation_spec["observation"].shape[-1]
    n_act = env.action_spec.shape[-1]

    mlp = MLP(in_features=n_obs, out_features=2 * n_act, num_cells=[64, 64])
    actor_net = nn.Sequential(mlp, NormalParamExtractor())
    actor = ProbabilisticActor(
        TensorDictModule(actor_net, in_keys=["observation"], out_keys=["loc", "scale"]),
        spec=env.action_spec, in_keys=["loc", "scale"], distribution_class=TanhNormal,
        distribution_kwargs={"low": env.action_spec_unbatched.space.low, "high": env.action_spec_unbatched.space.high},
        return_log_prob=True,
    )  # fmt: skip
    critic = ValueOperator(MLP(in_features=n_obs, out_features=1, num_cells=[64, 64]), in_keys=["observation"])
    collector = Collector(env, actor, frames_per_batch=args.per_batch, total_frames=args.frames,
                          auto_register_policy_transforms=False)  # fmt: skip
    advantage = GAE(gamma=0.99, lmbda=0.95, value_network=critic, average_gae=True)
    loss = ClipPPOLoss(actor, critic, clip_epsilon=0.1, entropy_coeff=0.01, critic_coeff=0.5, loss_critic_type="l2",
                       normalize_advantage=True)
    optimizer = torch.optim.Adam(loss.parameters(), lr=2.5e-4)

    for i, data in enumerate(collector):  # data: [bodies, steps] transitions
        for _ in range(4):  # epochs over the batch
            advantage(data)
            for minibatch in data.reshape(-1).split(256):
                losses = loss(minibatch)
                total = losses["loss_objective"] + losses["loss_critic"] + losses["loss_entropy"]
                optimizer.zero_grad()
                total.backward()
                nn.utils.clip_grad_norm_(loss.parameters(), 0.5)
                optimizer.step()
        reward = data["next", "reward"].mean(dim=tuple(range(1, data.ndim + 1)))
        print(f"iteration {i}: mean reward per step by body {[round(float(r), 4) for r in reward]}, "
              f"loss {float(total.detach()):.4f}", flush=True)  # fmt: skip
    collector.shutdown()  # closes the environments too


if __name__ == "__main__":
    main()
