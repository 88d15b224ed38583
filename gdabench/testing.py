"""Conformance checks for plugin authors: does my designer, environment or controller obey the
contracts the harness relies on?

:func:`check_body_batch` checks the batch contract between controllers and environments: the
:class:`~gdabench.sdk.BodyBatch` es an environment hands a controller that learns many bodies at once.

Call them from your own tests::

    from gdabench.testing import check_designer

    def test_my_designer_conforms():
        check_designer(MyDesigner, params={"temperature": 0.5})

Each check raises :class:`ConformanceError` (an ``AssertionError``) naming the broken rule; an
exception the plugin raises is one too, naming the call (the original is chained for the traceback).
"""

from __future__ import annotations

import contextlib
import math
import pickle
from pathlib import Path
from typing import Any, Callable, Iterator, Mapping, Sequence

import numpy as np

from .batched import BodyBatch, GymBodies, Transition
from .body import Body, as_body, random_body
from .designer import Designer
from .environment import Bodies, Controller, Environment, Evaluation
from .envs.simple import SumOfVoxels
from .errors import one_line
from .seeding import designer_seed


class ConformanceError(AssertionError):
    """A plugin broke a gdabench contract."""


def _require(condition: bool, message: str) -> None:
    if not condition:
        raise ConformanceError(message)


def _reward(result: float | Evaluation) -> float:
    """What ``Environment.evaluate`` scored: its reward, with or without extras."""
    return float(result.reward if isinstance(result, Evaluation) else result)
@contextlib.contextmanager
def _plugin(call: str) -> Iterator[None]:
    """A plugin that raises in ``call`` fails the check like a broken rule, so a test report says which call."""
    try:
        yield
    except ConformanceError:
        raise
    except Exception as exc:
        raise ConformanceError(f"{call} raised {one_line(exc)}") from exc


def _drive(designer: Designer, env: Environment, generations: int, seen: set[str]) -> list[list[str]]:
    """ask/tell like the harness; checks every generation; returns the body texts per generation."""
    texts = []
    for g in range(generations):
        with _plugin(f"generation {g}: ask()"):
            proposed = designer.ask()
        _require(
            isinstance(proposed, (list, tuple)) and len(proposed) > 0,
            f"generation {g}: ask() must return a non-empty list of bodies",
        )
        with _plugin(f"generation {g}: reading the bodies ask() returned"):
            bodies = [as_body(b) for b in proposed]
        with _plugin(f"generation {g}: proposal_info()"):
            info = designer.proposal_info()
        _require(
            not info or len(info) == len(bodies),
            f"generation {g}: proposal_info() has {len(info)} entries for {len(bodies)} bodies",
        )
        for b in bodies:
            _require(
                b.shape == tuple(designer.shape),
                f"generation {g}: body of shape {b.shape}, designer shape is {designer.shape}",
            )
            _require(
                env.invalid_reason(b) is None,
                f"generation {g}: proposed an invalid body {b.text} ({env.invalid_reason(b)})",
            )
            _require(
                b.hash not in seen, f"generation {g}: proposed {b.text} again (bodies must be unique within a run)"
            )
            seen.add(b.hash)
        rewards = [_reward(env.evaluate(b, seed=0)) for b in bodies]
        rewards[0] = math.nan  # designers must cope with bodies that could not be scored
        with _plugin(f"generation {g}: tell()"):
            designer.tell(bodies, rewards)
        texts.append([b.text for b in bodies])
    return texts


