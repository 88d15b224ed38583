"""Voxel bodies: codes, validity, stable hashing, text form and Evolution Gym's random sampler.

A :class:`Body` is an immutable value.  It copies the array it is built from and marks its own
copy read-only, so nothing a designer does after proposing a body can change what the harness
recorded (the thesis code re-encoded its survivors in place; that cannot happen here).
"""

from __future__ import annotations

import hashlib
from typing import Iterable, Sequence

import numpy as np

from .errors import MalformedBodyError

EMPTY, RIGID, SOFT, H_ACT, V_ACT = 0, 1, 2, 3, 4
VOXEL_NAMES = ("empty", "rigid", "soft", "horizontal actuator", "vertical actuator")
N_VOXEL_TYPES = len(VOXEL_NAMES)
DEFAULT_SHAPE = (5, 5)

#: Evolution Gym's ``sample_robot`` weights: empty three times as likely as each other type.
EVOGYM_VOXEL_WEIGHTS = np.array([3, 1, 1, 1, 1], dtype=float) / 7.0


class Body:
    """An immutable (H, W) grid of voxel codes (0 empty, 1 rigid, 2 soft, 3/4 actuators)."""

    __slots__ = ("_voxels", "_hash")
    _voxels: np.ndarray
    _hash: str

    def __init__(self, voxels: Body | np.ndarray | Sequence[Sequence[int]]):
        if isinstance(voxels, Body):
            voxels = voxels._voxels
        try:
            raw = np.array(voxels)
        except (TypeError, ValueError) as exc:  # ragged nested lists
            raise MalformedBodyError(f"malformed body: {exc}") from None
        if raw.ndim != 2 or 0 in raw.shape:
            raise MalformedBodyError(f"malformed body: expected a non-empty 2-D grid, got shape {raw.shape}")
        if raw.dtype.kind not in "iub":
            if raw.dtype.kind != "f" or not np.all(np.isfinite(raw)) or not np.all(raw == np.round(raw)):
                raise MalformedBodyError(f"malformed body: voxel codes must be integers, got dtype {raw.dtype}")
        if raw.min() < 0 or raw.max() >= N_VOXEL_TYPES:
            bad = raw[(raw < 0) | (raw >= N_VOXEL_TYPES)].flat[0]
            raise MalformedBodyError(f"malformed body: voxel code {bad} is not one of 0-4")
        array = raw.astype(np.int8, copy=True)
        array.flags.writeable = False
        self._voxels = array
        digest = hashlib.blake2b(f"{array.shape[0]}x{array.shape[1]}:".encode() + array.tobytes(), digest_size=8)
        self._hash = digest.hexdigest()

    # -- value semantics -------------------------------------------------------------------
    @property
    def voxels(self) -> np.ndarray:
        """Read-only int8 view of the grid (copy it to edit)."""
        return self._voxels

    @property
    def shape(self) -> tuple[int, int]:
        return self._voxels.shape

    @property
    def hash(self) -> str:
        """Stable 16-hex-digit digest of shape and codes; identical across processes and runs."""
        return self._hash

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Body) and self._hash == other._hash and np.array_equal(self._voxels, other._voxels)

    def __hash__(self) -> int:
        return hash(self._hash)

    def __array__(self, dtype=None, copy=None) -> np.ndarray:
        out = self._voxels if dtype is None else self._voxels.astype(dtype)
        return out.copy() if copy else out

    def __reduce__(self):
        return (Body.from_text, (self.text,))

    def __repr__(self) -> str:
        return f"Body('{self.text}')"

    # -- text form -------------------------------------------------------------------------
    @property
    def text(self) -> str:
        """Rows top to bottom separated by '/', one digit per voxel, e.g. ``'44444/.../44444'``."""
        return "/".join("".join(map(str, row)) for row in self._voxels.tolist())

    @classmethod
    def from_text(cls, text: str) -> Body:
        """Parse the text form; rows may be separated by '/', ';' or newlines, spaces are ignored."""
        if not isinstance(text, str):
            raise MalformedBodyError(f"malformed body text: expected a string, got {type(text).__name__}")
        rows = [r.replace(" ", "").replace("\t", "") for r in text.replace(";", "/").replace("\n", "/").split("/")]
        rows = [r for r in rows if r]
        if not rows:
            raise MalformedBodyError(f"malformed body text {text!r}: no voxels")
        for row in rows:
            bad = next((ch for ch in row if ch not in "01234"), None)
            if bad is not None:
                raise MalformedBodyError(f"malformed body text {text!r}: '{bad}' is not a voxel code 0-4")
        widths = sorted({len(r) for r in rows})
        if len(widths) > 1:
            raise MalformedBodyError(f"malformed body text {text!r}: rows have different lengths {widths}")
        return cls(np.array([[int(ch) for ch in r] for r in rows], dtype=np.int8))

    # -- validity --------------------------------------------------------------------------
    def invalid_reason(self) -> str | None:
        """Why Evolution Gym would reject this body, or None if it is valid."""
        return invalid_reason(self._voxels)

    def is_valid(self) -> bool:
        """Whether Evolution Gym would accept this body (as :func:`gdabench.is_valid` says of an array)."""
        return invalid_reason(self._voxels) is None


