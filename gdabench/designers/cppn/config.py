"""The neat-python configuration of the ``cppn`` designer: the shipped file, user files, errors.

neat-python reads its configuration from a file and reports problems in messages that often do
not say which entry is wrong (an ``AssertionError`` for a bad ``initial_connection``, "Missing
required item" for a bad boolean).  The harness promises one readable line naming the offending
key, so when neat-python rejects a file, each entry is tried in turn with the shipped value (or
without it, for entries the shipped file lacks); the entry whose replacement makes the file load
is the one reported.
"""

from __future__ import annotations

import configparser
import io
import os
import tempfile
from importlib import resources
from pathlib import Path
from typing import Any, Mapping

import neat
from neat.math_util import stat_functions

from ...errors import ConfigError
from .painting import ACTIVATIONS, AGGREGATIONS

SHIPPED_CONFIG = "neat.cfg"
#: what the CPPN reads and writes; a user config must agree
NUM_INPUTS = 3  # x, y, distance to the centre
NUM_OUTPUTS = 5  # one per voxel code


def shipped_config_text() -> str:
    """The configuration file shipped with gdabench (Evolution Gym's values)."""
    return resources.files(__package__).joinpath(SHIPPED_CONFIG).read_text(encoding="utf-8")


def read_config_text(path: str | os.PathLike[str] | None) -> str:
    """The text of the user's config file, or the shipped one when ``path`` is None."""
    if path is None:
        return shipped_config_text()
    try:
        return Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(
            f"cppn: cannot read config file {str(path)!r}: {exc.strerror if isinstance(exc, OSError) else exc}"
        ) from None


def load_config(text: str, population: int, source: str = "(built-in)") -> neat.Config:
    """Parse and check a neat-python config; ``pop_size`` is replaced by ``population``."""
    parser = _parse(text, source)
    if parser.has_option("NEAT", "seed"):
        raise ConfigError(f"cppn config {source}: [NEAT] seed is not used: the harness seeds every run (--seeds)")
    try:
        config = _neat_config(parser, population)
    except Exception as exc:  # noqa: BLE001 - neat-python raises bare Exception/RuntimeError/AssertionError
        culprit = _culprit(parser, population)
        where = f"[{culprit[0]}] {culprit[1]} = {culprit[2]} is rejected by neat-python: " if culprit else ""
        raise ConfigError(f"cppn config {source}: {where}{_first_line(exc)}") from None
    _check_cppn(config, parser, source)
    return config


def _parse(text: str, source: str) -> configparser.ConfigParser:
    parser = configparser.ConfigParser()
    try:
        parser.read_string(text, source=source)
        for section in parser.sections():
            parser.items(section)  # expands '%' interpolation now, as neat-python will
    except configparser.Error as exc:
        raise ConfigError(f"cppn config {source}: not an INI file: {_first_line(exc)}") from None
    if not parser.has_section("NEAT"):
        raise ConfigError(f"cppn config {source}: no [NEAT] section")
    return parser


def _neat_config(parser: configparser.ConfigParser, population: int) -> neat.Config:
    """Build neat-python's Config (it only reads files) and the parts it checks lazily."""
    parser["NEAT"]["pop_size"] = str(population)
    buffer = io.StringIO()
    parser.write(buffer)
    with tempfile.TemporaryDirectory(prefix="gdabench-cppn-") as tmp:
        path = Path(tmp) / "neat.cfg"
        path.write_text(buffer.getvalue(), encoding="utf-8")
        config = neat.Config(
            neat.DefaultGenome, neat.DefaultReproduction, neat.DefaultSpeciesSet, neat.DefaultStagnation, str(path)
        )
    if config.stagnation_config.species_fitness_func not in stat_functions:
        raise RuntimeError(f"unknown species fitness function {config.stagnation_config.species_fitness_func!r}")
    return config


def _culprit(parser: configparser.ConfigParser, population: int) -> tuple[str, str, str] | None:
    """(section, key, value) of the one entry that makes neat-python fail, if there is one."""
    shipped = configparser.ConfigParser()
    shipped.read_string(shipped_config_text())
    for section in parser.sections():
        for key, value in parser.items(section):
            if section == "NEAT" and key == "pop_size":
                continue
            trial = configparser.ConfigParser()
            trial.read_dict(parser)
            if shipped.has_option(section, key):
                trial[section][key] = shipped[section][key]
            else:
                trial.remove_option(section, key)
            try:
                _neat_config(trial, population)
            except Exception:  # noqa: BLE001 - still failing: this entry is not (alone) the cause
                continue
            return section, key, value
    return None


def _check_cppn(config: neat.Config, parser: configparser.ConfigParser, source: str) -> None:
    """What the CPPN itself needs beyond what neat-python checks."""
    g = config.genome_config

    def bad(key: str, value: object, why: str) -> ConfigError:
        return ConfigError(f"cppn config {source}: [DefaultGenome] {key} = {value}: {why}")

    # neat-python silently ignores unknown [DefaultGenome] entries (a typo would go unnoticed); the
    # entries it knows are the ones its public ``save`` writes
    written = io.StringIO()
    g.save(written)
    known = {line.split("=", 1)[0].strip() for line in written.getvalue().splitlines() if "=" in line}
    for key, value in parser.items("DefaultGenome"):
        if key not in known:
            raise bad(key, value, "unknown configuration item")

    if g.num_inputs != NUM_INPUTS:
        raise bad("num_inputs", g.num_inputs, f"the CPPN reads {NUM_INPUTS} inputs (x, y, distance to the centre)")
    if g.num_outputs != NUM_OUTPUTS:
        raise bad("num_outputs", g.num_outputs, f"the CPPN needs {NUM_OUTPUTS} outputs, one per voxel code")
    if not g.feed_forward:
        raise bad("feed_forward", g.feed_forward, "a CPPN is a feed-forward network; set it to True")
    functions: tuple[tuple[str, Mapping[str, Any]], ...] = (("activation", ACTIVATIONS), ("aggregation", AGGREGATIONS))
    for kind, names in functions:
        default = getattr(g, f"{kind}_default")
        if default.lower() not in ("random", "none") and default not in names:
            raise bad(f"{kind}_default", default, f"not one of {', '.join(names)}")
        for name in getattr(g, f"{kind}_options"):
            if name not in names:
                raise bad(
                    f"{kind}_options",
                    " ".join(getattr(g, f"{kind}_options")),
                    f"{name!r} is not one of {', '.join(names)}",
                )


def _first_line(exc: BaseException) -> str:
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    return (
        " ".join(lines)
        if type(exc).__name__ == "UnknownConfigItemError"
        else (lines[0] if lines else type(exc).__name__)
    )
