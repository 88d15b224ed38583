"""The designers from the ecosystem (nevergrad, bo, ribs-map-elites, ribs-cma-me): conformance,
reproducibility from the seed, what they tell their library, and the error without their extra."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from gdabench.body import Body
from gdabench.designers.ecosystem import RewardScale, descriptors
from gdabench.envs.simple import SumOfVoxels
from gdabench.errors import ConfigError
from gdabench.plugins import registry
from gdabench.seeding import designer_seed
from gdabench.testing import check_designer

# (registered name, params, the library its extra installs)
ADAPTERS = [
    ("nevergrad", {}, "nevergrad"),
    ("nevergrad", {"optimizer": "DiscreteOnePlusOne"}, "nevergrad"),
    ("nevergrad", {"optimizer": "PortfolioDiscreteOnePlusOne"}, "nevergrad"),
    ("bo", {"candidates": 100, "fit_iters": 10}, "botorch"),
    ("ribs-map-elites", {}, "ribs"),
    ("ribs-cma-me", {}, "ribs"),
]
EXTRA = {"nevergrad": "nevergrad", "bo": "bo", "ribs-map-elites": "ribs", "ribs-cma-me": "ribs"}


def factory(name: str, params: dict):
    spec = registry().get("designer", name).spec
    return lambda **harness: spec.create(**harness, **params)


def drive(designer, env, generations: int) -> list[list[str]]:
    texts = []
    for _ in range(generations):
        bodies = designer.ask()
        designer.tell(bodies, [float(env.evaluate(b, seed=0)) for b in bodies])
        texts.append([b.text for b in bodies])
    return texts


@pytest.mark.parametrize("name, params, module", ADAPTERS, ids=lambda v: v if isinstance(v, str) else None)
def test_adapter_conforms(name, params, module):
    pytest.importorskip(module)
    check_designer(factory(name, params), params={}, population=8, budget=200, generations=4)


@pytest.mark.parametrize("name, params, module", ADAPTERS, ids=lambda v: v if isinstance(v, str) else None)
def test_same_seed_same_bodies_other_seed_other_bodies(name, params, module):
    pytest.importorskip(module)
    env = SumOfVoxels(shape=(5, 5))
    make = factory(name, params)
    runs = [drive(make(shape=(5, 5), population=10, budget=100, seed=designer_seed(s)), env, 3) for s in (4, 4, 5)]
    assert runs[0] == runs[1]
    assert runs[0] != runs[2]


@pytest.mark.parametrize(
    "name, module",
    [("nevergrad", "nevergrad"), ("bo", "botorch"), ("ribs-map-elites", "ribs"), ("ribs-cma-me", "ribs")],
)
def test_missing_extra_names_the_pip_install(name, module, monkeypatch):
    monkeypatch.setitem(sys.modules, module, None)  # makes `import module` fail as if it were not installed
    with pytest.raises(ConfigError, match=rf"pip install 'gdabench\[{EXTRA[name]}\]'"):
        registry().get("designer", name).spec.create(shape=(5, 5), population=8, budget=100, seed=0)


def test_nevergrad_unknown_optimizer_names_the_choices():
    pytest.importorskip("nevergrad")
    with pytest.raises(
        ConfigError,
        match="unknown optimizer 'Nope'; choose one of NGOpt, DiscreteOnePlusOne, PortfolioDiscreteOnePlusOne",
    ):
        registry().get("designer", "nevergrad").spec.create(optimizer="Nope")


def test_nevergrad_hears_of_every_proposal_it_made():
    """Invalid and repeated proposals are told (penalty, known reward), so asks and tells balance."""
    pytest.importorskip("nevergrad")
    designer = (
        registry()
        .get("designer", "nevergrad")
        .spec.create(optimizer="DiscreteOnePlusOne", population=10, budget=300, seed=designer_seed(0))
    )
    env = SumOfVoxels(shape=(5, 5))
    drive(designer, env, 10)
    optimizer = designer.optimizer
    assert optimizer.num_ask > 100  # some proposals were refused (invalid or repeated) and asked again
    assert optimizer.num_tell == optimizer.num_ask
    assert len(designer.known) == 100


def test_ribs_decode_is_a_valid_deterministic_map():
    pytest.importorskip("ribs")
    from gdabench.designers.ecosystem.pyribs_designer import decode

    rng = np.random.default_rng(0)
    for shape in [(5, 5), (3, 7)]:
        for _ in range(200):
            bias = rng.normal(scale=2.0, size=5)  # per material: from nearly empty grids to nearly full ones
            x = rng.normal(size=shape[0] * shape[1] * 5) + np.tile(bias, shape[0] * shape[1])
            body = decode(x, shape)
            assert body.is_valid() and body.shape == shape
            assert decode(x.copy(), shape) == body
    all_empty = np.zeros((5, 5, 5))
    all_empty[..., 0] = 1.0
    all_empty[2, 3, 2] = 0.5  # the best non-empty logit: soft at (2, 3); then it needs an actuator
    assert decode(all_empty.ravel(), (5, 5)).voxels[2, 3] in (3, 4)
    assert np.count_nonzero(decode(all_empty.ravel(), (5, 5)).voxels) == 1


def test_ribs_archive_holds_the_bodies_descriptors():
    pytest.importorskip("ribs")
    from gdabench.designers.ecosystem.pyribs_designer import decode

    designer = (
        registry().get("designer", "ribs-map-elites").spec.create(population=10, budget=200, seed=designer_seed(0))
    )
    env = SumOfVoxels(shape=(5, 5))
    drive(designer, env, 5)
    data = designer.archive.data()
    assert len(designer.archive) > 1
    for solution, measures, objective in zip(data["solution"], data["measures"], data["objective"]):
        body = decode(solution, (5, 5))
        np.testing.assert_allclose(measures, descriptors(body))
        assert objective == designer.known[body.hash]


def test_bo_starts_from_the_samplers_bodies_like_ga():
    pytest.importorskip("botorch")
    ga = registry().get("designer", "ga").spec.create(population=10, budget=100, seed=designer_seed(2))
    bo = registry().get("designer", "bo").spec.create(population=10, budget=100, seed=designer_seed(2))
    assert bo.ask() == ga.ask()


def test_bo_picks_better_bodies_than_its_candidates():
    """On simple (reward = a linear count) the GP's Thompson draws choose above the pool's average."""
    pytest.importorskip("botorch")
    env = SumOfVoxels(shape=(5, 5))
    bo = registry().get("designer", "bo").spec.create(population=25, budget=200, seed=designer_seed(0), candidates=300)
    for _ in range(2):
        bodies = bo.ask()
        bo.tell(bodies, [env.evaluate(b, seed=0) for b in bodies])
    pool = bo._candidate_pool()
    chosen = [pool[i] for i in bo._thompson(pool, 25)]
    assert len(set(chosen)) == 25
    pool_mean = np.mean([env.evaluate(b, seed=0) for b in pool])
    chosen_mean = np.mean([env.evaluate(b, seed=0) for b in chosen])
    assert chosen_mean > pool_mean + 3


def test_penalty_ranks_below_every_reward():
    scale = RewardScale()
    assert scale.score(float("nan")) == -1.0
    scale.observe([3.0, float("nan"), 7.0])
    assert scale.penalty == -1.0  # 3 - (7 - 3)
    assert scale.score(5.0) == 5.0
    assert descriptors(Body.from_text("30000/00000/00000/00000/00000")) == (1 / 25, 1.0)
