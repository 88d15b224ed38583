"""Where each generation's model is trained: here, or ahead on a spare core (:mod:`.speculation`).

The designer says *what* a generation trains on (a :class:`.TrainJob`); a backend, chosen once
per designer by :func:`choose_backend`, trains it and leaves the model in its :attr:`trainer`,
with the generation's random stream where training left it, ready for sampling.  Both give the
same model for the same job, bit for bit: only where and when the work happens differs.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any, Callable

import torch

from ...sdk import cpu_count
from ...torch_runtime import resolve_device
from .config import GdaConfig
from .speculation import Following, Speculation, WorkerError
from .training import FitResult, Trainer, TrainerSpec, TrainJob, shared_trainer

#: ``borrow()``: True once the designer's trial holds one more CPU core (see Designer.lend_cores)
Borrow = Callable[[], bool]


@dataclass(frozen=True)
class Trained:
    """A generation's model, now in the backend's trainer: how training went, the stream to sample
    with, and whether the model was trained ahead (before the generation asked for it)."""

    result: FitResult
    generator: torch.Generator
    ahead: bool


def more_than_one_cpu() -> bool:
    """Outside a run (a designer driven by hand) a core is spare if the process may use more than one."""
    return cpu_count() >= 2


class LocalTraining:
    """Trains each model here when it is asked for; with ``warm_start``, from the last one's weights."""

    def __init__(self, spec: TrainerSpec, warm_start: bool = False):
        self.spec, self.warm_start = spec, warm_start
        self._weights: torch.Tensor | None = None  # the last model's weights, kept only to warm-start

    @property
    def trainer(self) -> Trainer:
        """The trainer holding the latest model (shared by the designers of this process)."""
        return shared_trainer(self.spec)

    def lend_cores(self, borrow: Borrow) -> None:
        """Spare cores are of no use here."""

    def train(self, job: TrainJob, following: Following) -> Trained:
        """``job``'s model, trained from ``job``'s seed; ``following`` says which jobs come next."""
        generator = torch.Generator().manual_seed(job.seed)
        result = job.run(self.trainer, generator, initial=self._weights if self.warm_start else None)
        if self.warm_start:
            self._weights = self.trainer.flat.detach().to("cpu", copy=True)
        return Trained(result, generator, ahead=False)

    def look_ahead(self, following: Following) -> None:
        """Called once a generation's model is trained: a chance to start on the next one."""


class TrainingAhead(LocalTraining):
    """Trains models ahead on a second core once one is lent (always, when ``forced``), and here
    until then or once the training process has failed (a warning; the results stay the same)."""

    def __init__(self, spec: TrainerSpec, forced: bool):
        super().__init__(spec)
        self.forced = forced
        self.failed = False
        self._borrow: Borrow = more_than_one_cpu
        self._speculation: Speculation | None = None

    def lend_cores(self, borrow: Borrow) -> None:
        self._borrow = borrow

    def train(self, job: TrainJob, following: Following) -> Trained:
        speculation = self._speculation_now()
        if speculation is not None:
            try:
                weights, state, result, ahead = speculation.train(job, self.trainer, following)
            except WorkerError as exc:
                self._fail(exc)
            else:
                self.trainer.set_weights(weights)
                generator = torch.Generator()
                generator.set_state(torch.from_numpy(state))
                return Trained(result, generator, ahead)
        return super().train(job, following)

    def look_ahead(self, following: Following) -> None:
        speculation = self._speculation_now()
        if speculation is not None:
            try:
                speculation.look_ahead(following)
            except WorkerError as exc:
                self._fail(exc)

    def _speculation_now(self) -> Speculation | None:
        """The training process's handle, started once a core is lent for it (None: train here)."""
        if self._speculation is None and not self.failed and (self.forced or self._borrow()):
            self._speculation = Speculation(self.spec)
        return self._speculation

    def _fail(self, exc: WorkerError) -> None:
        warnings.warn(
            f"gda: {exc}; training in this process from now on (same results, no overlap)", RuntimeWarning, stacklevel=4
        )
        self.failed = True
        if self._speculation is not None:
            self._speculation.close()
            self._speculation = None

    def __getstate__(self) -> dict[str, Any]:
        # a checkpoint keeps the choice, not the process: models trained ahead are trained again if
        # needed (the same numbers), and the harness lends cores again to the restored designer
        return {**self.__dict__, "_speculation": None, "_borrow": more_than_one_cpu}


def choose_backend(config: GdaConfig, shape: tuple[int, int], population: int, budget: int) -> LocalTraining:
    """Where a run of ``budget`` evaluations in generations of ``population`` trains its models:
    ahead with speculate=true, or with 'auto' when the run is long enough to repay it (once a
    core is lent); otherwise here.  Compiled as ``compile`` says (see :class:`.GdaConfig`)."""
    device = str(resolve_device(config.device, "gda"))
    compiles = config.compiles(population, budget)
    spec = TrainerSpec(config.schedule_args, shape, float(config.lr), compiles, config.threads, device)
    eligible = config.may_train_ahead and config.trains_long(population, budget)
    if config.speculate is True or (config.speculate == "auto" and eligible):
        return TrainingAhead(spec, forced=config.speculate is True)
    return LocalTraining(spec, config.warm_start)
