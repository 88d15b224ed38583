"""One PPO minibatch step: TorchRL's ``ClipPPOLoss`` -> gradient -> norm clipping -> Adam.

Evolution Gym's minibatches hold 4 samples, so training takes one optimiser step per
environment step, and the cost of a step is almost all per-operation overhead (the networks
are tiny).  Two interchangeable implementations of the same step:

* ``compiled``: the whole step (loss forward, gradient through ``torch.func.grad``, clipping,
  torch's functional Adam) is one ``torch.compile`` graph, which removes nearly all of that
  overhead.  Tracing it takes seconds, so it is done once per process and loss setting, not
  once per body: the graph is traced on a template network and every body's parameters and
  optimiser state are *inputs* to it.  Bodies with other numbers of observations or actuators
  reuse it too: dynamo traces it again with those sizes dynamic on the second layout it meets,
  and once more for more observations than the hidden width (its layout choices compare the
  two), and then no more.
* eager: the textbook ``loss.backward(); clip_grad_norm_(); optimizer.step()``.

Both use Adam with stable-baselines3's epsilon of 1e-5 and share its state; they agree to
float rounding (a test checks it).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Sequence

import torch
from tensordict import TensorDict
from torch import nn
from torch.func import functional_call, grad_and_value
from torch.optim.adam import adam
from torchrl.objectives import ClipPPOLoss

from .networks import ActorCritic

#: stable-baselines3's Adam epsilon for PPO ("small values to avoid NaN in Adam")
ADAM_EPS = 1e-5
ADAM_BETAS = (0.9, 0.999)
#: the minibatch entries ClipPPOLoss reads
BATCH_KEYS = ("observation", "action", "action_log_prob", "advantage", "value_target")


@dataclass(frozen=True)
class LossSettings:
    """What fixes the PPO objective and optimiser step apart from the network's sizes."""

    clip_range: float
    vf_coef: float
    ent_coef: float
    learning_rate: float
    max_grad_norm: float
    hidden: tuple[int, ...] = (64, 64)


def ppo_loss(nets: ActorCritic, settings: LossSettings) -> ClipPPOLoss:
    """SB3's PPO objective as a ClipPPOLoss: squared-error value loss, per-minibatch advantage
    normalisation, analytic Gaussian entropy; no value clipping."""
    return ClipPPOLoss(
        nets.actor(),
        nets.critic(),
        clip_epsilon=settings.clip_range,
        entropy_coeff=settings.ent_coef,
        critic_coeff=settings.vf_coef,
        loss_critic_type="l2",
        normalize_advantage=True,
        functional=False,  # the networks' own parameters: nothing to copy in and out
        log_explained_variance=False,
    )


