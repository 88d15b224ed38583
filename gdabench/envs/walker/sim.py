"""Soft-voxel simulation on pymunk: point masses joined by damped springs, on flat rigid terrain.

Every physical constant lives in :class:`WalkerPhysics` (docs/environments/walker.md explains
the choices).  :class:`VoxelSim` builds the pymunk space for one body, applies actuator
ratios as spring rest lengths, advances one environment step at a time and reports when the
simulation has become unstable instead of letting NaNs or tangled voxels through.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, fields, replace

import numpy as np
import pymunk
import pymunk.batch

from ...body import H_ACT, RIGID, SOFT, V_ACT
from ...errors import ConfigError
from .mesh import Mesh, SpringTable, build_mesh

#: the rest-length setter itself: assigning through the attribute passes pymunk's typing mixin's
#: ``__setattr__`` first, which made setting ~100 rest lengths per step 2.5 times slower
_SET_REST_LENGTH = pymunk.DampedSpring.rest_length.fset  # type: ignore[attr-defined]  # a property at run time


@dataclass(frozen=True)
class WalkerPhysics:
    """All physical constants of the walker simulation, in Evolution Gym's units.

    Evolution Gym's simulator works in its own units (voxels 0.1 long, 1 kg point masses,
    gravity 110, an environment step of 30 updates of 1e-4 s); these defaults use the same
    numbers, so positions, speeds, rewards and observations need no conversion.  Every spring
    there has a huge nominal constant, but each update first moves its rest length 0.6% of the
    way from its current length to its goal (``stiffness_scale``): it pulls like a spring of
    0.6% of that constant, and the stiff remainder only resists fast changes of length, which
    ``damping_time`` stands for.  The docs page ``environments/walker.md`` lists what was
    matched, what was fitted and what still differs.
    """

    voxel_size: float = 0.1
    #: simulated seconds per environment step (Evolution Gym: 30 updates of 1e-4 s), and pymunk steps within it
    step_seconds: float = 0.003
    substeps: int = 8
    #: pymunk solver iterations per substep (contacts, clamps and spring damping)
    iterations: int = 4
    gravity: float = 110.0
    #: every voxel corner is a point mass of this many kg (shared corners count once)
    point_mass: float = 1.0
    #: Evolution Gym's nominal constants (N/m) of an edge spring per material, and the diagonal's share
    rigid_edge_stiffness: float = 3e8 / 3.5
    actuator_edge_stiffness: float = 3e8 / 5
    soft_edge_stiffness: float = 3e8 / 6
    rigid_diagonal_fraction: float = 0.5
    actuator_diagonal_fraction: float = 0.5
    soft_diagonal_fraction: float = 0.25
    #: the share of a nominal constant a spring pulls with (Evolution Gym's convergence factor)
    stiffness_scale: float = 0.006
    #: damping (N s/m) of each spring per unit of its stiffness: the time a voxel takes to follow its actuator
    damping_time: float = 0.0045
    #: Evolution Gym's viscous drag on every point (N s/m)
    drag: float = 0.1
    #: ground friction, Evolution Gym's law: a point touching the terrain slides against a force
    #: proportional to its speed and its normal load, F = -ground_friction * N * v (s/m).  There
    #: a point in contact feels 1,200 v while it is pushed out with at least 10,500 N, so over
    #: time it gets 1200 / 10500 = 0.114 per newton of load.
    ground_friction: float = 0.114
    #: collision radius of a point mass (m); points collide with the terrain and each other
    point_radius: float = 0.045
    #: driven edges stay within this strain of their length (rigid voxels' edges, held within 3% there,
    #: are fixed distances here)
    max_strain: float = 0.25
    #: instability: any point faster than this (m/s) ...
    max_speed: float = 100.0
    #: ... or any voxel whose area falls below this fraction of its rest area (inverted or crushed) ...
    min_area_ratio: float = 0.1
    #: ... or any spring longer than this multiple of its unactuated length; and, as in Evolution
    #: Gym, more pairs of overlapping non-neighbouring surface voxels than there are surface voxels
    max_stretch: float = 2.5

    def with_overrides(self, items: list[str]) -> WalkerPhysics:
        """A copy with fields changed by ``KEY=VALUE`` strings (values in JSON), for scripts."""
        known = {f.name for f in fields(self)}
        changes = {}
        for item in items:
            key, _, value = item.partition("=")
            if key not in known:
                raise ConfigError(f"unknown physics parameter {key!r}; known: {', '.join(sorted(known))}")
            try:
                changes[key] = json.loads(value)
            except json.JSONDecodeError:
                raise ConfigError(f"physics parameter {key}: {value!r} is not a number") from None
        return replace(self, **changes)

    def tables(self) -> dict[int, SpringTable]:
        """Effective spring constants of every voxel type."""
        s = self.stiffness_scale

        def table(k: float, diagonal_fraction: float) -> SpringTable:
            return SpringTable(k * s, k * diagonal_fraction * s)

        act = table(self.actuator_edge_stiffness, self.actuator_diagonal_fraction)
        return {
            RIGID: table(self.rigid_edge_stiffness, self.rigid_diagonal_fraction),
            SOFT: table(self.soft_edge_stiffness, self.soft_diagonal_fraction),
            H_ACT: act,
            V_ACT: act,
        }


@dataclass(frozen=True)
class Terrain:
    """Flat rigid terrain from ``x_start`` to ``x_end`` with its surface at ``top``, and an
    endless floor at ``floor`` (Evolution Gym also collides everything with the plane y = 0)."""

    x_start: float
    x_end: float
    top: float
    floor: float

    def surface(self, x: np.ndarray) -> np.ndarray:
        """Height of the ground under each x."""
        return np.where((x > self.x_start) & (x < self.x_end), self.top, self.floor)


class VoxelSim:
    """One body on flat terrain.  ``positions``/``velocities`` are (n_points, 2) arrays."""

    def __init__(
        self,
        voxels: np.ndarray,
        physics: WalkerPhysics,
        *,
        origin: tuple[float, float],
        terrain: Terrain,
    ):
        """``origin`` is where the lower-left corner of the body's grid starts."""
        self.physics = physics
        self.mesh: Mesh = build_mesh(voxels, physics.tables(), voxel_size=physics.voxel_size, origin=origin)
        self.terrain = terrain
        self._build_space()
        self._buffer = pymunk.batch.Buffer()
        self._rows = self._batch_rows()
        self._contacts = pymunk.batch.Buffer()
        self._contact_fields = (
            pymunk.batch.ArbiterFields.BODY_A_ID
            | pymunk.batch.ArbiterFields.BODY_B_ID
            | pymunk.batch.ArbiterFields.TOTAL_IMPULSE
        )
        self._velocity_buffer = pymunk.batch.Buffer()
        self._fields = pymunk.batch.BodyFields.POSITION | pymunk.batch.BodyFields.VELOCITY
        self._read_state()
        m = self.mesh
        self._min_area = physics.min_area_ratio * physics.voxel_size**2
        self._max_length_sq = (physics.max_stretch * m.spring_base) ** 2
        self._ends_a, self._ends_b = m.spring_ends[:, 0], m.spring_ends[:, 1]
        self._tl, self._tr, self._br, self._bl = m.voxel_corners.T
        self._driven_springs = [self._springs[i] for i in m.driven]
        self._pair_a, self._pair_b = _distant_surface_pairs(m)
        self._max_overlaps = int(m.surface.sum())

    # -- construction --------------------------------------------------------------------------
    def _build_space(self) -> None:
        p, m = self.physics, self.mesh
        space = pymunk.Space()
        space.gravity = (0.0, -p.gravity)
        space.iterations = p.iterations
        space.damping = math.exp(-p.drag / p.point_mass)  # linear drag on every point, as velocity kept per second
        # pymunk's defaults assume pixel units; allow only a millimetre of overlap here
        space.collision_slop = 0.001
        self.space = space
        self._bodies = []
        for x, y in m.points:
            body = pymunk.Body(p.point_mass, math.inf)  # points do not rotate
            body.position = (float(x), float(y))
            shape = pymunk.Circle(body, p.point_radius)
            shape.friction = 0.0  # friction with the ground is applied by _ground_friction
            shape.elasticity = 0.0
            space.add(body, shape)
            self._bodies.append(body)
        self._springs: list[pymunk.Constraint] = []
        driven = set(m.driven.tolist())
        for s, ((a, b), rest, k) in enumerate(zip(m.spring_ends, m.spring_base, m.stiffness)):
            body_a, body_b = self._bodies[a], self._bodies[b]
            if m.rigid_edge[s]:  # Evolution Gym holds it within 3%: a fixed distance here
                joint = pymunk.PinJoint(body_a, body_b)
                self._springs.append(joint)
                joint.collide_bodies = False
                space.add(joint)
                continue
            spring = pymunk.DampedSpring(
                body_a, body_b, (0, 0), (0, 0), float(rest), float(k), float(k * p.damping_time)
            )
            spring.collide_bodies = False
            space.add(spring)
            self._springs.append(spring)
            if s in driven:  # an actuator can pull it far: clamp it as Evolution Gym does
                r = float(rest)
                clamp = pymunk.SlideJoint(
                    body_a, body_b, (0, 0), (0, 0), r * (1 - p.max_strain), r * (1 + p.max_strain)
                )
                clamp.collide_bodies = False
                space.add(clamp)
        self._separate_coincident_points()
        # the terrain block and the endless floor: their tops lie one point radius below the
        # surfaces, so resting point masses sit exactly on them; being a metre thick keeps fast
        # points from tunnelling through
        t, r = self.terrain, p.point_radius
        for box in (
            pymunk.BB(t.x_start, t.top - 1.0, t.x_end, t.top - r),
            pymunk.BB(-1e4, t.floor - 1.0, 1e4, t.floor - r),
        ):
            ground = pymunk.Poly.create_box_bb(space.static_body, box)
            ground.friction = 0.0
            space.add(ground)

    def _separate_coincident_points(self) -> None:
        """Voxels touching only at a corner have two points there: stop those colliding."""
        pts = self.mesh.points
        order = np.lexsort((pts[:, 1], pts[:, 0]))
        for a, b in zip(order[:-1], order[1:]):
            if np.allclose(pts[a], pts[b]):
                link = pymunk.DampedSpring(self._bodies[a], self._bodies[b], (0, 0), (0, 0), 0.0, 0.0, 0.0)
                link.collide_bodies = False  # a force-free constraint whose only job is this flag
                self.space.add(link)

    # -- stepping ------------------------------------------------------------------------------
    def set_ratios(self, ratios: np.ndarray) -> None:
        """Target length ratio of every actuator (action order); rest lengths change at once."""
        rest = self.mesh.rest_lengths(ratios)
        for spring, length in zip(self._driven_springs, rest.tolist()):
            _SET_REST_LENGTH(spring, length)

    def step(self) -> None:
        """Advance one environment step."""
        dt = self.physics.step_seconds / self.physics.substeps
        for _ in range(self.physics.substeps):
            self.space.step(dt)
            self._ground_friction()
        self._read_state()

    def _ground_friction(self) -> None:
        """Slow the tangential velocity of every point that touched the ground in the last substep.

        Friction F = -c N v over a substep whose normal impulse was J = N dt multiplies the
        tangential velocity by exp(-c J / m): exact for the viscous law, and never unstable.
        """
        buffer = self._contacts
        buffer.clear()
        pymunk.batch.get_space_arbiters(self.space, self._contact_fields, buffer)
        ids = np.frombuffer(buffer.int_buf(), dtype=np.uintp).reshape(-1, 2)
        on_ground = ids == self._static_id
        touching = on_ground.any(axis=1)
        if not touching.any():
            return
        impulse = np.frombuffer(buffer.float_buf(), dtype=np.float64).reshape(-1, 2)[touching]
        point_id = np.where(on_ground[touching, 0], ids[touching, 1], ids[touching, 0])
        rows = self._row_of_id[np.searchsorted(self._sorted_ids, point_id)]
        j = np.sqrt(np.einsum("ij,ij->i", impulse, impulse))
        tangent = np.stack([-impulse[:, 1], impulse[:, 0]], axis=1) / np.maximum(j, 1e-300)[:, None]
        self._buffer.clear()
        pymunk.batch.get_space_bodies(self.space, pymunk.batch.BodyFields.VELOCITY, self._buffer)
        velocity = np.frombuffer(self._buffer.float_buf(), dtype=np.float64).reshape(-1, 2).copy()
        v = velocity[rows]
        slide = np.einsum("ij,ij->i", v, tangent) * -np.expm1(
            -self.physics.ground_friction * j / self.physics.point_mass
        )
        velocity[rows] = v - slide[:, None] * tangent
        self._velocity_buffer.set_float_buf(velocity.reshape(-1))
        pymunk.batch.set_space_bodies(self.space, pymunk.batch.BodyFields.VELOCITY, self._velocity_buffer)

    def _batch_rows(self) -> np.ndarray:
        """Where each point's body appears in pymunk's batch output (it also lists static bodies)."""
        self._buffer.clear()
        pymunk.batch.get_space_bodies(self.space, pymunk.batch.BodyFields.BODY_ID, self._buffer)
        ids = list(memoryview(self._buffer.int_buf()).cast("P"))
        row_of = {body_id: row for row, body_id in enumerate(ids)}
        self._static_id = self.space.static_body.id
        order = np.argsort(np.array(ids, dtype=np.uintp))
        self._sorted_ids = np.array(ids, dtype=np.uintp)[order]
        self._row_of_id = order  # the batch row of the body whose id is _sorted_ids[k]
        return np.array([row_of[body.id] for body in self._bodies], dtype=np.intp)

    def _read_state(self) -> None:
        """Copy every point's position and velocity out of pymunk in one call."""
        self._buffer.clear()
        pymunk.batch.get_space_bodies(self.space, self._fields, self._buffer)
        self._state = np.frombuffer(self._buffer.float_buf(), dtype=np.float64).reshape(-1, 4)[self._rows]
        self.positions = self._state[:, :2]
        self.velocities = self._state[:, 2:]

    # -- checks --------------------------------------------------------------------------------
    def self_overlaps(self) -> int:
        """Evolution Gym's self-collision count: ordered pairs of surface voxels, not neighbours in
        the body grid, whose bounding boxes touch or overlap."""
        if not len(self._pair_a):
            return 0
        quads = self.positions[self.mesh.voxel_corners]
        low, high = quads.min(axis=1), quads.max(axis=1)
        a, b = self._pair_a, self._pair_b
        apart = (low[a] > high[b]) | (low[b] > high[a])
        return 2 * int((~apart.any(axis=1)).sum())

    def instability(self) -> str | None:
        """Why the current state is not a trustworthy simulation any more, or None."""
        p, pos, vel = self.physics, self.positions, self.velocities
        if not np.isfinite(self._state).all():
            return "non-finite state"
        if np.einsum("ij,ij->i", vel, vel).max() > p.max_speed**2:
            return "a point moves faster than max_speed"
        if self.self_overlaps() > self._max_overlaps:
            return "the body overlaps itself (Evolution Gym's self-collision count)"
        # area of a quadrilateral: half the cross product of its diagonals, signed so that an
        # upright voxel (corners TL, TR, BR, BL run clockwise) is positive and a flipped one negative
        diag1, diag2 = pos[self._br] - pos[self._tl], pos[self._bl] - pos[self._tr]
        area = 0.5 * (diag1[:, 1] * diag2[:, 0] - diag1[:, 0] * diag2[:, 1])
        if area.min() < self._min_area:
            return "a voxel collapsed or turned inside out"
        d = pos[self._ends_a] - pos[self._ends_b]
        if (np.einsum("ij,ij->i", d, d) > self._max_length_sq).any():
            return "a spring stretched beyond max_stretch"
        if (pos[:, 1] < self.terrain.surface(pos[:, 0]) - 0.5 * p.voxel_size).any():
            return "a point went through the terrain"
        return None


def _distant_surface_pairs(mesh: Mesh) -> tuple[np.ndarray, np.ndarray]:
    """Pairs (a < b) of surface voxels more than one cell apart in the body grid."""
    index = np.flatnonzero(mesh.surface)
    a, b = np.triu_indices(len(index), k=1)
    a, b = index[a], index[b]
    cells = mesh.voxel_cells
    distant = np.abs(cells[a] - cells[b]).max(axis=1) > 1
    return a[distant], b[distant]
