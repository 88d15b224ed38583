"""TorchRL's ``ClipPPOLoss`` against ``ppo``'s hand-written lockstep loss: the same numbers, and their cost.

    python benchmarks/compare/ppo_clip_loss.py                       # all three parts
    python benchmarks/compare/ppo_clip_loss.py --parts check,update  # without the (minutes-long) generations

``ClipPPOLoss`` runs once per body under ``torch.vmap``, over the stacked per-body parameters of ``ppo``'s
networks (tensordict's functional idiom: the parameters as a TensorDict with the bodies as its batch
dimension, swapped into the loss module with ``to_module``), so that its advantage normalisation and
means stay inside each body.  Two adaptations, both exact: the policy is the body's diagonal Gaussian
over its own actions (padded actions masked out, as ``Stacked.log_prob`` does), and the entropy skips
TorchRL's finiteness check, which is data-dependent control flow that ``torch.vmap`` refuses (the
entropy is analytic, so the check never changes it); ``reduction="none"`` and a mean per body, since
TorchRL's reduction squeezes a dimension vmap has taken away.  The optimiser step after the loss (per-body
gradient clipping, fused Adam) is the same in both arms.

Parts:

* ``check``: both losses (each body's total, and its value loss) on random minibatches of 25 bodies of
  walker-like sizes; prints the largest absolute difference;
* ``update``: CPU time of one lockstep update step (loss, backward, clipping, Adam; 25 bodies, 4 samples
  each: Evolution Gym's minibatch), the two arms interleaved, median over rounds;
* ``generation``: CPU time of a co-design generation's training (``benchmarks/compare/codesign_speed.py``'s
  lockstep arm: 25 random 5x5 bodies, ``--timesteps`` each, on the voxel walker), each arm in a fresh
  process on one core, interleaved; the TorchRL arm swaps ``LockstepUpdate.losses`` for the one here.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

import gdabench  # noqa: F401  # isort: skip - before torch: it pins torch's CPU kernels to AVX2 (gdabench.cpu)
import torch
from tensordict import TensorDict
from tensordict.nn import TensorDictModule, TensorDictSequential
from torch import nn
from torchrl.modules import ProbabilisticActor, ValueOperator
from torchrl.objectives import ClipPPOLoss

from gdabench.controllers.ppo.networks import HALF_LOG_2PI, ActorCritic, Stacked
from gdabench.controllers.ppo.update import LockstepUpdate, LossSettings, Minibatch

torch.distributions.Distribution.set_default_validate_args(False)  # argument checks are data-dependent too


class MaskedNormal(torch.distributions.Distribution):
    """A body's diagonal Gaussian over its own actions (padded ones masked out), as ``Stacked.log_prob`` has it."""

    arg_constraints: dict = {}
    has_rsample = True

    def __init__(self, loc: torch.Tensor, log_std: torch.Tensor, mask: torch.Tensor):
        self.loc, self.log_std, self.mask = loc, log_std, mask
        super().__init__(batch_shape=loc.shape[:-1], event_shape=loc.shape[-1:], validate_args=False)

    def log_prob(self, value: torch.Tensor) -> torch.Tensor:
        z = (value - self.loc) * torch.exp(-self.log_std)
        return -((0.5 * z.square() + self.log_std + HALF_LOG_2PI) * self.mask).sum(-1)

    def entropy(self) -> torch.Tensor:
        return ((0.5 + HALF_LOG_2PI + self.log_std) * self.mask).sum(-1)

    def rsample(self, sample_shape: torch.Size | None = None) -> torch.Tensor:
        shape = torch.Size(sample_shape or ()) + self.loc.shape
        return self.loc + torch.exp(self.log_std) * torch.randn(shape)

    @property
    def mean(self) -> torch.Tensor:
        return self.loc

    @property
    def deterministic_sample(self) -> torch.Tensor:
        return self.loc


class LogStd(nn.Module):
    """The Gaussian's state-independent log standard deviation, one per (padded) action."""

    def __init__(self, n: int):
        super().__init__()
        self.log_std = nn.Parameter(torch.zeros(n))

    def forward(self, loc: torch.Tensor) -> torch.Tensor:
        return self.log_std.expand_as(loc)


class Column0(nn.Module):
    """The critic: column 0 of the value network's (padded) output, as ``Stacked.value`` reads it."""

    def __init__(self, net: nn.Module):
        super().__init__()
        self.net = net

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.net(x)[..., :1]


class VmapClipPPOLoss(ClipPPOLoss):
    """ClipPPOLoss whose entropy skips the finiteness check (data-dependent control flow, which torch.vmap
    refuses); the distribution's entropy is analytic, so the check never changes the value."""

    def _get_entropy(self, dist, adv_shape):
        return dist.entropy().unsqueeze(-1)


