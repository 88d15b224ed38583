"""Bodies: validity against a brute-force reference, hashing, text form, immutability, sampler."""

from __future__ import annotations

import pickle
from collections import deque

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from hypothesis.extra.numpy import arrays

from gdabench.body import (
    EVOGYM_VOXEL_WEIGHTS,
    Body,
    as_body,
    has_actuator,
    invalid_reason,
    is_connected,
    parse_shape,
    random_body,
    valid_mask,
)
from gdabench.errors import MalformedBodyError


def reference_connected(grid: np.ndarray) -> bool:
    """Breadth-first search over edge neighbours: the definition, written the slow obvious way."""
    cells = {(int(r), int(c)) for r, c in zip(*np.nonzero(grid))}
    if not cells:
        return False
    start = next(iter(cells))
    seen, queue = {start}, deque([start])
    while queue:
        r, c = queue.popleft()
        for nb in ((r + 1, c), (r - 1, c), (r, c + 1), (r, c - 1)):
            if nb in cells and nb not in seen:
                seen.add(nb)
                queue.append(nb)
    return seen == cells


grids = st.tuples(st.integers(1, 7), st.integers(1, 7)).flatmap(
    lambda shape: arrays(np.int8, shape, elements=st.sampled_from([0, 0, 0, 1, 2, 3, 4]))
)


@settings(max_examples=600, deadline=None)
@given(grids)
def test_validity_matches_brute_force(grid):
    assert is_connected(grid) == reference_connected(grid)
    expected_valid = reference_connected(grid) and bool(np.isin(grid, (3, 4)).any())
    assert (invalid_reason(grid) is None) == expected_valid
    assert Body(grid).is_valid() == expected_valid


def test_validity_examples():
    assert Body.from_text("33/00").is_valid()
    assert Body.from_text("30/03").invalid_reason() == "voxels not connected"  # diagonal only
    assert Body.from_text("11/22").invalid_reason() == "no actuator"
    assert not is_connected(np.zeros((3, 3), dtype=np.int8))
    assert not has_actuator(np.ones((2, 2), dtype=np.int8))
    # wrap-around must not connect the end of one row to the start of the next
    assert Body.from_text("003/300/000").invalid_reason() == "voxels not connected"


def test_text_round_trip_and_forms():
    body = Body(np.arange(25).reshape(5, 5) % 5)
    assert body.text == "01234/01234/01234/01234/01234"
    assert Body.from_text(body.text) == body
    assert Body.from_text("0 1 2 3 4 / 01234\n01234;01234/01234") == body
    assert as_body(body.text) == body and as_body(body) is body and as_body(body.voxels.tolist()) == body


@pytest.mark.parametrize(
    "text, fragment",
    [("", "no voxels"), ("0123/012", "different lengths"), ("01a34", "'a' is not a voxel code"), ("56789", "'5'")],
)
def test_malformed_text_is_one_readable_line(text, fragment):
    with pytest.raises(MalformedBodyError) as info:
        Body.from_text(text)
    assert fragment in str(info.value) and "\n" not in str(info.value)


@pytest.mark.parametrize(
    "value", [np.zeros((2, 2, 2)), [[0, 1], [2]], [[5, 0]], [[-1, 0]], [[0.5, 1.0]], np.zeros((0, 3))]
)
def test_malformed_arrays_rejected(value):
    with pytest.raises(MalformedBodyError):
        Body(value)


def test_hash_is_stable_and_shape_aware():
    assert (
        Body.from_text("44444/44444/44444/44444/44444").hash == "efed6bd4377f7449"
    )  # blake2b-64 of b"5x5:" + codes; fixed forever
    flat = Body.from_text("3333")
    assert flat.hash != Body.from_text("33/33").hash  # same bytes, different shape
    assert len({Body.from_text(t).hash for t in ("3", "4", "34", "43")}) == 4


def test_body_is_immutable_and_copies_its_input():
    source = np.full((3, 3), 4, dtype=np.int8)
    body = Body(source)
    source[0, 0] = 0
    assert body.voxels[0, 0] == 4
    with pytest.raises(ValueError):
        body.voxels[0, 0] = 1
    assert pickle.loads(pickle.dumps(body)) == body


def test_random_body_is_valid_unique_and_follows_evogym_weights():
    rng = np.random.default_rng(0)
    seen: set[str] = set()
    bodies = []
    for _ in range(300):
        b = random_body(rng, (5, 5), exclude=seen)
        seen.add(b.hash)
        bodies.append(b)
    assert all(b.is_valid() for b in bodies) and len(seen) == 300
    # before the validity filter the sampler draws empty with probability 3/7
    assert EVOGYM_VOXEL_WEIGHTS[0] == pytest.approx(3 / 7)
    freq = np.bincount(np.concatenate([b.voxels.ravel() for b in bodies]), minlength=5) / (300 * 25)
    assert 0.25 < freq[0] < 0.45  # validity favours fuller bodies a little
    assert all(0.1 < f < 0.25 for f in freq[1:])


def one_at_a_time(rng: np.random.Generator, shape, exclude) -> Body:
    """Evolution Gym's sample_robot as written: one grid per draw until it is valid and new."""
    p = EVOGYM_VOXEL_WEIGHTS / EVOGYM_VOXEL_WEIGHTS.sum()
    while True:
        voxels = rng.choice(5, size=shape, p=p).astype(np.int8)
        if invalid_reason(voxels) is None and Body(voxels).hash not in exclude:
            return Body(voxels)


@pytest.mark.parametrize("shape, n", [((5, 5), 60), ((3, 7), 40), ((1, 2), 10), ((12, 12), 3)])
def test_batched_sampler_draws_exactly_what_one_at_a_time_drawing_does(shape, n):
    ours, theirs = np.random.default_rng(7), np.random.default_rng(7)
    seen: set[str] = set()
    for _ in range(n):
        body = random_body(ours, shape, exclude=seen)
        assert body == one_at_a_time(theirs, shape, seen)
        seen.add(body.hash)
    assert ours.random() == theirs.random()  # the stream goes on where one-at-a-time drawing left it


@given(arrays(np.int8, st.tuples(st.integers(1, 6), st.integers(1, 6), st.integers(1, 6)), elements=st.integers(0, 4)))
@settings(max_examples=200, deadline=None)
def test_valid_mask_is_the_validity_rule_grid_by_grid(grids):
    assert valid_mask(grids).tolist() == [invalid_reason(g) is None for g in grids]


def test_parse_shape():
    assert parse_shape("5x5") == (5, 5) and parse_shape("3X7") == (3, 7) and parse_shape([2, 4]) == (2, 4)
    for bad in ("5", "x5", "0x5", "axb"):
        with pytest.raises(MalformedBodyError):
            parse_shape(bad)
