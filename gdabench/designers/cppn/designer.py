"""Evolution Gym's CPPN-NEAT (``examples/cppn_neat``) as an ask/tell designer on neat-python.

Each genome is a CPPN that paints a body (:mod:`.painting`); NEAT evolves the genomes.  The
harness owns evaluation, so instead of ``neat.Population.run`` the designer steps neat-python's
parts itself, in the order Evolution Gym's ``Population.run`` does:

``ask``   express every genome; a genome whose body is invalid or was proposed before in this
          run is dropped and fresh random genomes are drawn until the population is full again
          (Evolution Gym's constraint step); then the population is re-speciated;
``tell``  the rewards become the genomes' fitness; neat-python reproduces (fitness sharing,
          stagnation, crossover, mutation) and speciates the children.

neat-python draws from Python's global ``random`` module.  Every call into it runs with the
designer's own generator state swapped in (and the caller's state restored afterwards), so a
seed always gives the same run, and a ``cppn`` run does not shift the random stream of anything
else in the process.  Not thread-safe: two threads driving neat-python at once would share the
global generator.
"""

from __future__ import annotations

import contextlib
import math
import random
from itertools import count
from typing import Any, Iterator, Mapping, Sequence

import neat
import numpy as np
from neat.reporting import ReporterSet

from ...body import Body, invalid_reason
from ...designer import Designer, nearest_first
from ...errors import ConfigError, DesignerError
from .config import load_config, read_config_text
from .painting import cppn_voxels

#: neat-python objects rebuilt from the config text when a pickled designer is restored
_NEAT_PARTS = ("_config", "_stagnation", "_reproduction", "_species")