def mlp(widths: list[int]) -> nn.Sequential:
    layers: list[nn.Module] = []
    for i, (a, b) in enumerate(zip(widths, widths[1:])):
        layers.append(nn.Linear(a, b))
        if i < len(widths) - 2:
            layers.append(nn.Tanh())
    return nn.Sequential(*layers)


def build(nets: Stacked, s: LossSettings) -> ClipPPOLoss:
    """One body's actor-critic (padded widths) in a ClipPPOLoss with ``s``'s coefficients, SB3's objective."""
    n_act = nets.n_act
    widths = [nets.n_obs, *[nets.mean_layers[i][0].shape[2] for i in range(len(nets.mean_layers) - 1)]]
    loc = TensorDictModule(mlp([*widths, n_act]), in_keys=["observation"], out_keys=["loc"])
    std = TensorDictModule(LogStd(n_act), in_keys=["loc"], out_keys=["log_std"])
    actor = ProbabilisticActor(TensorDictSequential(loc, std), in_keys=["loc", "log_std", "mask"],
                               distribution_class=MaskedNormal, return_log_prob=True)  # fmt: skip
    critic = ValueOperator(Column0(mlp([*widths, nets.value_layers[-1][0].shape[2]])), in_keys=["observation"])
    return VmapClipPPOLoss(
        actor, critic, clip_epsilon=s.clip_range, entropy_coeff=s.ent_coef, critic_coeff=s.vf_coef,
        loss_critic_type="l2", normalize_advantage=True, functional=False, reduction="none",
    )  # fmt: skip


def torchrl_params(loss: ClipPPOLoss, nets: Stacked) -> TensorDict:
    """The loss module's parameters for every body (batch dimension: bodies), as views of ``nets``' own
    stacked leaves, so gradients reach the same tensors the optimiser steps."""
    base = TensorDict.from_module(loss)
    d = {}
    for i, (w, b) in zip(range(0, 2 * len(nets.mean_layers), 2), nets.mean_layers):  # Linear, Tanh, Linear, ...
        d[f"actor_network.module.0.module.0.module.{i}.weight"] = w.transpose(1, 2)
        d[f"actor_network.module.0.module.0.module.{i}.bias"] = b
    d["actor_network.module.0.module.1.module.log_std"] = nets.log_std
    for i, (w, b) in zip(range(0, 2 * len(nets.value_layers), 2), nets.value_layers):
        d[f"critic_network.module.net.{i}.weight"] = w.transpose(1, 2)
        d[f"critic_network.module.net.{i}.bias"] = b
    for k in ("entropy_coeff", "critic_coeff", "clip_epsilon"):
        d[k] = base[k].expand(nets.n_bodies)
    return TensorDict(d, batch_size=[nets.n_bodies]).unflatten_keys(".")


def torchrl_losses(
    loss: ClipPPOLoss, nets: Stacked, batch: Minibatch, key: str
) -> tuple[torch.Tensor, torch.Tensor]:
    """Each body's (summed loss, value loss) by ClipPPOLoss, vmapped over the bodies."""
    params = torchrl_params(loss, nets)
    bodies, m = batch.obs.shape[:2]
    td = TensorDict({"observation": batch.obs, "action": batch.action, key: batch.log_prob,
                     "advantage": batch.advantage.unsqueeze(-1), "value_target": batch.returns.unsqueeze(-1),
                     "mask": nets.act_mask.unsqueeze(1).expand(bodies, m, -1)}, batch_size=[bodies, m])  # fmt: skip

    def one(p: TensorDict, t: TensorDict) -> tuple[torch.Tensor, torch.Tensor]:
        with p.to_module(loss):
            out = loss(t)
        total = out["loss_objective"].mean() + out["loss_critic"].mean() + out["loss_entropy"].mean()
        return total, out["loss_critic"].mean()
    total, critic = torch.vmap(one, (0, 0), randomness="same")(params, td)
    return total, critic / loss.critic_coeff


_LOSSES: dict[int, ClipPPOLoss] = {}


def torchrl_update_losses(self: LockstepUpdate, batch: Minibatch) -> tuple[torch.Tensor, torch.Tensor]:
    """``LockstepUpdate.losses`` computed by ClipPPOLoss (its module built once per set of networks)."""
    if id(self.nets) not in _LOSSES:
        _LOSSES[id(self.nets)] = build(self.nets, self.settings)
    return torchrl_losses(_LOSSES[id(self.nets)], self.nets, batch, KEY)


KEY = "action_log_prob"  # ClipPPOLoss's key for the log-probability the samples were drawn with
BODIES, SAMPLES = 25, 4


def walker_like(seed: int) -> tuple[Stacked, LossSettings]:
    torch.manual_seed(seed)
    sizes = [(2 + 2 * (10 + i % 20), 4 + i % 12) for i in range(BODIES)]  # walker-like observation and action sizes
    nets = Stacked([ActorCritic(o, a) for o, a in sizes], max(o for o, _ in sizes), max(a for _, a in sizes))
    return nets, LossSettings(0.1, 0.5, 0.01, 2.5e-4, 0.5)


