"""The ``cppn`` designer: Evolution Gym's CPPN-NEAT on neat-python, through ask/tell."""

from __future__ import annotations

import configparser
import io
import pickle
import random
from pathlib import Path

import neat
import numpy as np
import pytest
from typer.testing import CliRunner

from gdabench import hookimpl
from gdabench.body import Body, random_body
from gdabench.cli import app
from gdabench.designer import Designer
from gdabench.designers.cppn import CppnNeat
from gdabench.designers.cppn.config import load_config, shipped_config_text
from gdabench.designers.cppn.painting import cppn_voxels
from gdabench.envs.simple import SumOfVoxels
from gdabench.errors import ConfigError
from gdabench.execution import Execution
from gdabench.experiment.config import Experiment, PluginChoice
from gdabench.plugins import Registry
from gdabench.running.runner import compare
from gdabench.specs import DesignerSpec
from gdabench.testing import check_designer

SIMPLE = SumOfVoxels(shape=(5, 5))


def simple_rewards(bodies: list[Body]) -> list[float]:
    return [SIMPLE.evaluate(b, seed=0) for b in bodies]


def drive(designer: CppnNeat, generations: int) -> list[tuple[list[str], list[dict]]]:
    """Run ask/tell on the simple reward; returns each generation's bodies and extras."""
    history = []
    for _ in range(generations):
        bodies = designer.ask()
        history.append(([b.text for b in bodies], [dict(i) for i in designer.proposal_info()]))
        designer.tell(bodies, simple_rewards(bodies))
    return history


# -- configuration ------------------------------------------------------------------------------
def test_shipped_config_has_evolution_gym_values():
    config = load_config(shipped_config_text(), population=25)
    g = config.genome_config
    assert config.pop_size == 25
    assert (g.num_inputs, g.num_outputs, g.num_hidden) == (3, 5, 1)
    assert (g.initial_connection, g.connection_fraction) == ("partial_direct", 0.5)
    assert g.feed_forward is True
    assert (g.activation_default, g.activation_options, g.activation_mutate_rate) == ("sigmoid", ["sigmoid"], 0.0)
    assert (g.aggregation_default, g.aggregation_options, g.aggregation_mutate_rate) == ("sum", ["sum"], 0.0)
    assert (g.conn_add_prob, g.conn_delete_prob, g.node_add_prob, g.node_delete_prob) == (0.2, 0.2, 0.2, 0.2)
    for attr in ("bias", "weight"):
        assert (getattr(g, f"{attr}_init_mean"), getattr(g, f"{attr}_init_stdev")) == (0.0, 1.0)
        assert getattr(g, f"{attr}_init_type") == "gaussian"
        assert (getattr(g, f"{attr}_mutate_power"), getattr(g, f"{attr}_replace_rate")) == (0.5, 0.1)
        assert (getattr(g, f"{attr}_min_value"), getattr(g, f"{attr}_max_value")) == (-30.0, 30.0)
    assert (g.bias_mutate_rate, g.weight_mutate_rate) == (0.7, 0.8)
    assert (g.response_init_mean, g.response_init_stdev, g.response_mutate_rate, g.response_replace_rate) == (
        1.0,
        0.0,
        0.0,
        0.0,
    )
    assert g.enabled_mutate_rate == 0.01
    assert (g.compatibility_disjoint_coefficient, g.compatibility_weight_coefficient) == (1.0, 0.6)
    assert config.species_set_config.compatibility_threshold == 3.0
    # the defaults of Evolution Gym's neat-python fork, written out (neat-python 2 changed min_species_size)
    r, s = config.reproduction_config, config.stagnation_config
    assert (r.elitism, r.survival_threshold, r.min_species_size) == (0, 0.2, 2)
    assert (s.species_fitness_func, s.max_stagnation, s.species_elitism) == ("mean", 15, 0)
    assert config.reset_on_extinction is True


def test_population_comes_from_the_harness_and_user_config_is_used(tmp_path):
    path = tmp_path / "mine.cfg"
    path.write_text(shipped_config_text().replace("conn_add_prob    = 0.2", "conn_add_prob    = 0.5"))
    designer = CppnNeat(config=str(path), population=10, seed=np.random.SeedSequence(0))
    assert designer.neat_config.genome_config.conn_add_prob == 0.5
    assert designer.neat_config.pop_size == 10
    assert len(designer.ask()) == 10


def _edit(section: str, key: str, value: str | None) -> str:
    parser = configparser.ConfigParser()
    parser.read_string(shipped_config_text())
    if value is None:
        parser.remove_option(section, key)
    else:
        parser[section][key] = value
    buffer = io.StringIO()
    parser.write(buffer)
    return buffer.getvalue()