class CppnNeat(Designer):
    """CPPN-NEAT with Evolution Gym's configuration (or a user's neat-python config file).

    Parameters:
        config: a neat-python config file to use instead of Evolution Gym's (the population size comes from
            --population)
        max_replacements: fresh genomes tried per generation to replace invalid or repeated bodies
    """

    def __init__(self, *, config: str | None = None, max_replacements: int = 100_000, **kwargs: Any):
        super().__init__(**kwargs)
        if max_replacements < 1:
            raise ConfigError(f"cppn: max_replacements must be at least 1, got {max_replacements}")
        self.config_source = str(config) if config is not None else "(built-in)"
        self.config_text = read_config_text(config)
        self.max_replacements = int(max_replacements)
        words = self.seed_sequence.spawn(1)[0].generate_state(4, dtype=np.uint32)
        self._random_state = random.Random(sum(int(w) << (32 * i) for i, w in enumerate(words))).getstate()
        self._build_neat()
        self.generation = 0
        self.best_genome: Any = None  # the fittest genome told so far (neat.DefaultGenome)
        self._seen: set[str] = set()  # hashes of every body proposed (Evolution Gym's structure_hashes)
        self._proposal: list[tuple[int, Body]] | None = None  # (genome id, body) of the pending ask
        self._info: list[dict[str, Any]] = []
        #: genome id -> bodies of its parents (neat-python's ``ancestors``), kept from ``tell`` to the next ``ask``
        self._lineage: dict[int, tuple[Body, ...]] = {}
        self._parents: list[tuple[Body, ...]] = []
        with self._neat_random():
            self._genomes = self._reproduction.create_new(
                self._config.genome_type, self._config.genome_config, self.population
            )
            self._species.speciate(self._config, self._genomes, self.generation)

    @property
    def neat_config(self) -> Any:
        """The neat-python configuration in use (``neat.Config``): the file's settings, the harness's population."""
        return self._config

    # -- ask/tell ----------------------------------------------------------------------------
    def ask(self) -> list[Body]:
        if self._proposal is None:
            with self._neat_random():
                self._proposal, fresh, replaced = self._fill_population()
                self._species.speciate(self._config, self._genomes, self.generation)
            self._info = [self._row_info(gid, gid in fresh, replaced) for gid, _ in self._proposal]
            self._parents = [
                tuple(nearest_first(body, self._lineage.get(gid, ()))) if gid not in fresh else ()
                for gid, body in self._proposal
            ]
        return [body for _, body in self._proposal]

    def tell(self, bodies: Sequence[Body], rewards: Sequence[float]) -> None:
        if self._proposal is None:
            raise DesignerError("cppn: tell() called without a pending ask()")
        if [b.hash for b in bodies] != [b.hash for _, b in self._proposal]:
            raise DesignerError("cppn: tell() got other bodies than the last ask() proposed")
        for (gid, _), fitness in zip(self._proposal, _fitnesses(rewards)):
            genome = self._genomes[gid]
            genome.fitness = fitness
            if self.best_genome is None or fitness > self.best_genome.fitness:
                self.best_genome = genome
        config = self._config
        with self._neat_random():
            children = self._reproduction.reproduce(config, self._species, config.pop_size, self.generation)
            if not self._species.species:  # every species stagnated
                if not config.reset_on_extinction:
                    raise DesignerError(
                        "cppn: every species went extinct and the config says reset_on_extinction = False"
                    )
                children = self._reproduction.create_new(config.genome_type, config.genome_config, config.pop_size)
            self._species.speciate(config, children, self.generation)
        told = dict(self._proposal)
        ancestors = getattr(self._reproduction, "ancestors", {})
        self._lineage = {
            gid: tuple(told[p] for p in dict.fromkeys(ancestors.get(gid, ())) if p in told) for gid in children
        }
        self._genomes = children
        self.generation += 1
        self._proposal = None

    def proposal_info(self) -> list[Mapping[str, Any]]:
        """Why CPPN bodies look as they do: the genome's species and size, and replacements."""
        return list(self._info)

    def proposal_parents(self) -> list[Sequence[Body]]:
        """A genome's parents as neat-python records them (``DefaultReproduction.ancestors``: the two genomes
        crossed, or one for a copy), as the bodies they painted, nearest first; fresh genomes have none."""
        return list(self._parents)

    def body_of(self, genome: Any) -> Body:
        """The body a genome of this designer paints (e.g. ``designer.body_of(designer.best_genome)``)."""
        return Body(cppn_voxels(genome, self._config.genome_config, self.shape))

    # -- Evolution Gym's constraint step ---------------------------------------------------------
    def _fill_population(self) -> tuple[list[tuple[int, Body]], set[int], int]:
        """Keep genomes with new valid bodies; replace the others by fresh random genomes."""
        config = self._config
        kept: dict[int, tuple[Any, Body]] = {}
        fresh: set[int] = set()
        candidates, replaced = list(self._genomes.items()), 0
        while True:
            for gid, genome in candidates:
                voxels = cppn_voxels(genome, config.genome_config, self.shape)
                body = Body(voxels) if invalid_reason(voxels) is None else None
                if body is None or body.hash in self._seen:
                    replaced += 1
                    continue
                self._seen.add(body.hash)
                kept[gid] = (genome, body)
            missing = self.population - len(kept)
            if missing <= 0:
                break
            if replaced > self.max_replacements:
                raise DesignerError(
                    f"cppn: {replaced} genomes in a row painted invalid or already proposed bodies "
                    f"(max_replacements = {self.max_replacements}); is the body space exhausted?"
                )
            candidates = list(self._reproduction.create_new(config.genome_type, config.genome_config, missing).items())
            fresh.update(gid for gid, _ in candidates)
        self._genomes = {gid: genome for gid, (genome, _) in kept.items()}
        return [(gid, body) for gid, (_, body) in kept.items()], fresh, replaced

    def _row_info(self, gid: int, fresh: bool, replaced: int) -> dict[str, Any]:
        nodes, connections = self._genomes[gid].size()
        return {
            "cppn_genome": gid,
            "cppn_species": self._species.get_species_id(gid),
            "cppn_species_count": len(self._species.species),
            "cppn_nodes": nodes,
            "cppn_connections": connections,
            "cppn_fresh": fresh,
            "cppn_replaced": replaced,
        }

    # -- neat-python plumbing ----------------------------------------------------------------------
    def _build_neat(self) -> None:
        self._config = load_config(self.config_text, self.population, self.config_source)
        reporters = ReporterSet()
        self._stagnation = neat.DefaultStagnation(self._config.stagnation_config, reporters)
        self._reproduction = neat.DefaultReproduction(self._config.reproduction_config, reporters, self._stagnation)
        self._species = neat.DefaultSpeciesSet(self._config.species_set_config, reporters)

    @contextlib.contextmanager
    def _neat_random(self) -> Iterator[None]:
        """Run neat-python on this designer's private state of the global ``random`` generator."""
        outer = random.getstate()
        random.setstate(self._random_state)
        try:
            yield
        finally:
            self._random_state = random.getstate()
            random.setstate(outer)

    def __getstate__(self) -> dict[str, Any]:
        # neat-python's own pickling advances its id counters as a side effect, so the live
        # objects are not pickled; their state is, and __setstate__ rebuilds them from the config.
        state = {k: v for k, v in self.__dict__.items() if k not in _NEAT_PARTS}
        state["_neat_state"] = {
            "species": self._species.species,
            "genome_to_species": self._species.genome_to_species,
            "next_species_id": _peek(self._species, "indexer"),
            "next_genome_id": _peek(self._reproduction, "genome_indexer"),
            "next_node_id": _peek(self._config.genome_config, "node_indexer"),
            "innovations": self._reproduction.innovation_tracker,
        }
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        saved = state.pop("_neat_state")
        self.__dict__.update(state)
        self._build_neat()
        self._species.species = saved["species"]
        self._species.genome_to_species = saved["genome_to_species"]
        self._species.indexer = count(saved["next_species_id"])
        self._reproduction.genome_indexer = count(saved["next_genome_id"])
        self._reproduction.innovation_tracker = saved["innovations"]
        if saved["next_node_id"] is not None:
            self._config.genome_config.node_indexer = count(saved["next_node_id"])


def _peek(owner: Any, attr: str) -> int | None:
    """Next value of ``owner.attr`` (an ``itertools.count`` or None) without losing it."""
    counter = getattr(owner, attr)
    if counter is None:
        return None
    value = next(counter)
    setattr(owner, attr, count(value))
    return value


def _fitnesses(rewards: Sequence[float]) -> list[float]:
    """Rewards as NEAT fitness; a body that could not be scored ranks with its generation's worst."""
    finite = [float(r) for r in rewards if not math.isnan(float(r))]
    floor = min(finite) if finite else 0.0
    return [floor if math.isnan(float(r)) else float(r) for r in rewards]
