"""``--log tensorboard``: each trial's figures per generation as TensorBoard scalars.

Event files go to ``RUN_DIR/tensorboard/<trial>/`` (one run per trial in TensorBoard's list), with
the trial's evaluations so far as the step: ``best_so_far``, the generation's ``reward/max``,
``reward/mean`` and ``reward/min`` (scored bodies only), and ``evaluated`` (new evaluations in the
generation).  ``tensorboard --logdir RUN_DIR/tensorboard`` shows them; a resumed trial appends.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..errors import ConfigError
from ..hookspecs import hookimpl

try:
    from torch.utils.tensorboard import SummaryWriter
except ImportError:  # torch's writer needs the tensorboard package
    SummaryWriter = None  # type: ignore[misc,assignment]  # checked before use


class TensorBoardLogger:
    """Writes TensorBoard event files; one writer per running trial."""

    def __init__(self) -> None:
        if SummaryWriter is None:
            raise ConfigError("--log tensorboard needs TensorBoard: pip install 'gdabench[tensorboard]'")
        self.writers: dict[str, Any] = {}

    def _writer(self, run_dir: Path, name: str) -> Any:
        if name not in self.writers:
            self.writers[name] = SummaryWriter(log_dir=str(Path(run_dir) / "tensorboard" / name))
        return self.writers[name]

    @hookimpl
    def gdabench_generation_finished(self, run_dir, trial, rows, report) -> None:
        writer = self._writer(run_dir, trial.name)
        step = int(report.n_evals)
        scored = rows.loc[rows["status"] == "ok", "reward"]
        if report.best == report.best:  # not nan
            writer.add_scalar("best_so_far", float(report.best), step)
        if len(scored):
            writer.add_scalar("reward/max", float(scored.max()), step)
            writer.add_scalar("reward/mean", float(scored.mean()), step)
            writer.add_scalar("reward/min", float(scored.min()), step)
        writer.add_scalar("evaluated", int(report.new_evals), step)
        writer.flush()

    @hookimpl
    def gdabench_trial_finished(self, trial) -> None:
        writer = self.writers.pop(trial.name, None)
        if writer is not None:
            writer.close()

    @hookimpl
    def gdabench_run_finished(self) -> None:
        for writer in self.writers.values():
            writer.close()
        self.writers.clear()
