"""Conformance checks for plugin authors: does my designer, environment or controller obey the
contracts the harness relies on?

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
from typing import Any, Callable, Iterator, Mapping

import numpy as np

from .body import Body, as_body, random_body
from .designer import Designer
from .environment import Controller, Environment, Evaluation
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