class Objective(nn.Module):
    """The summed PPO loss as a function of the networks' parameters (for ``functional_call``)."""

    def __init__(self, nets: ActorCritic, settings: LossSettings):
        super().__init__()
        self.nets = nets
        self._loss = (ppo_loss(nets, settings),)  # not a submodule: its parameters are the networks'

    def forward(self, *tensors: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """(summed loss, its value-function term, detached) on the minibatch given as one
        tensor per entry of :data:`BATCH_KEYS`."""
        batch = TensorDict(dict(zip(BATCH_KEYS, tensors)), batch_size=tensors[0].shape[:1])
        out = self._loss[0](batch)
        return out["loss_objective"] + out["loss_critic"] + out["loss_entropy"], out["loss_critic"].detach()


class _CompiledStep:
    """The fused step for one :class:`LossSettings`, traced once per process on a template network."""

    def __init__(self, settings: LossSettings):
        self.settings = settings
        # the template's sizes do not matter: the parameters passed in replace its own
        self.objective = Objective(ActorCritic(2, 2, settings.hidden), settings)
        self.names = [name for name, _ in self.objective.named_parameters()]
        self.compiled = torch.compile(
            self._step, fullgraph=True, options={"guard_filter_fn": _input_guards, "size_asserts": False}
        )

    def _step(
        self,
        params: list[torch.Tensor],
        exp_avgs: list[torch.Tensor],
        exp_avg_sqs: list[torch.Tensor],
        steps: list[torch.Tensor],
        *batch: torch.Tensor,
    ) -> torch.Tensor:
        def objective(named: dict[str, torch.Tensor]) -> tuple[torch.Tensor, torch.Tensor]:
            return functional_call(self.objective, named, batch)

        with torch.no_grad():  # the gradient comes from torch.func; the updates are in place
            named_grads, (loss, value_loss) = grad_and_value(objective, has_aux=True)(dict(zip(self.names, params)))
            grads = clipped(list(named_grads.values()), self.settings.max_grad_norm)
            beta1, beta2 = ADAM_BETAS
            adam(
                params,
                grads,
                exp_avgs,
                exp_avg_sqs,
                [],
                steps,
                amsgrad=False,
                beta1=beta1,
                beta2=beta2,
                lr=self.settings.learning_rate,
                weight_decay=0.0,
                eps=ADAM_EPS,
                maximize=False,
            )
        return torch.stack([loss, value_loss])


#: guards that stay on the compiled step: the inputs' metadata and sizes, and torch's global
#: state.  Dynamo would also guard ~1,400 attributes of the template network and loss, which
#: cost a third of a step to check; nothing ever changes them (the template is private, and
#: :func:`compiled_step` starts afresh when the settings change).
KEPT_GUARDS = frozenset(
    {
        "SHAPE_ENV",
        "GLOBAL_STATE",
        "GRAD_MODE",
        "DETERMINISTIC_ALGORITHMS",
        "DEFAULT_DEVICE",
        "TORCH_FUNCTION_STATE",
        "FUNCTORCH_STACK_MATCH",
        "AUTOGRAD_SAVED_TENSORS_HOOKS",
    }
)


def _input_guards(entries: list) -> list[bool]:
    return [e.guard_type in KEPT_GUARDS or (e.guard_type == "TENSOR_MATCH" and not e.is_global) for e in entries]


_current: _CompiledStep | None = None


def compiled_step(settings: LossSettings) -> _CompiledStep:
    """The process's compiled step for ``settings``: traced on first use, then reused by every
    body (a run trains all its bodies with the same settings).  Other settings drop it first:
    its guards do not look at the template, so two live templates could be confused."""
    global _current
    if _current is None or _current.settings != settings:
        torch.compiler.reset()
        _current = _CompiledStep(settings)
    return _current


def clipped(grads: Sequence[torch.Tensor], max_norm: float) -> list[torch.Tensor]:
    """``grads`` scaled as ``clip_grad_norm_`` scales gradients (same coefficient, on plain tensors)."""
    # per-tensor norms, which inductor fuses into its kernel (it would call _foreach_norm as a separate op)
    total = nn.utils.get_total_norm(grads, foreach=False)
    scale = torch.clamp(max_norm / (total + 1e-6), max=1.0)
    return [g * scale for g in grads]


class MinibatchUpdate:
    """Applies PPO minibatch steps to ``nets`` in place."""

    def __init__(self, nets: ActorCritic, settings: LossSettings, *, compiled: bool):
        if nets.hidden != settings.hidden:
            raise ValueError(f"networks with hidden layers {nets.hidden} but loss settings for {settings.hidden}")
        self.objective = Objective(nets, settings)
        self.params = dict(self.objective.named_parameters())
        self.max_grad_norm = settings.max_grad_norm
        self.optimizer = torch.optim.Adam(
            list(self.params.values()), lr=settings.learning_rate, betas=ADAM_BETAS, eps=ADAM_EPS
        )
        self.compiled = compiled
        if compiled:
            self._compiled = compiled_step(settings)
            assert self._compiled.names == list(self.params), "template and body networks differ in layout"
            self._state = self._initial_adam_state()
        #: seconds the first step took (it includes compiling, unless this process compiled before); None before it
        self.first_seconds: float | None = None

    def _initial_adam_state(
        self,
    ) -> tuple[list[torch.Tensor], list[torch.Tensor], list[torch.Tensor], list[torch.Tensor]]:
        """Adam's state as ``torch.optim.Adam`` would create it, created now so that the compiled
        step can take it as input (and the optimiser object holds it, as in the eager path)."""
        views, exp_avgs, exp_avg_sqs, steps = [], [], [], []
        for p in self.params.values():
            state = self.optimizer.state[p]
            state["step"] = torch.tensor(0.0, dtype=torch.float32)
            state["exp_avg"] = torch.zeros_like(p, memory_format=torch.preserve_format)
            state["exp_avg_sq"] = torch.zeros_like(p, memory_format=torch.preserve_format)
            views.append(p.detach())  # same storage: the compiled step updates the parameters in place
            exp_avgs.append(state["exp_avg"])
            exp_avg_sqs.append(state["exp_avg_sq"])
            steps.append(state["step"])
        return views, exp_avgs, exp_avg_sqs, steps

    def __call__(self, *tensors: torch.Tensor) -> torch.Tensor:
        """One step on the minibatch given as one tensor per entry of :data:`BATCH_KEYS`;
        returns the minibatch's (loss, value loss) before the step, detached, stacked."""
        if self.first_seconds is None:
            start = time.perf_counter()
            loss = self._step(*tensors)
            self.first_seconds = time.perf_counter() - start
            return loss
        return self._step(*tensors)

    def _step(self, *tensors: torch.Tensor) -> torch.Tensor:
        if self.compiled:
            return self._compiled.compiled(*self._state, *tensors)
        self.optimizer.zero_grad(set_to_none=True)
        loss, value_loss = self.objective(*tensors)
        loss.backward()
        nn.utils.clip_grad_norm_(self.params.values(), self.max_grad_norm)
        self.optimizer.step()
        return torch.stack([loss.detach(), value_loss])