def check_designer(
    factory: Callable[..., Designer],
    *,
    params: Mapping[str, Any] | None = None,
    shape: tuple[int, int] = (5, 5),
    population: int = 8,
    budget: int = 200,
    generations: int = 4,
    env: Environment | None = None,
) -> None:
    """ask/tell order, valid unique bodies, determinism under a seed, state save/restore by pickle."""
    env = env or SumOfVoxels(shape=shape)

    def new(seed: int) -> Designer:
        with _plugin("the designer's constructor"):
            designer = factory(
                shape=shape, population=population, budget=budget, seed=designer_seed(seed), **dict(params or {})
            )
        _require(isinstance(designer, Designer), f"factory returned {type(designer).__name__}, not a gdabench.Designer")
        return designer

    first = _drive(new(0), env, generations, set())
    _require(
        first == _drive(new(0), env, generations, set()),
        "the same seed gave different bodies (take randomness from self.rng / the seed)",
    )

    half = generations // 2 or 1
    seen: set[str] = set()
    original = new(1)
    _drive(original, env, half, seen)
    with _plugin("pickling the designer"):
        restored = pickle.loads(pickle.dumps(original))
    after_restore = _drive(restored, env, generations - half, set(seen))
    _require(
        after_restore == _drive(original, env, generations - half, set(seen)),
        "a designer restored from pickle continued differently",
    )


def check_environment(
    factory: Callable[..., Environment],
    *,
    params: Mapping[str, Any] | None = None,
    shape: tuple[int, int] = (5, 5),
    controller: Controller | None = None,
    bodies: int = 10,
    seed: int = 0,
) -> None:
    """Finite rewards for valid bodies, invalid bodies refused, determinism, optimum not exceeded."""
    with _plugin("the environment's constructor"):
        env = factory(shape=shape, **dict(params or {}))
    _require(isinstance(env, Environment), f"factory returned {type(env).__name__}, not a gdabench.Environment")
    _require(
        not env.requires_controller or controller is not None, "this environment needs a controller: pass controller="
    )
    rng = np.random.default_rng(seed)
    best = -math.inf
    for _ in range(bodies):
        body = random_body(rng, shape)
        _require(env.invalid_reason(body) is None, f"a valid body {body.text} was refused: {env.invalid_reason(body)}")
        with _plugin(f"evaluate({body.text})"):
            result = env.evaluate(body, seed=seed, controller=controller)
        reward = _reward(result)
        _require(math.isfinite(reward), f"{body.text} scored {reward}")
        if env.deterministic:
            again = env.evaluate(body, seed=seed, controller=controller)
            again_reward = _reward(again)
            _require(
                again_reward == reward, f"deterministic environment scored {body.text} {reward} then {again_reward}"
            )
        best = max(best, reward)
    _require(
        env.invalid_reason(Body(np.ones(shape, dtype=np.int8))) is not None,
        "a body without actuator was accepted as valid",
    )
    if env.optimum is not None:
        _require(best <= env.optimum + 1e-9, f"reward {best} exceeds the reported optimum {env.optimum}")


def check_controller(
    factory: Callable[..., Controller],
    make_env: Callable[[], Any],
    *,
    params: Mapping[str, Any] | None = None,
    seed: int = 0,
    workdir: Path | None = None,
) -> Evaluation:
    """An Evaluation with a finite reward, identical for the same seed; returns it."""
    with _plugin("the controller's constructor"):
        controller = factory(**dict(params or {}))
    _require(
        isinstance(controller, Controller), f"factory returned {type(controller).__name__}, not a gdabench.Controller"
    )
    with _plugin("evaluate()"):
        first = controller.evaluate(make_env, seed=seed, workdir=workdir)
    _require(isinstance(first, Evaluation), f"evaluate() returned {type(first).__name__}, not a gdabench.Evaluation")
    _require(math.isfinite(first.reward), f"controller reached a non-finite reward {first.reward}")
    with _plugin("evaluate(), a second time"):
        second = factory(**dict(params or {})).evaluate(make_env, seed=seed, workdir=workdir)
    _require(second.reward == first.reward, f"the same seed gave rewards {first.reward} and {second.reward}")
    return first


