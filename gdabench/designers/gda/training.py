"""Training the noise predictor on a generation's survivors (thesis Algorithm 1).

Faithful to the author's loop: the survivors, repeated to a dataset of 64 items, are shuffled
every epoch and cut into batches of 5 (12 batches of 5 and one of 4); each item gets a timestep
``t ~ U{1..T-1}`` and Gaussian noise, and AdamW (lr 1e-3, PyTorch's default weight decay 0.01)
minimises the MSE between the true and the predicted noise.

What makes it fast is not the arithmetic but the overhead around it (a step is a few
milliseconds of tiny kernels): the forward and backward passes are hand-derived
(:mod:`.backprop`), all parameters and gradients live in two flat buffers so the optimizer is
one fused kernel over all of them (``torch.optim.AdamW(fused=True)``; the count: :mod:`.model`), each epoch's
shuffle, timesteps, noise and noisy inputs are drawn and computed in a handful of batched
operations, and the time features of every timestep are tabulated once.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np
import torch

from .backprop import FastUNet
from .model import UNet, reset_parameters
from .schedule import NoiseSchedule, make_schedule


@dataclass(frozen=True)
class FitResult:
    """What one training run did: epochs run, mean loss of the last epoch, wall time."""

    epochs: int
    loss: float
    seconds: float


@dataclass(frozen=True)
class TrainerSpec:
    """Everything that makes two trainers compute the same numbers (trainers and training
    processes are shared by it)."""

    schedule: tuple[str, int, float, float]  # make_schedule's arguments
    shape: tuple[int, int]
    lr: float
    compile: bool
    threads: int | None
    device: str = "cpu"

    def make(self) -> Trainer:
        return Trainer(
            make_schedule(*self.schedule), shape=self.shape, lr=self.lr, device=self.device, compile=self.compile
        )


#: trainers shared by the designers of one process (they run one after another): every
#: generation starts from fresh weights anyway, and sharing compiles the step only once
_TRAINERS: dict[TrainerSpec, Trainer] = {}


def shared_trainer(spec: TrainerSpec) -> Trainer:
    """This process's trainer for ``spec``, made on first use."""
    if spec not in _TRAINERS:
        _TRAINERS[spec] = spec.make()
    return _TRAINERS[spec]


def _compiled_marker(spec: TrainerSpec) -> Path | None:
    """A file beside inductor's on-disk cache saying that this machine has compiled ``spec``'s kernels once
    (later runs load them from that cache in seconds); None where the cache cannot be found."""
    try:
        from torch._inductor.runtime.cache_dir_utils import cache_dir

        key = repr((torch.__version__, spec.shape, spec.schedule, spec.device, os.environ.get("ATEN_CPU_CAPABILITY")))
        return Path(cache_dir()) / f"gdabench-gda-{hashlib.sha1(key.encode()).hexdigest()[:16]}.done"
    except Exception:  # noqa: BLE001 - a private module of torch's: the note is a courtesy
        return None


def compiling_note(spec: TrainerSpec) -> str:
    """What the progress display says while this process compiles ``spec``'s kernels (minutes the first
    time on a machine, with nothing else moving)."""
    marker = _compiled_marker(spec)
    return "compiling kernels" + (" (first run on this machine)" if marker is not None and not marker.exists() else "")


def mark_compiled(spec: TrainerSpec) -> None:
    marker = _compiled_marker(spec)
    if marker is not None:
        with contextlib.suppress(OSError):
            marker.touch()