@pytest.mark.parametrize(
    "section, key, value",
    [
        ("DefaultGenome", "conn_add_prob", "lots"),
        ("DefaultGenome", "feed_forward", "maybe"),
        ("NEAT", "no_fitness_termination", "maybe"),
        ("DefaultGenome", "initial_connection", "bogus"),
        ("DefaultGenome", "initial_connection", "partial_direct 1.5"),
        ("DefaultGenome", "weight_max_value", "-50"),
        ("DefaultGenome", "foo_bar", "1"),
        ("DefaultGenome", "num_inputs", "4"),
        ("DefaultGenome", "num_outputs", "3"),
        ("DefaultGenome", "feed_forward", "False"),
        ("DefaultGenome", "activation_options", "sigmoid banana"),
        ("DefaultGenome", "aggregation_default", "median"),
        ("DefaultStagnation", "species_fitness_func", "best"),
        ("NEAT", "seed", "3"),
        ("DefaultGenome", "num_hidden", None),
    ],
)
def test_bad_config_is_one_line_naming_the_key(tmp_path, section, key, value):
    path = tmp_path / "bad.cfg"
    path.write_text(_edit(section, key, value))
    with pytest.raises(ConfigError) as info:
        CppnNeat(config=str(path), seed=np.random.SeedSequence(0))
    message = str(info.value)
    assert "\n" not in message
    assert key in message and str(path) in message


def test_unreadable_or_malformed_config(tmp_path):
    with pytest.raises(ConfigError, match="cannot read config file"):
        CppnNeat(config=str(tmp_path / "missing.cfg"))
    (tmp_path / "junk.cfg").write_text("no sections here\n")
    with pytest.raises(ConfigError, match="not an INI file"):
        CppnNeat(config=str(tmp_path / "junk.cfg"))


def test_cli_reports_a_bad_config_in_one_line(tmp_path):
    path = tmp_path / "bad.cfg"
    path.write_text(_edit("DefaultGenome", "node_add_prob", "often"))
    result = CliRunner().invoke(
        app,
        [
            "compare",
            "--designers",
            f"cppn[config={path}]",
            "--env",
            "simple",
            "--budget",
            "50",
            "--out",
            str(tmp_path / "run"),
            "-q",
        ],
    )
    assert result.exit_code == 2
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and "node_add_prob" in lines[0]
    assert not (tmp_path / "run").exists()


# -- painting bodies ------------------------------------------------------------------------------
def _genome(
    config: neat.Config, biases: list[float], connections: list[tuple[int, int, float, bool]]
) -> neat.DefaultGenome:
    genome = neat.DefaultGenome(1)
    for key, bias in enumerate(biases):
        node = neat.DefaultNodeGene(key)
        node.bias, node.response, node.activation, node.aggregation, node.time_constant = (
            bias,
            1.0,
            "sigmoid",
            "sum",
            1.0,
        )
        genome.nodes[key] = node
    for n, (src, dst, weight, enabled) in enumerate(connections, start=1):
        gene = neat.DefaultConnectionGene((src, dst), innovation=n)
        gene.weight, gene.enabled = weight, enabled
        genome.connections[gene.key] = gene
    return genome


def test_cppn_paints_bodies_as_evolution_gym_does():
    config = load_config(shipped_config_text(), population=25)
    x, y, d = config.genome_config.input_keys
    # outputs 0-3 have no inputs and give their raw bias; output 4 is sigmoid(5 * (x - 2.5))
    # (x is the row index), so rows 3-4 beat the constant 0.5 of output 3; the disabled
    # connection from y would otherwise dominate output 3 everywhere
    genome = _genome(config, [-5.0, -5.0, -5.0, 0.5, -2.5], [(x, 4, 1.0, True), (y, 3, 30.0, False)])
    expected = np.array([[3] * 5] * 3 + [[4] * 5] * 2)
    assert np.array_equal(cppn_voxels(genome, config.genome_config, (5, 5)), expected)
    # distance to the centre: sigmoid(5 * (d - 1)) > 0.5 only outside the centre cross
    genome = _genome(config, [-5.0, -5.0, -5.0, 0.5, -1.0], [(d, 4, 1.0, True)])
    body = cppn_voxels(genome, config.genome_config, (5, 5))
    assert body[2, 2] == 3 and body[1, 2] == 3 and body[0, 0] == 4 and body[0, 1] == 4
    # a node without inputs outputs its raw bias, not sigmoid(bias): -1 loses to sigmoid(-10) > 0
    genome = _genome(config, [-5.0, -1.0, -5.0, -5.0, -2.0], [(x, 4, 0.0, True)])
    assert np.all(cppn_voxels(genome, config.genome_config, (5, 5)) == 4)


