"""Express a CPPN genome as a voxel body, the way Evolution Gym's CPPN-NEAT does.

Evolution Gym queries the network once per voxel with inputs ``x`` (row index), ``y`` (column
index) and ``d`` (distance to the grid centre) and takes the voxel code of the largest of the
five outputs.  Its networks are built by PyTorch-NEAT; this module evaluates the same graph with
numpy and keeps that library's semantics, because they decide which bodies a genome makes:

* computation in float32, so strong activations saturate to exactly 1.0 and ties go to the
  lowest voxel code (argmax takes the first maximum);
* a node without incoming connections outputs its raw bias (not ``activation(bias)``);
* disabled connections are ignored, connections out of output nodes are ignored, and a
  connection is used when either end is needed for the outputs;
* activations are PyTorch-NEAT's (``sigmoid`` is ``1 / (1 + exp(-5 z))``).
"""

from __future__ import annotations

import functools
import operator
from typing import Any, Callable, Sequence

import numpy as np
from neat.graphs import required_for_output

Array = np.ndarray

#: activation functions PyTorch-NEAT offers, by neat-python name
ACTIVATIONS: dict[str, Callable[[Array], Array]] = {
    "sigmoid": lambda z: 1 / (1 + np.exp(-5 * z)),
    "tanh": lambda z: np.tanh(2.5 * z),
    "abs": np.abs,
    "gauss": lambda z: np.exp(-5 * z * z),
    "identity": lambda z: z,
    "sin": np.sin,
    "relu": lambda z: np.maximum(z, 0),
}

#: aggregation functions over the weighted inputs of a node (summed in connection order)
AGGREGATIONS: dict[str, Callable[[Sequence[Array]], Array | float]] = {
    "sum": lambda xs: sum(xs),
    "product": lambda xs: functools.reduce(operator.mul, xs, 1),
}


@functools.lru_cache(maxsize=8)
def cppn_inputs(shape: tuple[int, int]) -> tuple[Array, Array, Array]:
    """Per-voxel inputs ``x, y, d`` (row-major, float32) for a grid of ``shape``."""
    gx, gy = np.meshgrid(np.arange(shape[0]), np.arange(shape[1]), indexing="ij")
    x, y = gx.ravel().astype(np.float32), gy.ravel().astype(np.float32)
    cx, cy = (shape[0] - 1) / 2, (shape[1] - 1) / 2
    d = np.sqrt((x - cx) ** 2 + (y - cy) ** 2).astype(np.float32)
    for a in (x, y, d):
        a.flags.writeable = False
    return x, y, d


def cppn_outputs(genome: Any, genome_config: Any, shape: tuple[int, int]) -> Array:
    """The network's outputs for every voxel: shape ``(num_outputs, H * W)``, float32."""
    inputs, outputs = genome_config.input_keys, genome_config.output_keys
    # like PyTorch-NEAT, "required" is computed over all connection genes, enabled or not
    required = required_for_output(inputs, outputs, genome.connections)
    incoming: dict[int, list[tuple[int, float]]] = {k: [] for k in outputs}
    for gene in genome.connections.values():
        src, dst = gene.key
        if not gene.enabled or (src not in required and dst not in required) or src in outputs:
            continue
        incoming.setdefault(dst, []).append((src, gene.weight))
        incoming.setdefault(src, [])

    values: dict[int, Array] = dict(zip(inputs, cppn_inputs(shape)))

    def value(key: int) -> Array:
        if key not in values:
            node = genome.nodes[key]
            conns = incoming[key]
            if not conns:
                values[key] = np.full(shape[0] * shape[1], node.bias, dtype=np.float32)
            else:
                total = AGGREGATIONS[node.aggregation]([w * value(src) for src, w in conns])
                values[key] = ACTIVATIONS[node.activation](node.response * total + node.bias)
        return values[key]

    with np.errstate(over="ignore", invalid="ignore"):
        return np.stack([value(k) for k in outputs]).astype(np.float32, copy=False)


def cppn_voxels(genome: Any, genome_config: Any, shape: tuple[int, int]) -> Array:
    """The body a genome makes: per voxel, the code of the largest output (int8, ``shape``)."""
    return cppn_outputs(genome, genome_config, shape).argmax(axis=0).astype(np.int8).reshape(shape)