def check_body_batch(bodies: Bodies, *, envs_per_body: int = 2, steps: int = 10, seed: int = 0) -> None:
    """The batch contract, for every batch ``bodies`` (:meth:`ControlledEnvironment.bodies
    <gdabench.envs.controlled.ControlledEnvironment.bodies>`) offers a controller: its array batch
    (``make_batch``) where it has one, and its Gymnasium environments batched by
    :class:`~gdabench.sdk.GymBodies`.  Rows are body-major (``envs_per_body`` per body), sizes are per body
    and within the padding (``bodies.pad``, where given), padded columns are zero, every step is a
    :class:`~gdabench.sdk.Transition` of finite values with boolean episode flags, actions outside the
    action space are taken (clipped), and the same seeds give the same steps."""
    n = len(bodies)
    _require(n >= 1, "no bodies to batch")
    makers: dict[str, Callable[[int], BodyBatch]] = {
        "GymBodies over make_envs": lambda k: GymBodies(list(bodies.make_envs), k)
    }
    if bodies.make_batch is not None:
        make_batch = bodies.make_batch
        makers["make_batch"] = lambda k: make_batch(list(range(n)), k)
    for name, make in makers.items():
        pad = bodies.pad if name == "make_batch" else None
        first = _roll(name, make, n, envs_per_body, steps, seed, pad)
        again = _roll(name, make, n, envs_per_body, steps, seed, pad)
        same = all(np.array_equal(a, b) for a, b in zip(first, again))
        _require(same, f"{name}: the same seeds gave different steps")


def _roll(name: str, make: Callable[[int], BodyBatch], n: int, per_body: int, steps: int, seed: int,
          pad: tuple[int, int] | None) -> list[np.ndarray]:  # fmt: skip
    """One batch's reset and ``steps`` steps of random (partly out-of-range) actions, checked; what it saw."""
    with _plugin(f"{name}({per_body})"):
        batch = make(per_body)
    rows = n * per_body
    try:
        _require(batch.envs_per_body == per_body, f"{name}: envs_per_body {batch.envs_per_body}, not {per_body}")
        _require(len(batch.obs_sizes) == n and len(batch.act_sizes) == n,
                 f"{name}: obs_sizes/act_sizes need one entry per body ({n})")  # fmt: skip
        with _plugin(f"{name}: seed() and reset()"):
            batch.seed([seed + b for b in range(n)])
            obs = np.asarray(batch.reset())
        _require(obs.ndim == 2 and obs.shape[0] == rows, f"{name}: reset() gave shape {obs.shape}, not ({rows}, obs)")
        _require(obs.shape[1] >= max(batch.obs_sizes), f"{name}: observations narrower than the widest body's")
        if pad is not None:
            _require(obs.shape[1] == pad[0], f"{name}: observations {obs.shape[1]} wide, not padded to {pad[0]}")
            _require(max(batch.act_sizes) <= pad[1], f"{name}: an action size exceeds the padding {pad[1]}")
        _check_rows(name, "reset()", obs, batch.obs_sizes, per_body)
        width = pad[1] if pad is not None else max(batch.act_sizes)
        rng = np.random.default_rng(seed)
        seen = [obs]
        for step in range(steps):
            with _plugin(f"{name}: step() {step}"):
                t = batch.step(2.0 * rng.standard_normal((rows, width)))  # about a third outside [-1, 1]
            _require(isinstance(t, Transition), f"{name}: step() returned {type(t).__name__}, not a Transition")
            for field in ("next_obs", "obs"):
                value = np.asarray(getattr(t, field))
                _require(value.shape == obs.shape, f"{name}: {field} has shape {value.shape}, not {obs.shape}")
                _check_rows(name, f"step() {field}", value, batch.obs_sizes, per_body)
            _require(np.shape(t.reward) == (rows,) and bool(np.isfinite(t.reward).all()),
                     f"{name}: rewards must be {rows} finite numbers")  # fmt: skip
            for flag in ("terminated", "truncated", "unstable"):
                value = np.asarray(getattr(t, flag))
                _require(value.shape == (rows,) and value.dtype == bool, f"{name}: {flag} must be {rows} booleans")
            seen += [np.asarray(t.obs), np.asarray(t.reward), np.asarray(t.done)]
        return seen
    finally:
        batch.close()


def _check_rows(name: str, what: str, obs: np.ndarray, sizes: Sequence[int], per_body: int) -> None:
    _require(bool(np.isfinite(obs).all()), f"{name}: {what} has non-finite observations")
    for row in range(obs.shape[0]):
        size = sizes[row // per_body]
        _require(not obs[row, size:].any(), f"{name}: {what} row {row} is not zero beyond its body's {size} values")

