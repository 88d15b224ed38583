"""GA invariants: Evolution Gym's survivor schedule, survivors unchanged, children new and valid."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gdabench.body import Body
from gdabench.designers.ga import GeneticAlgorithm
from gdabench.designers.random_search import RandomSearch
from gdabench.errors import ConfigError
from gdabench.seeding import designer_seed


def simple_reward(body: Body) -> float:
    return float(body.voxels.sum())


def drive(designer, budget: int):
    """Run ask/tell like the harness does; return the generations as (bodies, rewards)."""
    history, evals = [], 0
    while evals < budget:
        bodies = designer.ask()
        rewards = [simple_reward(b) for b in bodies]
        evals += len(bodies)
        history.append((bodies, rewards, list(designer.survivors) if hasattr(designer, "survivors") else None))
        if evals < budget:
            designer.tell(bodies, rewards)
    return history


def evogym_schedule(pop: int, budget: int) -> list[int]:
    """Children per generation as Evolution Gym's run_ga produces them (its own arithmetic)."""
    sizes, evals = [pop], pop
    while evals < budget:
        pct = 0.6 * (budget - evals - 1) / (budget - 1)
        survivors = max(2, math.ceil(pop * pct))
        children = min(pop - survivors, budget - evals)
        sizes.append(children)
        evals += children
    return sizes


@pytest.mark.parametrize("pop, budget", [(25, 1000), (25, 300), (10, 137)])
def test_generation_sizes_follow_evogym_schedule(pop, budget):
    ga = GeneticAlgorithm(population=pop, budget=budget, seed=designer_seed(3))
    history = drive(ga, budget)
    assert [len(b) for b, _, _ in history] == evogym_schedule(pop, budget)
    assert sum(len(b) for b, _, _ in history) == budget


def test_survivor_counts_schedule_endpoints():
    ga = GeneticAlgorithm(population=25, budget=1000, seed=0)
    assert ga.survivor_count(25) == math.ceil(25 * 0.6 * (1000 - 25 - 1) / 999) == 15
    assert ga.survivor_count(999) == 2  # never below two
    assert GeneticAlgorithm(population=25, budget=1000, survivors=5).survivor_count(500) == 5


def test_survivors_keep_bodies_and_scores_and_are_the_best():
    ga = GeneticAlgorithm(population=25, budget=400, seed=designer_seed(1))
    all_scores: dict[str, float] = {}
    evals = 0
    previous: list[tuple[Body, float]] = []
    while evals < 400:
        bodies = ga.ask()
        # children are new bodies, each a mutation of a current survivor
        assert not {b.hash for b in bodies} & set(all_scores)
        rewards = [simple_reward(b) for b in bodies]
        all_scores.update({b.hash: r for b, r in zip(bodies, rewards)})
        evals += len(bodies)
        ga.tell(bodies, rewards)
        # survivors are the top-k of (previous survivors + this generation), with their original scores
        pool = previous + list(zip(bodies, rewards))
        k = ga.survivor_count(evals)
        assert len(ga.survivors) == k
        kept = [r for _, r in ga.survivors]
        assert kept == sorted(kept, reverse=True) and sorted(kept) == sorted(r for _, r in pool)[-k:]
        for body, reward in ga.survivors:
            assert all_scores[body.hash] == reward
        survivor_texts = {b.text for b, _ in ga.survivors}
        for body, _ in previous:
            if body.text in survivor_texts:  # a surviving body is the very same value, unchanged
                assert any(s is body for s, _ in ga.survivors)
        previous = list(ga.survivors)


def test_children_differ_from_parents_and_are_valid_and_unique():
    ga = GeneticAlgorithm(population=25, budget=1000, survivors=5, seed=designer_seed(7))
    history = drive(ga, 1000)
    seen = set()
    for bodies, _, _ in history:
        for b in bodies:
            assert b.is_valid() and b.hash not in seen
            seen.add(b.hash)
    ga2 = GeneticAlgorithm(population=25, budget=1000, survivors=5, seed=designer_seed(7))
    first = ga2.ask()
    ga2.tell(first, [simple_reward(b) for b in first])
    children = ga2.ask()
    parents = {p["parent"] for p in ga2.proposal_info()}
    survivors = {b.hash: b for b, _ in ga2.survivors}
    assert parents <= set(survivors)
    for child, info in zip(children, ga2.proposal_info()):
        parent = survivors[info["parent"]]
        assert child != parent
        # mutation is local: a child shares most voxels with its parent (rate 0.1, <= 50 attempts)
        assert (child.voxels != parent.voxels).sum() < 25


def test_same_seed_same_bodies_different_seed_different_bodies():
    def texts(seed):
        return [
            b.text
            for gen, _, _ in drive(GeneticAlgorithm(population=25, budget=200, seed=designer_seed(seed)), 200)
            for b in gen
        ]

    assert texts(5) == texts(5)
    assert texts(5) != texts(6)


def test_fixed_survivors_keep_five():
    ga = GeneticAlgorithm(population=25, budget=500, survivors=5, seed=designer_seed(0))
    history = drive(ga, 500)
    assert [len(b) for b, _, _ in history][:3] == [25, 20, 20]
    assert len(ga.survivors) == 5


def test_ga_beats_random_on_simple():
    def best(designer):
        return max(max(r) for _, r, _ in drive(designer, 1000))

    ga = [best(GeneticAlgorithm(population=25, budget=1000, seed=designer_seed(s))) for s in range(3)]
    rnd = [best(RandomSearch(population=25, budget=1000, seed=designer_seed(s))) for s in range(3)]
    assert np.median(ga) > np.median(rnd) + 5


@pytest.mark.parametrize(
    "kwargs, fragment",
    [
        ({"population": 25, "survivors": 25}, "survivors must be between 1 and population - 1"),
        ({"population": 25, "survivors": 0}, "survivors must be between"),
        ({"population": 2}, "population must be at least 3"),
        ({"population": 25, "mutation_rate": 0}, "mutation_rate"),
        ({"population": 0}, "population must be at least 1"),
    ],
)
def test_bad_parameters(kwargs, fragment):
    with pytest.raises(ConfigError, match=fragment):
        GeneticAlgorithm(budget=100, **kwargs)
