"""One PPO minibatch step: TorchRL's ``ClipPPOLoss`` -> gradient -> norm clipping -> Adam.

Evolution Gym's minibatches hold 4 samples, so training takes one optimiser step per
environment step, and the cost of a step is almost all per-operation overhead (the networks
are tiny).  Two interchangeable implementations of the same step:

* ``compiled``: the whole step (loss forward, gradient through ``torch.func.grad``, clipping,
  ``torch.optim.Adam``) is traced by ``torch.compile`` into one graph, which removes nearly
  all of that overhead.  Compiling takes seconds per body, so it pays off on long trainings.
* eager: the textbook ``loss.backward(); clip_grad_norm_(); optimizer.step()``.

Both use Adam with stable-baselines3's epsilon of 1e-5; they agree to float rounding.
"""

from __future__ import annotations

import time

import torch
from tensordict import TensorDict
from torch import nn
from torch.func import functional_call, grad_and_value
from torchrl.objectives import ClipPPOLoss

from .networks import ActorCritic

#: stable-baselines3's Adam epsilon for PPO ("small values to avoid NaN in Adam")
ADAM_EPS = 1e-5
#: the minibatch entries ClipPPOLoss reads
BATCH_KEYS = ("observation", "action", "action_log_prob", "advantage", "value_target")


def ppo_loss(nets: ActorCritic, *, clip_range: float, vf_coef: float, ent_coef: float) -> ClipPPOLoss:
    """SB3's PPO objective as a ClipPPOLoss: squared-error value loss, per-minibatch advantage
    normalisation, analytic Gaussian entropy; no value clipping."""
    return ClipPPOLoss(
        nets.actor(),
        nets.critic(),
        clip_epsilon=clip_range,
        entropy_coeff=ent_coef,
        critic_coeff=vf_coef,
        loss_critic_type="l2",
        normalize_advantage=True,
        functional=False,  # the networks' own parameters: nothing to copy in and out
        log_explained_variance=False,
    )


class _Objective(nn.Module):
    """The summed PPO loss as a function of the networks' parameters (for ``functional_call``)."""

    def __init__(self, nets: ActorCritic, loss: ClipPPOLoss):
        super().__init__()
        self.nets = nets
        self._loss = (loss,)  # not a submodule: its parameters are the networks'

    def forward(self, batch: TensorDict) -> tuple[torch.Tensor, torch.Tensor]:
        """(summed loss, its value-function term, detached)."""
        out = self._loss[0](batch)
        return out["loss_objective"] + out["loss_critic"] + out["loss_entropy"], out["loss_critic"].detach()


class MinibatchUpdate:
    """Applies PPO minibatch steps to ``nets`` in place."""

    def __init__(self, nets: ActorCritic, loss: ClipPPOLoss, *, learning_rate: float, max_grad_norm: float, compiled: bool):
        self.objective = _Objective(nets, loss)
        self.params = dict(self.objective.named_parameters())
        self.max_grad_norm = max_grad_norm
        self.optimizer = torch.optim.Adam(list(self.params.values()), lr=learning_rate, eps=ADAM_EPS)
        self.compiled = compiled
        self._step = torch.compile(self._functional_step) if compiled else self._autograd_step
        #: seconds the first step took (it includes compiling); None before the first step
        self.first_seconds: float | None = None

    def __call__(self, *tensors: torch.Tensor) -> torch.Tensor:
        """One step on the minibatch given as one tensor per entry of :data:`BATCH_KEYS`;
        returns the minibatch's (loss, value loss) before the step, detached, stacked."""
        if self.first_seconds is None:
            start = time.perf_counter()
            loss = self._step(*tensors)
            self.first_seconds = time.perf_counter() - start
            return loss
        return self._step(*tensors)

    def _batch(self, tensors: tuple[torch.Tensor, ...]) -> TensorDict:
        return TensorDict(dict(zip(BATCH_KEYS, tensors)), batch_size=tensors[0].shape[:1])

    def _autograd_step(self, *tensors: torch.Tensor) -> torch.Tensor:
        self.optimizer.zero_grad(set_to_none=True)
        loss, value_loss = self.objective(self._batch(tensors))
        loss.backward()
        nn.utils.clip_grad_norm_(self.params.values(), self.max_grad_norm)
        self.optimizer.step()
        return torch.stack([loss.detach(), value_loss])

    def _functional_step(self, *tensors: torch.Tensor) -> torch.Tensor:
        batch = self._batch(tensors)
        detached = {name: p.detach() for name, p in self.params.items()}
        grads, (loss, value_loss) = grad_and_value(lambda params: functional_call(self.objective, params, (batch,)), has_aux=True)(detached)
        for name, p in self.params.items():
            p.grad = grads[name]
        nn.utils.clip_grad_norm_(self.params.values(), self.max_grad_norm)
        self.optimizer.step()
        return torch.stack([loss.detach(), value_loss])

    def release(self) -> None:
        """Drop compiled code (it is specific to this body's network shapes)."""
        if self.compiled:
            torch.compiler.reset()