# -- ask/tell --------------------------------------------------------------------------------------
def test_run_bodies_are_valid_unique_and_carry_extras(tmp_path):
    experiment = Experiment(designers=(PluginChoice("cppn"),), envs=PluginChoice("simple"), budget=200, seeds=(0,))
    frame = compare(experiment, tmp_path / "run", command=["test"]).load_evaluations()
    assert len(frame) == 200
    assert (frame["status"] == "ok").all()
    assert frame["body_hash"].is_unique
    assert all(Body.from_text(t).is_valid() for t in frame["body"])
    for column in (
        "cppn_genome",
        "cppn_species",
        "cppn_species_count",
        "cppn_nodes",
        "cppn_connections",
        "cppn_fresh",
        "cppn_replaced",
    ):
        assert column in frame.columns
    assert (frame["cppn_nodes"] >= 5).all()  # five outputs, at least
    per_gen = frame.groupby("generation").agg(fresh=("cppn_fresh", "sum"), replaced=("cppn_replaced", "first"))
    # every rejected genome was replaced by a fresh one; the fresh ones kept are among those
    assert (per_gen["fresh"] <= per_gen["replaced"]).all()
    assert per_gen["replaced"].sum() > 0


def test_fitness_reaches_the_genomes():
    designer = CppnNeat(seed=np.random.SeedSequence(1))
    told = [r for texts, _ in drive(designer, 6) for r in simple_rewards([Body.from_text(t) for t in texts])]
    best = designer.best_genome
    assert best.fitness == max(told)
    assert best.fitness == SIMPLE.evaluate(designer.body_of(best), seed=0)


def test_unscored_bodies_rank_with_the_worst():
    designer = CppnNeat(seed=np.random.SeedSequence(2))
    bodies = designer.ask()
    rewards = simple_rewards(bodies)
    rewards[0] = float("nan")
    designer.tell(bodies, rewards)
    assert len(designer.ask()) == 25


def test_species_form_over_generations():
    designer = CppnNeat(seed=np.random.SeedSequence(0))
    history = drive(designer, 15)
    first = {i["cppn_species"] for i in history[0][1]}
    seen = {i["cppn_species"] for _, infos in history for i in infos}
    assert seen - first, "no new species in 15 generations"
    assert max(infos[0]["cppn_species_count"] for _, infos in history) >= 2


def test_same_seed_same_bodies_whatever_the_global_random_state():
    random.seed(1)
    a = drive(CppnNeat(seed=np.random.SeedSequence(3)), 5)
    random.seed(2)
    b = drive(CppnNeat(seed=np.random.SeedSequence(3)), 5)
    c = drive(CppnNeat(seed=np.random.SeedSequence(4)), 5)
    assert a == b
    assert [t for t, _ in a] != [t for t, _ in c]


def test_global_random_stream_is_left_alone():
    random.seed(7)
    expected = [random.random() for _ in range(5)]
    random.seed(7)
    drive(CppnNeat(seed=np.random.SeedSequence(0)), 3)
    assert [random.random() for _ in range(5)] == expected


class PyRandomDesigner(Designer):
    """A designer that draws from Python's global ``random``, as a third-party plugin might."""

    def ask(self) -> list[Body]:
        rng = np.random.default_rng(random.getrandbits(64))
        return [random_body(rng, self.shape) for _ in range(self.population)]

    def tell(self, bodies, rewards) -> None:
        pass


class PyRandomPlugin:
    @hookimpl
    def gdabench_designers(self):
        return [DesignerSpec(name="pyrandom", factory=PyRandomDesigner, description="test: global random")]


def test_a_cppn_run_in_between_changes_no_other_designer(tmp_path):
    reg = Registry(entry_points=False, extra_plugins={"pyrandom-test": PyRandomPlugin()})

    def rows(names: list[str], out: Path):
        experiment = Experiment(tuple(PluginChoice(n) for n in names), PluginChoice("simple"), budget=75, seeds=(0, 1))
        random.seed(11)
        frame = compare(
            experiment, out, command=["test"], reg=reg, execution=Execution(jobs=1)
        ).load_evaluations()  # one process
        frame = frame[frame["designer"] != "cppn"]
        return frame[["designer", "seed", "generation", "index", "body", "reward"]].reset_index(drop=True)

    alone = rows(["ga", "pyrandom"], tmp_path / "alone")
    between = rows(["ga", "cppn", "pyrandom"], tmp_path / "between")
    assert alone.equals(between)


def test_pickled_designer_resumes_identically():
    live = CppnNeat(seed=np.random.SeedSequence(5))
    drive(live, 3)
    clone = pickle.loads(pickle.dumps(live))
    untouched = CppnNeat(seed=np.random.SeedSequence(5))
    drive(untouched, 3)  # never pickled: pickling must not change the live run either
    assert drive(clone, 4) == drive(live, 4) == drive(untouched, 4)


def test_cppn_passes_the_plugin_conformance_checks():
    check_designer(CppnNeat)