def repeat_to(data: torch.Tensor, size: int) -> torch.Tensor:
    """The survivors repeated in order and cut to ``size`` items, as the author's dataset is."""
    reps = -(-size // data.shape[0])
    return data.repeat(reps, *([1] * (data.dim() - 1)))[:size]


class Trainer:
    """One U-Net (for sampling), its fast training step, and AdamW over the flat parameters.

    :meth:`reset` makes the model fresh (new random weights, new optimizer state) without
    allocating a new one; :meth:`fit` trains it and leaves the trained weights in ``model``.
    """

    def __init__(
        self,
        schedule: NoiseSchedule,
        *,
        shape: tuple[int, int] = (5, 5),
        lr: float = 1e-3,
        weight_decay: float = 0.01,
        device: torch.device | str = "cpu",
        compile: bool = False,
    ):
        self.device = torch.device(device)
        self.compile = compile
        self._compiled: dict[int, Callable[..., torch.Tensor]] = {}
        self._sample_forward: Callable[[torch.Tensor, torch.Tensor], torch.Tensor] | None = None
        with torch.random.fork_rng(devices=[]):  # construction draws weights that reset() replaces
            self.model = UNet().to(self.device)
            self._cpu_model = self.model if self.device.type == "cpu" else UNet()
        self.net = FastUNet(self.model, shape, self.device)
        self.lr, self.weight_decay = float(lr), float(weight_decay)
        self.set_schedule(schedule)
        self.optimizer = self._new_optimizer()

    @property
    def warm(self) -> bool:
        """Whether the training step is compiled (or runs eagerly): nothing left to compile."""
        return not self.compile or bool(self._compiled)

    @property
    def sampling_warm(self) -> bool:
        """Whether sampling's network is compiled (or runs eagerly): nothing left to compile for sampling."""
        return not self.compile or self._sample_forward is not None

    @property
    def flat(self) -> torch.Tensor:
        """All weights in one vector (the training layout; see :mod:`.backprop`)."""
        return self.net.params.flat

    def _step(self, size: int) -> Callable[..., torch.Tensor]:
        """The training step for a batch of ``size`` (each size compiled once, when asked for)."""
        if not self.compile:
            return self.net.step
        step = self._compiled.get(size)
        if step is None:
            self.net.prepare(size)
            # the C++ wrapper runs the graph's ~500 kernel calls and allocations without Python
            # in between: 12% faster steps than inductor's Python wrapper, no longer to compile
            compiled = torch.compile(self.net.step, dynamic=False, options={"cpp_wrapper": True})
            step = self._compiled[size] = self._first_call(
                compiled, self.net.step, lambda: self._compiled.__setitem__(size, compiled)
            )
        return step

    def sample_forward(self) -> Callable[[torch.Tensor, torch.Tensor], torch.Tensor]:
        """The network's forward pass for sampling: compiled, for every pass size at once, when
        training is compiled (2.8 -> 2.1 ms per call of 50 bodies on one core)."""
        if not self.compile:
            return self.model.forward_features
        if self._sample_forward is None:
            compiled = torch.compile(self.model.forward_features, options={"cpp_wrapper": True})

            def forward(x: torch.Tensor, t_feat: torch.Tensor) -> torch.Tensor:
                torch._dynamo.mark_dynamic(x, 0)  # one graph whatever the pass size
                return compiled(x, t_feat)

            self._sample_forward = self._first_call(
                forward, self.model.forward_features, lambda: setattr(self, "_sample_forward", forward)
            )
        return self._sample_forward

    def _first_call(self, compiled: Callable[..., torch.Tensor], eager: Callable[..., torch.Tensor],
                    done: Callable[[], None]) -> Callable[..., torch.Tensor]:
        """``compiled``, whose first call compiles: on success ``done()`` installs it, on any
        failure (no compiler, unsupported platform, ...) warn once and run eagerly from then on."""

        def first_call(*args: torch.Tensor) -> torch.Tensor:
            try:
                out = compiled(*args)
            except Exception as exc:  # noqa: BLE001
                warnings.warn(
                    f"gda: torch.compile failed ({type(exc).__name__}: {exc}); running without it",
                    RuntimeWarning,
                    stacklevel=2,
                )
                self.compile = False
                return eager(*args)
            done()
            return out

        return first_call

    def set_schedule(self, schedule: NoiseSchedule) -> None:
        self.schedule = schedule
        ab = schedule.alpha_bars
        self.sqrt_ab = ab.sqrt().to(self.device, torch.float32)
        self.sqrt_1m_ab = (1.0 - ab).sqrt().to(self.device, torch.float32)
        self.time_table = self.model.time_features(torch.arange(schedule.steps, device=self.device))

    @torch.no_grad()
    def set_weights(self, flat: np.ndarray) -> None:
        """Load weights in the training layout (:attr:`flat`, e.g. trained in another process) into the model."""
        self.net.params.flat.copy_(torch.from_numpy(flat))
        self.net.params.store()

    def _new_optimizer(self) -> torch.optim.AdamW:
        flat = self.net.params.flat
        flat.grad = self.net.params.grad  # the hand-derived step writes the gradient there
        return torch.optim.AdamW([flat], lr=self.lr, weight_decay=self.weight_decay, fused=True)

    @torch.no_grad()
    def reset(self, generator: torch.Generator) -> None:
        """A fresh model: weights re-drawn from ``generator`` (on the CPU) and a new optimizer."""
        reset_parameters(self._cpu_model, generator)
        if self._cpu_model is not self.model:
            self.model.load_state_dict(self._cpu_model.state_dict())
        self.net.params.load()
        self.optimizer = self._new_optimizer()

    @torch.no_grad()
    def fit(
        self,
        data: torch.Tensor,
        *,
        epochs: int,
        generator: torch.Generator,
        batch_size: int = 5,
        dataset_size: int = 64,
        target_loss: float | None = None,
        stop: Callable[[], bool] | None = None,
    ) -> FitResult:
        """Train on ``data`` (n, 1, H, W encoded bodies) for ``epochs`` epochs.

        With ``target_loss`` training stops after the first epoch whose mean loss is at most
        that value (``epochs`` is then the maximum): the thesis's proposal to control
        exploration by the MSE reached rather than by a fixed number of epochs.  ``stop`` is
        asked before each epoch; training ends early once it returns True (a training run
        that turned out not to be needed).
        """
        start = time.perf_counter()
        dataset = repeat_to(data.to(self.device, torch.float32), dataset_size)
        shape = dataset.shape[1:]
        steps = self.schedule.steps
        bounds = [(s, min(s + batch_size, dataset_size)) for s in range(0, dataset_size, batch_size)]
        losses = torch.zeros(len(bounds), device=self.device)
        optimizer = self.optimizer
        epoch_loss, done = float("nan"), 0
        for _ in range(epochs):
            if stop is not None and stop():
                break
            order = torch.randperm(dataset_size, generator=generator).to(self.device)
            t = torch.randint(1, steps, (dataset_size,), generator=generator).to(self.device)
            noise = torch.randn((dataset_size, *shape), generator=generator).to(self.device)
            xt = self.sqrt_ab[t].view(-1, 1, 1, 1) * dataset[order] + self.sqrt_1m_ab[t].view(-1, 1, 1, 1) * noise
            feats = self.time_table[t]
            for i, (a, b) in enumerate(bounds):
                losses[i] = self._step(b - a)(xt[a:b], feats[a:b], noise[a:b])
                optimizer.step()
            done += 1
            epoch_loss = float(losses.mean())
            if target_loss is not None and epoch_loss <= target_loss:
                break
        self.net.params.store()
        return FitResult(done, epoch_loss, time.perf_counter() - start)


@dataclass(frozen=True)
class TrainJob:
    """One generation's training: its data, its torch seed and the rest of ``Trainer.fit``'s arguments."""

    data: bytes  # float32 encoded survivors, C order
    data_shape: tuple[int, ...]  # (n, 1, H, W)
    seed: int
    fit: tuple[tuple[str, Any], ...]

    @classmethod
    def make(cls, data: np.ndarray, seed: int, **fit: Any) -> TrainJob:
        data = np.ascontiguousarray(data, dtype=np.float32)
        return cls(data.tobytes(), data.shape, int(seed), tuple(sorted(fit.items())))

    def run(self, trainer: Trainer, generator: torch.Generator, stop: Callable[[], bool] | None = None,
            initial: torch.Tensor | None = None) -> FitResult:
        """Train ``trainer`` from fresh weights drawn from ``generator`` (or from ``initial``, to warm-start)."""
        trainer.reset(generator)
        if initial is not None:
            with torch.no_grad():
                trainer.flat.copy_(initial.to(trainer.device))
        data = torch.from_numpy(np.frombuffer(self.data, dtype=np.float32).reshape(self.data_shape).copy())
        return trainer.fit(data, generator=generator, stop=stop, **dict(self.fit))

    def train(
        self, trainer: Trainer, stop: Callable[[], bool] | None = None
    ) -> tuple[np.ndarray, np.ndarray, FitResult]:
        """A fresh model trained from this job's own seed: its weights (training layout), the
        stream's state after training (where sampling goes on) and the result."""
        generator = torch.Generator().manual_seed(self.seed)
        result = self.run(trainer, generator, stop=stop)
        return trainer.flat.detach().cpu().numpy().copy(), generator.get_state().numpy(), result

    def warm_up(self, trainer: Trainer) -> None:
        """Compile ``trainer``'s step for this job's batches now: one epoch on blank bodies (every
        run starts from fresh weights anyway)."""
        fit = {**dict(self.fit), "epochs": 1, "target_loss": None}
        trainer.fit(torch.zeros(self.data_shape), generator=torch.Generator().manual_seed(0), **fit)
