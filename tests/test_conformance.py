"""The conformance helpers accept the built-ins and catch designers that break the contract."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest

from gdabench import make_env
from gdabench.body import random_body
from gdabench.designers.ga import GeneticAlgorithm
from gdabench.designers.random_search import RandomSearch
from gdabench.environment import Bodies
from gdabench.envs.simple import SumOfVoxels
from gdabench.testing import ConformanceError, check_body_batch, check_designer, check_environment


@pytest.mark.parametrize(
    "factory, params", [(GeneticAlgorithm, {}), (GeneticAlgorithm, {"survivors": 3}), (RandomSearch, {})]
)
def test_builtin_designers_conform(factory, params):
    check_designer(factory, params=params)


def test_builtin_environment_conforms():
    check_environment(SumOfVoxels)


class Unseeded(RandomSearch):
    def ask(self):
        rng = np.random.default_rng()  # ignores the seed
        return [random_body(rng, self.shape) for _ in range(self.population)]


class Repeater(RandomSearch):
    def ask(self):
        self._first = getattr(self, "_first", None) or super().ask()
        return self._first


class Forgetful(RandomSearch):
    def __getstate__(self):
        state = dict(self.__dict__)
        state["rng"] = np.random.default_rng(123)  # loses its random stream when pickled
        return state


class Crashes(RandomSearch):
    def tell(self, bodies, rewards):
        raise KeyError("best")


class Unpicklable(RandomSearch):
    def __reduce__(self):
        raise TypeError("cannot pickle 'generator' object")


@pytest.mark.parametrize(
    "factory, fragment",
    [
        (Unseeded, "same seed gave different bodies"),
        (Repeater, "again"),
        (Forgetful, "restored from pickle continued differently"),
        (Crashes, "generation 0: tell() raised KeyError: 'best'"),
        (Unpicklable, "pickling the designer raised TypeError: cannot pickle"),
    ],
)
def test_broken_designers_are_caught(factory, fragment):
    with pytest.raises(ConformanceError, match=re.escape(fragment)):
        check_designer(factory)


def test_an_environment_that_raises_fails_the_check_naming_the_call():
    class Exploding(SumOfVoxels):
        def evaluate(self, body, seed=0, controller=None):
            raise RuntimeError("simulator exploded")

    with pytest.raises(ConformanceError, match=r"evaluate\(\d+(/\d+)+\) raised RuntimeError: simulator exploded"):
        check_environment(Exploding)


# -- the batch contract between controllers and environments ---------------------------------------
@pytest.mark.parametrize("engine", ["voxel", "pymunk"])
def test_the_walkers_batches_keep_the_batch_contract(engine):
    env = make_env("walker", shape=(3, 3), engine=engine)
    rng = np.random.default_rng(0)
    check_body_batch(env.bodies([random_body(rng, (3, 3)) for _ in range(2)]), steps=5)


def test_a_batch_that_breaks_the_contract_is_named():
    env = make_env("walker", shape=(3, 3))
    good = env.bodies([random_body(np.random.default_rng(1), (3, 3))])

    wide = Bodies(good.make_envs, good.make_batch, (good.pad[0] + 1, good.pad[1]))  # promises wider rows
    with pytest.raises(ConformanceError, match="make_batch: observations .* not padded to"):
        check_body_batch(wide, steps=2)

    class Flaky:  # rewards that are not finite
        def __init__(self, batch):
            self._batch = batch
            self.envs_per_body, self.obs_sizes, self.act_sizes = batch.envs_per_body, batch.obs_sizes, batch.act_sizes
            self.seed, self.reset, self.close = batch.seed, batch.reset, batch.close

        def step(self, actions):
            t = self._batch.step(actions)
            return dataclasses.replace(t, reward=np.full_like(t.reward, np.nan))

    flaky = Bodies(good.make_envs, lambda indices, n: Flaky(good.make_batch(indices, n)), good.pad)
    with pytest.raises(ConformanceError, match="make_batch: rewards must be 1 finite numbers"):
        check_body_batch(flaky, envs_per_body=1, steps=2)
