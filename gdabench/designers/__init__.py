"""Built-in designers (registered through the ``gdabench_designers`` hook)."""

from __future__ import annotations

from ..specs import DesignerSpec, hookimpl


@hookimpl
def gdabench_designers() -> list[DesignerSpec]:
    return [
        DesignerSpec(
            name="ga",
            factory="gdabench.designers.ga:GeneticAlgorithm",
            description="Evolution Gym's genetic algorithm: mutation only, survivors 60% -> 0% of the population",
        ),
        DesignerSpec(
            name="cppn",
            factory="gdabench.designers.cppn:CppnNeat",
            description="Evolution Gym's CPPN-NEAT on neat-python: CPPNs paint bodies, NEAT evolves the CPPNs",
        ),
        DesignerSpec(
            name="random",
            factory="gdabench.designers.random_search:RandomSearch",
            description="Fresh random valid bodies every generation: the floor any designer must beat",
        ),
        DesignerSpec(
            name="gda",
            factory="gdabench.designers.gda:GenerationalDiffusion",
            description="Generational diffusion algorithm of the thesis: a fresh DDPM trained on the survivors each "
                        "generation",
        ),
        DesignerSpec(
            name="gda-fast",
            factory="gdabench.designers.gda:GenerationalDiffusion",
            description="GDA with the best measured improvements (docs/designers/gda.md): a reward model picks from a "
                        "pool of DDIM samples",
            defaults={"epochs": 10, "sampler": "ddim", "sample_steps": 50, "pool": 1000, "max_samples": 2000},
        ),
        DesignerSpec(
            name="nevergrad",
            factory="gdabench.designers.ecosystem.nevergrad_designer:NevergradDesigner",
            description="nevergrad's optimizers (NGOpt, DiscreteOnePlusOne, ...) on the voxel codes; extra: nevergrad",
        ),
        DesignerSpec(
            name="bo",
            factory="gdabench.designers.ecosystem.bayesopt:BayesianOptimization",
            description="Bayesian optimisation on BoTorch: a GP on one-hot bodies Thompson-samples each generation "
                        "from random and mutated bodies; extra: bo",
        ),
        DesignerSpec(
            name="ribs-map-elites",
            factory="gdabench.designers.ecosystem.pyribs_designer:RibsMapElites",
            description="pyribs MAP-Elites (Gaussian emitters) on filled share x actuator share; extra: ribs",
        ),
        DesignerSpec(
            name="ribs-cma-me",
            factory="gdabench.designers.ecosystem.pyribs_designer:RibsMapElites",
            description="pyribs CMA-ME (improvement-ranked CMA-ES emitters) on filled share x actuator share; extra: "
                        "ribs",
            defaults={"emitter": "cma"},
        ),
    ]