def as_body(value: Body | np.ndarray | Sequence[Sequence[int]] | str) -> Body:
    """Coerce a body, array, nested list or text form to a :class:`Body`."""
    if isinstance(value, Body):
        return value
    if isinstance(value, str):
        return Body.from_text(value)
    return Body(value)


def _occupancy_bits(occupied: np.ndarray) -> tuple[int, int]:
    """Pack a boolean grid into an int, rows ``width + 1`` bits apart so shifts never wrap rows."""
    h, w = occupied.shape
    padded = np.zeros((h, w + 1), dtype=np.uint8)
    padded[:, :w] = occupied
    packed = np.packbits(padded.ravel(), bitorder="little").tobytes()
    return int.from_bytes(packed, "little"), w + 1


def is_connected(voxels: np.ndarray) -> bool:
    """True when the non-empty voxels form one 4-connected (edge-adjacent) component."""
    mask, stride = _occupancy_bits(np.asarray(voxels) != EMPTY)
    if mask == 0:
        return False
    reach = mask & -mask  # start from the lowest occupied voxel and flood-fill with bit shifts
    while True:
        grown = (reach | reach << 1 | reach >> 1 | reach << stride | reach >> stride) & mask
        if grown == reach:
            return reach == mask
        reach = grown


def has_actuator(voxels: np.ndarray) -> bool:
    arr = np.asarray(voxels)
    return bool(np.any((arr == H_ACT) | (arr == V_ACT)))


def invalid_reason(voxels: np.ndarray) -> str | None:
    """Evolution Gym's validity rule: at least one actuator and all voxels 4-connected."""
    if not has_actuator(voxels):
        return "no actuator"
    if not is_connected(voxels):
        return "voxels not connected"
    return None


def is_valid(voxels: Body | np.ndarray) -> bool:
    return invalid_reason(np.asarray(voxels)) is None


def random_body(
    rng: np.random.Generator,
    shape: tuple[int, int] = DEFAULT_SHAPE,
    weights: Sequence[float] | np.ndarray = EVOGYM_VOXEL_WEIGHTS,
    exclude: Iterable[str] | None = None,
    max_draws: int = 100_000,
) -> Body:
    """Evolution Gym's ``sample_robot``: draw every voxel from ``weights`` until the body is valid.

    ``exclude`` is a container of body hashes to avoid (the set of bodies seen so far).  Grids are
    drawn in growing batches and checked together (at 12x12 thousands of draws make one connected
    body), then the generator is left where drawing them one at a time stops, so every body and
    every later draw is the one-at-a-time sampler's.
    """
    p = np.asarray(weights, dtype=float)
    p = p / p.sum()
    drawn, batch = 0, 8
    while drawn < max_draws:
        n = min(batch, max_draws - drawn)
        state = rng.bit_generator.state
        grids = rng.choice(N_VOXEL_TYPES, size=(n, *shape), p=p).astype(np.int8)
        for i in np.flatnonzero(valid_mask(grids)):
            body = Body(grids[i])
            if exclude is None or body.hash not in exclude:
                rng.bit_generator.state = state
                rng.choice(N_VOXEL_TYPES, size=(int(i) + 1, *shape), p=p)  # consume exactly the grids up to this one
                return body
        drawn += n
        batch = min(2 * batch, 1024)
    raise MalformedBodyError(f"no new valid {shape[0]}x{shape[1]} body found in {max_draws} random draws")


