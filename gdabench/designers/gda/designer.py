"""The generational diffusion algorithm (GDA, thesis chapter 4) as an ask/tell designer.

Each generation: the survivors are the best ``survivors`` bodies among the previous survivors
and the generation just evaluated (they keep their reward); a *fresh* diffusion model is
trained on them; new bodies are drawn from it until the next generation holds ``population``
valid, unique, never-proposed bodies.  Generation 0 comes from Evolution Gym's random sampler
(the same bodies as ``ga`` and ``random`` under the same seed).

Departures from the author's code, all deliberate:

* bodies are never changed in place.  The author's code re-encodes every survivor's array in
  place before training, so a body that survives k generations is trained on as a permuted
  body while keeping its first score (an accidental mutation operator).  That behaviour is
  available, explicitly, as ``published_reencoding=True`` so the thesis's numbers can be
  reproduced; the default trains on the survivors as they are;
* a sampling shortfall never crashes (the author's code fails after 1,000 samples).  After
  ``max_samples`` draws the generation is completed with fresh bodies from Evolution Gym's
  random sampler; every row says how its body was made in the ``source`` column
  (``initial``, ``sampled`` or ``random``);
* how many samples are drawn per denoising pass adapts to the acceptance rate seen so far.
  Samples are independent and taken in order, so the accepted bodies have exactly the
  distribution of the author's fixed passes of 50; only the work changes.

Options beyond the thesis (each measured against the faithful setting in docs/benchmarks/gda.md):
``target_mse`` (train until the epoch's mean loss reaches it), ``schedule='cosine'``,
``sampler='ddim'`` with ``sample_steps``, ``temperature`` (noise scale while sampling),
``warm_start`` (continue from the previous generation's weights), ``pool`` (draw more new
bodies than needed and propose those a reward regression rates best), ``prior`` (train
generation 0's model on the best bodies of another run instead of sampling at random).
The operators the thesis proposes (sections 6.3-6.4; measured in docs/benchmarks/gda-operators.md):
``crossover`` (a share of each generation made by noising two survivors to ``crossover_t``,
interpolating and denoising), ``categories`` (target shares of near-copies, same shape with new
materials and novel shapes among the sampled bodies) and ``hybrid`` (every ``hybrid``-th
generation made by the GA's mutation of the survivors instead of a model).
Speed options that keep the results' distribution: ``compile`` (``torch.compile`` the
training step and the sampling network: same distribution, other rounding), ``threads``,
``device``; ``speculate`` (train models ahead on both cores: on a second one while this one
samples, and here while the second trains; see :mod:`.speculation`) leaves the results
unchanged bit for bit.
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import torch

from ...body import CATEGORIES, Body, as_body, categorize, invalid_reason, mutate, random_body
from ...designer import Designer, top_k
from ...errors import ConfigError, GdabenchError
from .encoding import decode, encode, published_reencoding
from .runtime import check_threads, resolve_device, torch_threads
from .sampling import SAMPLERS, ancestral_sample, ddim_sample, denoise, noised
from .schedule import make_schedule
from .speculation import Following, Speculation, WorkerConfig, WorkerError, wanted
from .surrogate import ridge_predictor
from .training import Trainer, TrainJob, TrainResult

TORCH_STREAM = 1  # spawn-key branch of the designer's seed used for torch (weights, noise)
MUTATION_RATE = 0.1  # the hybrid schedule's GA generations mutate as ``ga`` does by default
MAX_PASS = 256  # most samples denoised in one pass when the pass size adapts
#: compile='auto' compiles training and sampling, and speculate='auto' trains ahead on a second
#: core, when a run trains at least this many steps: about where the ~1 ms saved per step
#: repays a first-time compilation (under a minute) on a 2-core CPU
AUTO_COMPILE_STEPS = 50_000
#: trainers shared by the designers of one process (they run one after another): every
#: generation starts from fresh weights anyway, and sharing compiles the step only once
_TRAINERS: dict[tuple[Any, ...], Trainer] = {}


@dataclass(frozen=True)
class Survivor:
    """A surviving body, its reward, and how often the published code would have re-encoded it."""

    body: Body
    reward: float
    reencoded: int = 0


class GenerationalDiffusion(Designer):
    """GDA with the thesis's defaults; the module docstring says which options depart from it.

    Parameters:
        survivors: bodies kept each generation, and the training set of the next model
        epochs: training epochs per generation (the most, with target_mse)
        dataset_size: items per epoch: the survivors repeated to this size
        batch_size: training batch (None: the thesis's 5)
        lr: AdamW learning rate
        steps: diffusion timesteps T
        beta_start: first variance of the noise schedule
        beta_end: last variance of the noise schedule
        schedule: noise schedule, linear (thesis) or cosine
        sampler: ddpm (thesis, T denoising steps) or ddim (sample_steps steps)
        sample_steps: denoising steps of the ddim sampler
        sample_batch: samples per denoising pass (None: adapts to the acceptance rate)
        temperature: scale of the noise added while sampling
        pool: draw this many new bodies and propose those a ridge regression on rewards rates best
        max_samples: draws per generation before the rest is filled with random bodies
        crossover: share of each generation made by interpolating two noised survivors and denoising (0: none)
        crossover_t: timestep the two survivors are noised to before they are interpolated
        categories: target shares near-copy/new-materials/novel-shape of the sampled bodies, e.g. 0.3/0.3/0.4
        hybrid: every hybrid-th generation is made by mutating survivors as the GA does, not by a model (0: never)
        target_mse: stop training at the first epoch whose mean loss is at most this
        warm_start: train from the previous generation's weights instead of fresh ones
        published_reencoding: re-encode survivors in place as the author's code does (reproduces the thesis)
        prior: a run directory whose best bodies train generation 0's model
        prior_top: how many of the prior run's best bodies
        device: cpu, cuda, cuda:N or auto
        threads: torch threads (None: leave torch's setting)
        compile: torch.compile training and sampling: true, false or auto (long runs on the CPU)
        speculate: train the next model ahead on a spare core: true, false or auto
    """

    def __init__(
        self,
        *,
        survivors: int = 5,
        epochs: int = 250,
        dataset_size: int = 64,
        batch_size: int | None = None,
        lr: float = 1e-3,
        steps: int = 500,
        beta_start: float = 1e-4,
        beta_end: float = 0.02,
        schedule: str = "linear",
        sampler: str = "ddpm",
        sample_steps: int = 50,
        sample_batch: int | None = None,
        temperature: float = 1.0,
        pool: int | None = None,
        max_samples: int = 1000,
        crossover: float = 0.0,
        crossover_t: int = 150,
        categories: str | None = None,
        hybrid: int = 0,
        target_mse: float | None = None,
        warm_start: bool = False,
        published_reencoding: bool = False,
        prior: str | None = None,
        prior_top: int = 5,
        device: str = "cpu",
        threads: int | None = 1,
        compile: bool | str = "auto",
        speculate: bool | str = "auto",
        **kwargs: Any,
    ):
        super().__init__(**kwargs)
        positive = {"survivors": survivors, "epochs": epochs, "dataset_size": dataset_size, "max_samples": max_samples,
                    "sample_steps": sample_steps, "prior_top": prior_top}
        for name, value in positive.items():
            if not isinstance(value, int) or isinstance(value, bool) or value < 1:
                raise ConfigError(f"gda: {name} must be a positive integer, got {value!r}")
        for name, value in (("batch_size", batch_size), ("sample_batch", sample_batch), ("pool", pool)):
            if value is not None and (not isinstance(value, int) or value < 1):
                raise ConfigError(f"gda: {name} must be a positive integer, got {value!r}")
        if not lr > 0:
            raise ConfigError(f"gda: lr must be positive, got {lr!r}")
        if target_mse is not None and not target_mse > 0:
            raise ConfigError(f"gda: target_mse must be positive, got {target_mse!r}")
        if sampler not in SAMPLERS:
            raise ConfigError(f"gda: unknown sampler {sampler!r}; choose one of {', '.join(SAMPLERS)}")
        self.n_survivors = survivors
        self.epochs = epochs
        self.dataset_size = dataset_size
        self.batch_size = batch_size or survivors
        self.lr = float(lr)
        self.schedule_args = (schedule, int(steps), float(beta_start), float(beta_end))
        make_schedule(*self.schedule_args)  # validate now: errors belong to the command line
        self.sampler = sampler
        self.sample_steps = sample_steps
        self.sample_batch = sample_batch
        if not temperature >= 0:
            raise ConfigError(f"gda: temperature must be at least 0, got {temperature!r}")
        self.temperature = float(temperature)
        if pool is not None and pool < self.population:
            raise ConfigError(f"gda: pool must be at least the population ({self.population}), got {pool}")
        self.pool = pool
        self.max_samples = max_samples
        self.target_mse = None if target_mse is None else float(target_mse)
        self.warm_start = bool(warm_start)
        self.published_reencoding = bool(published_reencoding)
        self.device_name = device
        resolve_device(device)
        check_threads(threads)
        self.threads = threads
        if compile not in (True, False, "auto"):
            raise ConfigError(f"gda: compile must be true, false or auto, got {compile!r}")
        self.compile = compile
        if speculate not in (True, False, "auto"):
            raise ConfigError(f"gda: speculate must be true, false or auto, got {speculate!r}")
        if not 0.0 <= crossover <= 1.0:
            raise ConfigError(f"gda: crossover must be a share between 0 and 1, got {crossover!r}")
        if crossover and not 1 <= crossover_t < self.schedule_args[1]:
            raise ConfigError(f"gda: crossover_t must be a timestep between 1 and steps - 1 = {self.schedule_args[1] - 1}, got {crossover_t!r}")
        if not isinstance(hybrid, int) or isinstance(hybrid, bool) or hybrid < 0 or hybrid == 1:
            raise ConfigError(f"gda: hybrid must be 0 (never) or at least 2 (every hybrid-th generation), got {hybrid!r}")
        self.crossover, self.crossover_t, self.hybrid = float(crossover), crossover_t, hybrid
        self.category_shares = parse_shares(categories) if categories is not None else None
        if self.category_shares is not None and pool is not None:
            raise ConfigError("gda: categories and pool both choose among samples; give one of them")
        if speculate is True and (self.warm_start or self.published_reencoding or hybrid or resolve_device(device).type != "cpu"):
            raise ConfigError("gda: speculate=true needs device=cpu and none of warm_start, published_reencoding, hybrid")
        self.speculate = speculate
        self.prior_bodies = load_prior(prior, prior_top, self.shape) if prior else []

        self.survivors: list[Survivor] = []
        self.evaluated: list[tuple[np.ndarray, float]] = []  # every told body, for the pool's reward model
        self.evaluations = 0
        self.generation = 0
        self._seen: set[str] = set()
        self._info: list[dict[str, Any]] = []
        self._acceptance = 0.5  # running estimate of the share of samples that are new and valid
        self._weights: torch.Tensor | None = None  # previous model's weights, kept only to warm-start
        self._trainer: Trainer | None = None
        self._trained_ahead = False
        self._speculation: Speculation | None = None  # while training ahead (see :mod:`.speculation`)

    # -- ask/tell ------------------------------------------------------------------------------
    def ask(self) -> list[Body]:
        with torch_threads(self.threads):
            return self._ask()

    def _ask(self) -> list[Body]:
        wanted = min(self.population, self.budget - self.evaluations)
        if wanted < 1:
            raise GdabenchError("gda: the evaluation budget is used up; nothing left to ask for")
        training_set = self._training_set()
        if training_set is None:
            bodies = [self._remember(random_body(self.rng, self.shape, exclude=self._seen)) for _ in range(wanted)]
            self._info = [{"source": "initial"} for _ in bodies]
        elif self.hybrid and self.generation % self.hybrid == 0:
            bodies = self._mutants(wanted)
            self._info = [{"source": "mutation"} for _ in bodies]
        else:
            generator = self._torch_generator()
            trained = self._train(training_set, generator)
            if self._speculates():
                try:
                    self._speculation.look_ahead(self._following(training_set))
                except WorkerError as exc:
                    self._stop_speculating(exc)
            start = time.perf_counter()
            children, drawn = self._crossover_new(round(self.crossover * wanted), training_set, generator)
            if self.pool is not None:
                candidates, more = self._sample_new(self.pool, generator, remember=False)
                sampled = [self._remember(b) for b in self._most_promising(candidates, wanted - len(children))]
            elif self.category_shares is not None:
                sampled, more = self._sample_by_category(wanted - len(children), training_set, generator)
            else:
                sampled, more = self._sample_new(wanted - len(children), generator)
            drawn += more
            sample_seconds = time.perf_counter() - start
            fallback = [self._remember(random_body(self.rng, self.shape, exclude=self._seen)) for _ in range(wanted - len(children) - len(sampled))]
            bodies = children + sampled + fallback
            common = {
                "train_epochs": trained.epochs,
                "train_loss": trained.loss,
                "train_seconds": trained.seconds,
                "trained_ahead": self._trained_ahead,
                "compiled": bool(self.trainer.compile),  # False also after torch.compile failed and gda went on eagerly
                "samples_drawn": drawn,
                "sample_seconds": sample_seconds,
            }
            sources = ["crossover"] * len(children) + ["sampled"] * len(sampled) + ["random"] * len(fallback)
            self._info = [{"source": source, **common} for source in sources]
        self.generation += 1
        return bodies

    def tell(self, bodies: Sequence[Body], rewards: Sequence[float]) -> None:
        self.evaluations += len(bodies)
        if self.pool is not None:
            self.evaluated += [(np.array(as_body(b).voxels), float(r)) for b, r in zip(bodies, rewards)]
        pool = self.survivors + [Survivor(as_body(b), float(r)) for b, r in zip(bodies, rewards)]
        scores = [s.reward for s in pool]
        self.survivors = top_k(pool, scores, self.n_survivors)[0]

    def proposal_info(self) -> list[Mapping[str, Any]]:
        return list(self._info)

    # -- training and sampling -----------------------------------------------------------------
    def _training_set(self) -> list[np.ndarray] | None:
        """Bodies the next model learns from (None: sample generation 0 at random)."""
        if self.survivors:
            if self.published_reencoding:
                data = [published_reencoding(s.body.voxels, s.reencoded) for s in self.survivors]
                self.survivors = [replace(s, reencoded=s.reencoded + 1) for s in self.survivors]
                return data
            return [np.array(s.body.voxels) for s in self.survivors]
        if self.prior_bodies:
            return [np.array(b.voxels) for b in self.prior_bodies]
        return None

    def _torch_seed(self, generation: int) -> int:
        """Generation ``generation``'s torch seed, derived from the run's seed alone (so resume is exact)."""
        ss = np.random.SeedSequence(self.seed_sequence.entropy, spawn_key=(*self.seed_sequence.spawn_key, TORCH_STREAM, generation))
        return int(ss.generate_state(1, dtype=np.uint64)[0] >> np.uint64(1))

    def _torch_generator(self) -> torch.Generator:
        """This generation's torch stream."""
        return torch.Generator().manual_seed(self._torch_seed(self.generation))

    def _long_run(self) -> bool:
        """Whether this run trains enough steps on the CPU for compiling and speculating to pay off."""
        generations = -(-self.budget // self.population)
        steps = (generations - 1) * self.epochs * -(-self.dataset_size // self.batch_size)
        return resolve_device(self.device_name).type == "cpu" and steps >= AUTO_COMPILE_STEPS

    def _compiles(self) -> bool:
        return self._long_run() if self.compile == "auto" else bool(self.compile)

    def _speculates(self) -> bool:
        """Whether models are trained ahead from now on (then ``_speculation`` is set)."""
        if self._speculation is None:
            eligible = not self.warm_start and not self.published_reencoding and not self.hybrid and self._long_run()
            if wanted(self.speculate, eligible):
                self._speculation = Speculation(self._worker_config())
        return self._speculation is not None

    @property
    def trainer(self) -> Trainer:
        if self._trainer is None:
            device = resolve_device(self.device_name)
            key = (self.schedule_args, self.shape, self.lr, str(device), self._compiles())
            if key not in _TRAINERS:
                _TRAINERS[key] = Trainer(make_schedule(*self.schedule_args), shape=self.shape, lr=self.lr, device=device, compile=key[-1])
            self._trainer = _TRAINERS[key]
        return self._trainer

    def _worker_config(self) -> WorkerConfig:
        return WorkerConfig(self.schedule_args, self.shape, self.lr, self._compiles(), self.threads)

    def _job(self, bodies: list[np.ndarray], generation: int) -> TrainJob:
        data = encode(np.stack(bodies))[:, None]
        return TrainJob.make(data, self._torch_seed(generation), epochs=self.epochs, batch_size=self.batch_size,
                             dataset_size=self.dataset_size, target_loss=self.target_mse)

    def _following(self, bodies: list[np.ndarray]) -> Following:
        """The training job ``k`` generations on if the survivors stay ``bodies``; None if the run
        will not ask for it (or there are no survivors yet, after a prior)."""
        return lambda k: self._job(bodies, self.generation + k) if self.survivors and self._asks_again(k) else None

    def _asks_again(self, generations: int) -> bool:
        """Whether the run will ask for generation ``self.generation + generations``."""
        wanted = min(self.population, self.budget - self.evaluations)
        return self.evaluations + wanted + (generations - 1) * self.population < self.budget

    def _stop_speculating(self, exc: WorkerError) -> None:
        warnings.warn(f"gda: {exc}; training in this process from now on (same results, no overlap)", RuntimeWarning, stacklevel=3)
        self.speculate = False
        if self._speculation is not None:
            self._speculation.close()
            self._speculation = None

    def _train(self, bodies: list[np.ndarray], generator: torch.Generator) -> TrainResult:
        """A fresh model trained on ``bodies`` (ahead, or elsewhere, when speculating); ``generator``
        ends where training leaves this generation's stream, ready for sampling."""
        job = self._job(bodies, self.generation)
        self._trained_ahead = False
        if self._speculates():
            try:
                weights, state, result, self._trained_ahead = self._speculation.train(job, self.trainer, self._following(bodies))
            except WorkerError as exc:
                self._stop_speculating(exc)
            else:
                self.trainer.set_weights(weights)
                generator.set_state(torch.from_numpy(state))
                return result
        initial = self._weights if self.warm_start else None
        result = job.run(self.trainer, generator, initial=initial)
        if self.warm_start:
            self._weights = self.trainer.flat.detach().to("cpu", copy=True)
        return result

    def _draw(self, n: int, generator: torch.Generator) -> np.ndarray:
        """``n`` decoded samples (n, H, W) from the current model."""
        trainer = self.trainer
        forward = trainer.sample_forward()
        if self.sampler == "ddim":
            x = ddim_sample(trainer.model, trainer.schedule, n, self.shape, generator, trainer.device, self.sample_steps,
                            temperature=self.temperature, forward=forward)
        else:
            x = ancestral_sample(trainer.model, trainer.schedule, n, self.shape, generator, trainer.device, self.temperature, forward)
        return decode(x[:, 0].cpu().numpy())

    def _sample_new(self, wanted: int, generator: torch.Generator, remember: bool = True) -> tuple[list[Body], int]:
        """Up to ``wanted`` new valid distinct bodies, in sampling order, drawing at most ``max_samples``.

        ``remember=False`` leaves them out of the seen set (a pool to choose from).
        """
        accepted: list[Body] = []
        taken: set[str] = set()
        drawn = 0
        while len(accepted) < wanted and drawn < self.max_samples:
            n = self._pass_size(wanted - len(accepted), self.max_samples - drawn)
            for voxels in self._draw(n, generator):
                drawn += 1
                body = self._accept(voxels, taken)
                if body is not None:
                    accepted.append(self._remember(body) if remember else body)
                    if len(accepted) == wanted:
                        break
        if drawn:
            self._acceptance = 0.5 * self._acceptance + 0.5 * max(len(accepted) / drawn, 0.02)
        return accepted, drawn

    def _accept(self, voxels: np.ndarray, taken: set[str]) -> Body | None:
        """``voxels`` as a body if it is valid and neither seen nor ``taken`` yet (then it is taken)."""
        if invalid_reason(voxels) is not None:
            return None
        body = Body(voxels)
        if body.hash in self._seen or body.hash in taken:
            return None
        taken.add(body.hash)
        return body

    def _crossover_new(self, wanted: int, parents: list[np.ndarray], generator: torch.Generator) -> tuple[list[Body], int]:
        """Up to ``wanted`` new bodies made by the interpolation crossover (thesis section 6.4).

        Two distinct survivors are drawn, a weight ``w`` uniformly from [0, 1]; ``w a + (1 - w) b``
        is diffused to ``crossover_t`` and denoised by the model.  (Noising a and b separately and
        interpolating, with the noise rescaled to the variance the model expects at that timestep,
        is the same distribution.)  At most ``max_samples`` candidates are drawn.
        """
        if wanted < 1 or len(parents) < 2:
            return [], 0
        trainer = self.trainer
        data = torch.from_numpy(encode(np.stack(parents))[:, None])
        accepted: list[Body] = []
        taken: set[str] = set()
        drawn = 0
        while len(accepted) < wanted and drawn < self.max_samples:
            n = self._pass_size(wanted - len(accepted), self.max_samples - drawn)
            first = torch.randint(len(parents), (n,), generator=generator)
            second = (first + torch.randint(1, len(parents), (n,), generator=generator)) % len(parents)
            w = torch.rand((n, 1, 1, 1), generator=generator)
            x = noised(trainer.schedule, w * data[first] + (1 - w) * data[second], self.crossover_t, generator).to(trainer.device)
            x = denoise(trainer.model, trainer.schedule, x, self.crossover_t, generator, self.temperature, trainer.sample_forward())
            for voxels in decode(x[:, 0].cpu().numpy()):
                drawn += 1
                body = self._accept(voxels, taken)
                if body is not None:
                    accepted.append(self._remember(body))
                    if len(accepted) == wanted:
                        break
        return accepted, drawn

    def _sample_by_category(self, wanted: int, parents: list[np.ndarray], generator: torch.Generator) -> tuple[list[Body], int]:
        """Up to ``wanted`` new sampled bodies whose categories relative to the survivors (near-copy,
        new materials, novel shape; :func:`gdabench.body.categorize`) meet ``categories``' shares.

        Samples are sorted into their category until its quota is full; when ``max_samples`` draws
        leave a quota short, the surplus of the other categories fills it, in sampling order.
        """
        quotas = share_counts(self.category_shares, wanted)
        buckets: list[list[Body]] = [[] for _ in quotas]
        surplus: list[Body] = []
        taken: set[str] = set()
        survivors = np.stack(parents)
        drawn = 0
        while any(len(b) < q for b, q in zip(buckets, quotas)) and drawn < self.max_samples:
            missing = sum(q - len(b) for b, q in zip(buckets, quotas))
            n = self._pass_size(missing, self.max_samples - drawn)
            fresh = []
            for voxels in self._draw(n, generator):
                drawn += 1
                body = self._accept(voxels, taken)
                if body is not None:
                    fresh.append(body)
            if not fresh:
                continue
            _, category = categorize(np.stack([b.voxels for b in fresh]), survivors)
            for body, c in zip(fresh, category):
                k = max(int(c), 1) - 1  # a copy of a prior's body (survivors were seen) counts as a near-copy
                (buckets[k] if len(buckets[k]) < quotas[k] else surplus).append(body)
        accepted = [b for bucket in buckets for b in bucket]
        accepted += surplus[: wanted - len(accepted)]
        if drawn:
            self._acceptance = 0.5 * self._acceptance + 0.5 * max(len(accepted) / drawn, 0.02)
        return [self._remember(b) for b in accepted], drawn

    def _mutants(self, wanted: int) -> list[Body]:
        """``wanted`` new bodies by the GA's operator: a uniformly chosen survivor, each voxel redrawn
        with probability 0.1 until valid (Evolution Gym's ``mutate``); random bodies if none is found."""
        children: list[Body] = []
        for _ in range(100 * wanted):
            if len(children) == wanted:
                break
            parent = self.survivors[int(self.rng.integers(len(self.survivors)))].body
            child = mutate(parent, self.rng, MUTATION_RATE)
            if child is not None and child.hash not in self._seen:
                children.append(self._remember(child))
        return children + [self._remember(random_body(self.rng, self.shape, exclude=self._seen)) for _ in range(wanted - len(children))]

    def _most_promising(self, candidates: list[Body], k: int) -> list[Body]:
        """The ``k`` candidates a ridge regression on all evaluated bodies rates best (ties: sampling order)."""
        if len(candidates) <= k or not self.evaluated:
            return candidates[:k]
        voxels, rewards = zip(*self.evaluated)
        predict = ridge_predictor(np.stack(voxels), np.array(rewards))
        scores = predict(np.stack([b.voxels for b in candidates]))
        return [candidates[i] for i in np.argsort(-scores, kind="stable")[:k]]

    def _pass_size(self, missing: int, allowed: int) -> int:
        if self.sample_batch is not None:
            return min(self.sample_batch, allowed)
        expected = math.ceil(1.25 * missing / self._acceptance) + 2
        return max(1, min(expected, MAX_PASS, allowed))

    def _remember(self, body: Body) -> Body:
        self._seen.add(body.hash)
        return body

    # -- pickling (checkpoints) ----------------------------------------------------------------
    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_trainer"] = None  # rebuilt on demand; every generation starts from a fresh (or saved) model
        state["_speculation"] = None  # models trained ahead are trained again if needed (the same numbers)
        return state


def load_prior(source: str, top: int, shape: tuple[int, int]) -> list[Body]:
    """The ``top`` best distinct bodies of another run (run directory or evaluations.parquet),
    or the bodies listed one per line in a text file."""
    path = Path(source)
    if path.is_dir():
        path = path / "evaluations.parquet"
    if not path.exists():
        raise ConfigError(f"gda: prior {source!r} not found (give a run directory, its evaluations.parquet, or a text file of bodies)")
    try:
        if path.suffix == ".parquet":
            import pandas as pd

            rows = pd.read_parquet(path, columns=["body", "reward", "status"])
            rows = rows[rows["status"] == "ok"].sort_values("reward", ascending=False, kind="stable")
            texts = list(dict.fromkeys(rows["body"]))
        else:
            texts = [line.split()[0] for line in path.read_text().splitlines() if line.strip() and not line.startswith("#")]
    except GdabenchError:
        raise
    except Exception as exc:  # noqa: BLE001 - any unreadable file is one line for the user
        raise ConfigError(f"gda: cannot read prior {source!r}: {type(exc).__name__}: {exc}") from None
    bodies = [as_body(t) for t in texts]
    bodies = [b for b in bodies if b.shape == tuple(shape) and b.is_valid()][:top]
    if not bodies:
        raise ConfigError(f"gda: prior {source!r} holds no valid {shape[0]}x{shape[1]} body")
    return bodies


def parse_shares(text: str) -> tuple[float, float, float]:
    """``'0.3/0.3/0.4'`` -> the target shares of near-copies, new materials and novel shapes (summing to 1)."""
    names = "/".join(c.replace(" ", "-") for c in CATEGORIES[1:])
    try:
        shares = tuple(float(part) for part in str(text).split("/"))
    except ValueError:
        shares = ()
    if len(shares) != 3 or any(not v >= 0 for v in shares) or not math.isclose(sum(shares), 1.0, abs_tol=1e-6):
        raise ConfigError(f"gda: categories must be three shares {names} summing to 1, e.g. 0.3/0.3/0.4; got {text!r}")
    return shares  # type: ignore[return-value]


def share_counts(shares: Sequence[float], n: int) -> list[int]:
    """``n`` split by ``shares`` into whole counts (largest remainders; ties to the earlier share)."""
    exact = [share * n for share in shares]
    counts = [math.floor(e) for e in exact]
    for i in sorted(range(len(exact)), key=lambda i: counts[i] - exact[i])[: n - sum(counts)]:
        counts[i] += 1
    return counts
