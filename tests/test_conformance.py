"""The conformance helpers accept the built-ins and catch designers that break the contract."""

from __future__ import annotations

import re

import numpy as np
import pytest

from gdabench.body import random_body
from gdabench.designers.ga import GeneticAlgorithm
from gdabench.designers.random_search import RandomSearch
from gdabench.envs.simple import SumOfVoxels
from gdabench.testing import ConformanceError, check_designer, check_environment


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