def valid_mask(grids: np.ndarray) -> np.ndarray:
    """:func:`is_valid` for a stack of grids (n, H, W): grids without an actuator, or with an
    occupied voxel that has no occupied neighbour (most large random grids), are ruled out together;
    the few left are flood-filled one by one."""
    occupied = grids != EMPTY
    neighbours = np.zeros(occupied.shape, dtype=bool)
    neighbours[:, 1:] |= occupied[:, :-1]
    neighbours[:, :-1] |= occupied[:, 1:]
    neighbours[:, :, 1:] |= occupied[:, :, :-1]
    neighbours[:, :, :-1] |= occupied[:, :, 1:]
    isolated = np.any(occupied & ~neighbours, axis=(1, 2)) & (occupied.sum(axis=(1, 2)) > 1)
    ok = np.any((grids == H_ACT) | (grids == V_ACT), axis=(1, 2)) & ~isolated
    for i in np.flatnonzero(ok):
        ok[i] = is_connected(grids[i])
    return ok


def mutate(
    parent: Body,
    rng: np.random.Generator,
    rate: float = 0.1,
    attempts: int = 50,
    weights: Sequence[float] | np.ndarray = EVOGYM_VOXEL_WEIGHTS,
) -> Body | None:
    """Evolution Gym's ``mutate``: each voxel of a copy is redrawn from ``weights`` with
    probability ``rate``; the same copy is mutated again (up to ``attempts`` times) until it is
    valid.  Returns None when no attempt gave a valid body.  The child may equal the parent.
    """
    p = np.asarray(weights, dtype=float)
    p = p / p.sum()
    child = np.array(parent.voxels)
    for _ in range(attempts):
        mask = rng.random(child.shape) < rate
        n = int(mask.sum())
        if n:
            child[mask] = rng.choice(N_VOXEL_TYPES, size=n, p=p)
        if invalid_reason(child) is None:
            return Body(child)
    return None


#: how a body relates to its nearest parent (thesis section 4.5): a copy, a near-copy (what a mutation or a
#: noisy reconstruction makes), the same shape with other materials, or a novel shape
CATEGORIES = ("copy", "near-copy", "new materials", "novel shape")
#: a body this many voxels (or fewer) from a parent is a near-copy (Evolution Gym's GA mutates ~2.5 of 25)
NEAR_COPY = 3


def hamming(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(len(a), len(b)) matrix of the number of differing voxels between two stacks of bodies."""
    a, b = a.reshape(len(a), -1), b.reshape(len(b), -1)
    return (a[:, None, :] != b[None, :, :]).sum(axis=2)


def categorize(bodies: np.ndarray, parents: np.ndarray, near_copy: int = NEAR_COPY) -> tuple[np.ndarray, np.ndarray]:
    """Distance of each body to its nearest parent, and its category index in :data:`CATEGORIES`."""
    distance = hamming(bodies, parents).min(axis=1)
    same_shape = hamming(bodies != EMPTY, parents != EMPTY).min(axis=1) == 0
    category = np.select([distance == 0, distance <= near_copy, same_shape], [0, 1, 2], default=3)
    return distance, category


def parse_shape(text: str | Sequence[int]) -> tuple[int, int]:
    """Parse '5x5' (or a pair) into a shape tuple."""
    if isinstance(text, str):
        parts = text.lower().replace("*", "x").split("x")
        try:
            h, w = (int(p) for p in parts)
        except ValueError:
            raise MalformedBodyError(f"malformed shape {text!r}: expected HxW, e.g. 5x5") from None
    else:
        h, w = (int(v) for v in text)
    if h < 1 or w < 1:
        raise MalformedBodyError(f"malformed shape {text!r}: both sides must be at least 1")
    return h, w