def minibatch(nets: Stacked) -> Minibatch:
    shape = (BODIES, SAMPLES)
    return Minibatch(torch.randn(*shape, nets.n_obs), torch.randn(*shape, nets.n_act), torch.randn(shape),
                     torch.randn(shape), torch.randn(shape))  # fmt: skip


def check(seeds: int) -> float:
    worst = 0.0
    for seed in range(seeds):
        nets, settings = walker_like(seed)
        batch = minibatch(nets)
        hand = LockstepUpdate(nets, settings)
        with torch.no_grad():
            a_total, a_value = hand.losses(batch)
            b_total, b_value = torchrl_losses(build(nets, settings), nets, batch, KEY)
        worst = max(worst, float((a_total - b_total).abs().max()), float((a_value - b_value).abs().max()))
    print(f"check: largest |difference| over {seeds} minibatches of {BODIES} bodies (total and value loss): "
          f"{worst:.3g}")  # fmt: skip
    return worst


def time_updates(rounds: int, steps: int) -> dict[str, float]:
    torch.set_num_threads(1)
    nets, settings = walker_like(0)
    batch = minibatch(nets)
    arms = {"hand-written": LockstepUpdate(nets, settings), "ClipPPOLoss": LockstepUpdate(nets, settings)}
    loss = build(nets, settings)
    arms["ClipPPOLoss"].losses = lambda b: torchrl_losses(loss, nets, b, KEY)  # type: ignore[method-assign]
    times: dict[str, list[float]] = {name: [] for name in arms}
    for update in arms.values():
        update(batch)  # warm up
    for _ in range(rounds):
        for name, update in arms.items():
            start = time.process_time()
            for _ in range(steps):
                update(batch)
            times[name].append((time.process_time() - start) / steps)
    medians = {name: statistics.median(t) for name, t in times.items()}
    ratio = medians["ClipPPOLoss"] / medians["hand-written"]
    print(f"update step, CPU ms (median of {rounds} rounds of {steps}): "
          f"hand-written {1e3 * medians['hand-written']:.2f}, "
          f"ClipPPOLoss {1e3 * medians['ClipPPOLoss']:.2f} (x{ratio:.2f})")  # fmt: skip
    return medians


def one_generation(arm: str, timesteps: int, seed: int) -> dict:
    sys.path.insert(0, str(Path(__file__).parent))
    import codesign_speed

    codesign_speed._one_core()
    if arm == "ClipPPOLoss":
        LockstepUpdate.losses = torchrl_update_losses  # type: ignore[method-assign]
    return codesign_speed.run_lockstep(codesign_speed.bodies(BODIES, seed), timesteps, seed)


def generations(repeats: int, timesteps: int, seed: int) -> dict[str, float]:
    cpu: dict[str, list[float]] = {"hand-written": [], "ClipPPOLoss": []}
    for r in range(repeats):
        for arm in (("hand-written", "ClipPPOLoss") if r % 2 == 0 else ("ClipPPOLoss", "hand-written")):
            out = subprocess.run([sys.executable, __file__, "--one", arm, "--timesteps", str(timesteps),
                                  "--seed", str(seed)], capture_output=True, text=True, check=True).stdout  # fmt: skip
            row = json.loads(out.strip().splitlines()[-1])
            cpu[arm].append(row["cpu"])
            print(f"  {arm}: {row['cpu']:.1f} CPU s, {row['steps'] / row['cpu']:,.0f} env steps per CPU s", flush=True)
    medians = {arm: statistics.median(v) for arm, v in cpu.items()}
    ratio = medians["ClipPPOLoss"] / medians["hand-written"]
    print(f"generation ({BODIES} bodies x {timesteps} timesteps), CPU s (median of {repeats}): hand-written "
          f"{medians['hand-written']:.1f}, ClipPPOLoss {medians['ClipPPOLoss']:.1f} (x{ratio:.2f})")  # fmt: skip
    return medians


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--parts", default="check,update,generation")
    parser.add_argument("--seeds", type=int, default=5, help="minibatches compared")
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--steps", type=int, default=50, help="update steps per timed round")
    parser.add_argument("--repeats", type=int, default=2, help="generations per arm")
    parser.add_argument("--timesteps", type=int, default=2560, help="timesteps per body in a generation")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--one", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        print(json.dumps(one_generation(args.one, args.timesteps, args.seed)))
        return
    parts = args.parts.split(",")
    if "check" in parts:
        check(args.seeds)
    if "update" in parts:
        time_updates(args.rounds, args.steps)
    if "generation" in parts:
        generations(args.repeats, args.timesteps, args.seed)


if __name__ == "__main__":
    main()
