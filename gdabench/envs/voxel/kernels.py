"""The physics of one environment step, for many environments at once (Numba, one thread per environment).

Each function mirrors a routine of Evolution Gym 2.0's ``PhysicsEngine.cpp`` and keeps its order of
floating-point operations wherever that order can change a result (sums of spring forces over edges
in edge order, every RK4 stage, the contact force terms), so that trajectories agree with Evolution
Gym's to rounding.  Every loop runs over one body's own counts, never over the padding, so a body's
trajectory is bit-identical alone, in any batch, padded to any shape and on any number of threads.

Arrays: ``pos``/``vel``/``vtrue`` are ``(N, P, 2)`` (every point that can move: the world's moving
objects', then the robot's; objects of fixed voxels only are one static collider with its own tables);
body tables are indexed by ``body[i]`` and padded to the batch's largest body.  The kernels know no task:
they step the physics and report instability, nothing else.
"""

from __future__ import annotations

import math

import numba
import numpy as np

DT = 0.0001
SUBSTEPS = 30
DRAG = 0.1
GRAVITY = 110.0
K_GROUND = 2000000.0 * 7
K_OBJECT = 300000.0 * 7
CONTACT_DAMPING = 140.0
CONTACT_ADDITIVE = 0.005
DYNAMIC_FRICTION = 0.2
FRICTION = 150.0 * 8
CONVERGENCE = 0.006
BAND = 0.25
BAND_RIGID = 0.03
PARALLEL_TOL = 0.0001

_jit = numba.njit(cache=True, error_model="numpy", boundscheck=False)
#: small functions of the innermost loops, inlined by Numba: a call passing a dozen arrays costs more than they do
_inline = numba.njit(cache=True, error_model="numpy", boundscheck=False, inline="always")

#: which two edges (of top, right, bottom, left) meet at each corner (top-left, top-right, bottom-right, bottom-left)
CORNER_EDGES = np.array([[0, 3], [0, 1], [2, 1], [2, 3]], dtype=np.int64)


@_inline
def _intersecting(pa, ea, pb, eb, ia, ib):
    """``PhysicsEngine::get_intersecting``: do segment ``ia`` (points ``pa``) and ``ib`` (``pb``) cross?"""
    a1x = pa[ea[ia, 0], 0]
    a1y = pa[ea[ia, 0], 1]
    d1x = pa[ea[ia, 1], 0] - a1x
    d1y = pa[ea[ia, 1], 1] - a1y
    a2x = pb[eb[ib, 0], 0]
    a2y = pb[eb[ib, 0], 1]
    d2x = pb[eb[ib, 1], 0] - a2x
    d2y = pb[eb[ib, 1], 1] - a2y
    det = -d1x * d2y + d2x * d1y
    if abs(det) < PARALLEL_TOL:
        return False
    xd = a2x - a1x
    yd = a2y - a1y
    t = (-d2y * xd + d2x * yd) / det
    s = (-d1y * xd + d1x * yd) / det
    return 0.0 <= t and t <= 1.0 and 0.0 <= s and s <= 1.0


@_inline
def _dist_point_edge(px, py, pe, ee, ie):
    ax = pe[ee[ie, 0], 0]
    ay = pe[ee[ie, 0], 1]
    bx = pe[ee[ie, 1], 0] - ax
    by = pe[ee[ie, 1], 1] - ay
    base = math.sqrt(bx * bx + by * by)
    if base < 0.000001:
        return 1000.0
    sx = px - ax
    sy = py - ay
    return abs(bx * sy - sx * by) / base


@_jit
def _inside(px, py, x0, y0, x1, y1, x2, y2, x3, y3, lox, loy, hix, hiy):
    """``Boxel::point_in_boxel`` for corners top-left (x0, y0), top-right, bottom-right, bottom-left.

    Its test passes a point in either triangle (tl, tr, br) or (tl, bl, br), and any point on the
    line through br and tl (``c == 0``).  (lox, loy, hix, hiy) is the boxel's bounding box: a point
    outside it can only pass through that line, which is all that is computed then (same answers).
    Scalars only: a call passing arrays costs reference counting in the innermost loop.
    """
    tlx = x0 - px
    tly = y0 - py
    brx = x2 - px
    bry = y2 - py
    c = brx * tly - bry * tlx
    if px < lox or px > hix or py < loy or py > hiy:
        return c == 0.0
    trx = x1 - px
    try_ = y1 - py
    blx = x3 - px
    bly = y3 - py
    a = tlx * try_ - tly * trx
    b = trx * bry - try_ * brx
    if c * a >= 0.0 and c * b >= 0.0:
        return True
    d = tlx * bly - tly * blx
    e = blx * bry - bly * brx
    return c * d >= 0.0 and c * e >= 0.0


@_jit
def _corners(pos, points, r):
    """The corners (x, y) of boxel ``r``: top-left, top-right, bottom-right, bottom-left."""
    return (pos[points[r, 0], 0], pos[points[r, 0], 1], pos[points[r, 1], 0], pos[points[r, 1], 1],
            pos[points[r, 2], 0], pos[points[r, 2], 1], pos[points[r, 3], 0], pos[points[r, 3], 1])


@_jit
def _resolve_point(p, main_edges, m, corner, pm, em, vm, fm, apply_m, ref_edges, r, pr, er, surf_r, vr, fr, apply_r,
                   times):
    """``PhysicsEngine::resolve_point_boxel_collisions``: push point ``p`` of a boxel out of another.

    ``p`` is corner ``corner`` of boxel ``m`` (its edges: ``main_edges[m]``) and lies in boxel ``r``.
    ``pm``/``em``/``vm``/``fm``: the main object's positions, edge ends, true velocities and collision
    forces; ``pr``/``er``/``vr``/``fr`` the reference boxel's object's.  ``apply_*`` is False for the
    terrain, whose points never move.  The forces are added ``times`` times (Evolution Gym meets a
    pair of one object twice).
    """
    px = pm[p, 0]
    py = pm[p, 1]
    e1 = main_edges[m, CORNER_EDGES[corner, 0]]
    e2 = main_edges[m, CORNER_EDGES[corner, 1]]
    best = -1
    best_d = 0.0
    for k in range(4):
        e = ref_edges[r, k]
        if not surf_r[e]:
            continue
        if _intersecting(pm, em, pr, er, e1, e) or _intersecting(pm, em, pr, er, e2, e):
            d = _dist_point_edge(px, py, pr, er, e)
            if best < 0 or d < best_d:
                best = e
                best_d = d
    if best < 0:
        return
    a = er[best, 0]
    b = er[best, 1]
    sx = pr[b, 0] - pr[a, 0]
    sy = pr[b, 1] - pr[a, 1]
    nx = -sy
    ny = sx
    z = math.sqrt(nx * nx + ny * ny)
    nx = nx / z
    ny = ny / z
    nfx = nx * K_OBJECT * (CONTACT_ADDITIVE + best_d)
    nfy = ny * K_OBJECT * (CONTACT_ADDITIVE + best_d)
    z = math.sqrt(nx * nx + ny * ny)
    ux = nx / z
    uy = ny / z
    dp = ux * vm[p, 0] + uy * vm[p, 1]
    da = ux * vr[a, 0] + uy * vr[a, 1]
    db = ux * vr[b, 0] + uy * vr[b, 1]
    v1x = ux * -1.0 * dp * CONTACT_DAMPING
    v1y = uy * -1.0 * dp * CONTACT_DAMPING
    v2x = ux * 1.0 * da * CONTACT_DAMPING
    v2y = uy * 1.0 * da * CONTACT_DAMPING
    v3x = ux * 1.0 * db * CONTACT_DAMPING
    v3y = uy * 1.0 * db * CONTACT_DAMPING
    tx = -uy
    ty = ux
    proj = tx * vm[p, 0] + ty * vm[p, 1]
    mag = math.sqrt(nfx * nfx + nfy * nfy)
    if proj < 0:
        proj *= -1
        tx *= -1
        ty *= -1
    th = math.tanh(proj / (DYNAMIC_FRICTION * mag))
    ffx = FRICTION * tx * -1.0 * DYNAMIC_FRICTION * mag * th
    ffy = FRICTION * ty * -1.0 * DYNAMIC_FRICTION * mag * th
    for _ in range(times):
        if apply_m:
            fm[p, 0] += nfx + v1x
            fm[p, 1] += nfy + v1y
        if apply_r:
            fr[a, 0] -= nfx / 2 + v2x / 2
            fr[a, 1] -= nfy / 2 + v2y / 2
            fr[b, 0] -= nfx / 2 + v3x / 2
            fr[b, 1] -= nfy / 2 + v3y / 2
        if apply_m:
            fm[p, 0] += ffx
            fm[p, 1] += ffy
        if apply_r:
            fr[a, 0] -= ffx / 2
            fr[a, 1] -= ffy / 2
            fr[b, 0] -= ffx / 2
            fr[b, 1] -= ffy / 2


@_jit
def _slope(xp, xv, ne, ea, rest, k, cforce, n, skip, fe, inc, start, n_a, out_a):
    """``PhysicsEngine::get_pos_vel_slope``: accelerations of the points (mass 1) at one RK4 stage, but of those
    in ``skip``, from the springs of the first ``ne`` edges (every edge of a point not skipped)."""
    for j in range(ne):
        a = ea[j, 0]
        b = ea[j, 1]
        dx = xp[a, 0] - xp[b, 0]
        dy = xp[a, 1] - xp[b, 1]
        dist = math.sqrt(dx * dx + dy * dy)
        mag = (dist - rest[j]) * k[j] / dist
        fe[j, 0] = dx * mag
        fe[j, 1] = dy * mag
    _accelerations(xp, xv, cforce, n, skip, fe, inc, start, n_a, out_a)


@_jit
def _accelerations(xp, xv, cforce, n, skip, fe, inc, start, n_a, out_a):
    """The second half of :func:`_slope`, from the springs' forces ``fe``.

    Spring forces are gathered per point from ``inc`` (its edges where it is end ``a``, then where it
    is end ``b``, each in edge order): the same additions in the same order as Evolution Gym's scatter
    over all ``a`` ends, then all ``b`` ends.  Points in ``skip`` are left as they are.
    """
    for i in range(n):
        if skip[i]:
            continue
        fx = 0.0
        fy = 0.0
        first_b = start[i] + n_a[i]
        for m in range(start[i], first_b):
            fx -= fe[inc[m], 0]
            fy -= fe[inc[m], 1]
        for m in range(first_b, start[i + 1]):
            fx += fe[inc[m], 0]
            fy += fe[inc[m], 1]
        fx = fx + xv[i, 0] * -DRAG
        fy = fy + xv[i, 1] * -DRAG
        fy = fy + 1.0 * -GRAVITY
        fx = fx + cforce[i, 0]
        fy = fy + cforce[i, 1]
        y = xp[i, 1]
        if y < 0:
            normal = y * -K_GROUND
            fy = fy + normal
            fx = fx + (-10 * DYNAMIC_FRICTION) * (normal * math.tanh(xv[i, 0] * normal * DYNAMIC_FRICTION))
        out_a[i, 0] = fx / 1.0
        out_a[i, 1] = fy / 1.0


@_jit
def _substep(n, ne, ea, rest0, k, esurf, fixed, goal, ns, sown, sbp, sbe, pairs, ng, gstart, ngp, gpairs, nr, rig, inc,
             start, n_a, live, far, terrain, pos, vel, vt, s):
    """``Environment::step``: one physics update of dt 1e-4.  Returns the count of overlapping
    non-adjacent surface boxel pairs of the robot (ordered, as Evolution Gym counts them) seen at its start.

    Only the accelerations that can reach a moving point are computed (see :func:`engine._live`): the moving
    points' in RK4's four stages, the pinned points' sharing a spring with one (not ``far``) in the first two;
    edges come ordered so that those touching a moving point (``live[0]``), then a near one (``live[1]``), lead.
    """
    ne_move, ne_near = live[0], live[1]
    tpos, tedge, tsurf, tbp, tbe, tbb, town, tlink, tbin_start, tbin_boxel, trows, tzero = terrain
    cf, boxes, rest, fe, x0, v0, xs, vs, acc, sp, sv, corr = s
    bb = boxes[0]
    gb = boxes[1]
    # collisions, from the positions and true velocities at the start of the update
    for q in range(ns):
        for c in range(2):
            lo = pos[sbp[q, 0], c]
            hi = lo
            for m in range(1, 4):
                v = pos[sbp[q, m], c]
                lo = min(lo, v)
                hi = max(hi, v)
            bb[q, c] = lo
            bb[q, 2 + c] = hi
    for g in range(ng):  # each group's box: the union of its boxels'
        for c in range(4):
            gb[g, c] = bb[gstart[g], c]
        for q in range(gstart[g] + 1, gstart[g + 1]):
            for c in range(2):
                gb[g, c] = min(gb[g, c], bb[q, c])
                gb[g, 2 + c] = max(gb[g, 2 + c], bb[q, 2 + c])
    for i in range(n):
        cf[i, 0] = 0.0
        cf[i, 1] = 0.0
    count = 0
    for h in range(ngp):
        g1 = gpairs[h, 0]
        g2 = gpairs[h, 1]
        if g1 != g2 and (gb[g1, 0] > gb[g2, 2] or gb[g1, 2] < gb[g2, 0] or gb[g1, 1] > gb[g2, 3]
                         or gb[g1, 3] < gb[g2, 1]):
            continue  # no boxel of one group can touch one of the other
        for q in range(gpairs[h, 2], gpairs[h, 3]):
            i = pairs[q, 0]
            j = pairs[q, 1]
            if bb[i, 0] > bb[j, 2] or bb[i, 2] < bb[j, 0] or bb[i, 1] > bb[j, 3] or bb[i, 3] < bb[j, 1]:
                continue  # BoundingBox::in: the boxes neither overlap nor touch
            kind = pairs[q, 2]
            if kind == 0:  # two of the robot's boxels, not grid neighbours
                count += 2
            # PhysicsEngine::resolve_boxel_collisions both ways: every tested corner of one boxel inside the other
            # is pushed out; the bounding-box tree meets a pair of one object twice, as (i, j) and (j, i)
            # (written out here: as a function, even one Numba inlines, it runs at half the speed)
            times = 1 if kind == 3 else 2
            for d in range(2):
                m, r = (i, j) if d == 0 else (j, i)
                mask = pairs[q, 3 + d]
                cx0, cy0, cx1, cy1, cx2, cy2, cx3, cy3 = _corners(pos, sbp, r)
                for corner in range(4):
                    p = sbp[m, corner]
                    if (mask >> corner) & 1 and _inside(pos[p, 0], pos[p, 1], cx0, cy0, cx1, cy1, cx2, cy2, cx3, cy3,
                                                   bb[r, 0], bb[r, 1], bb[r, 2], bb[r, 3]):
                        _resolve_point(p, sbe, m, corner, pos, ea, vt, cf, True, sbe, r, pos, ea, esurf, vt, cf, True,
                                       times)
    nrow = trows[0]
    ncol = (tbin_start.shape[0] - 1) // nrow
    for q in range(ns):
        if math.isnan(bb[q, 0]) or math.isnan(bb[q, 2]) or math.isnan(bb[q, 1]) or math.isnan(bb[q, 3]):
            continue
        c0 = max(int(math.floor(bb[q, 0] / 0.1)) - 1, 0)
        c1 = min(int(math.floor(bb[q, 2] / 0.1)) + 1, ncol - 1)
        r0 = max(int(math.floor(bb[q, 1] / 0.1)) - 1, 0)
        r1 = min(int(math.floor(bb[q, 3] / 0.1)) + 1, nrow - 1)
        if r1 < r0:
            continue
        for c in range(c0, c1 + 1):  # the static boxels whose corner's cell is near: (column, row) bins
            for m in range(tbin_start[c * nrow + r0], tbin_start[c * nrow + r1 + 1]):
                t = tbin_boxel[m]
                if bb[q, 0] > tbb[t, 2] or bb[q, 2] < tbb[t, 0] or bb[q, 1] > tbb[t, 3] or bb[q, 3] < tbb[t, 1]:
                    continue  # BoundingBox::in: the boxes neither overlap nor touch
                # the moving boxel's corners inside the static one, then the static one's inside the moving one
                own = town[t] == sown[q]  # a static part of the moving boxel's own object: met twice, and corners
                times = 2 if own else 1  # the two share are no contact
                cx0, cy0, cx1, cy1, cx2, cy2, cx3, cy3 = _corners(tpos, tbp, t)
                for corner in range(4):
                    p = sbp[q, corner]
                    if own and (p == tlink[t, 0] or p == tlink[t, 1] or p == tlink[t, 2] or p == tlink[t, 3]):
                        continue
                    if _inside(pos[p, 0], pos[p, 1], cx0, cy0, cx1, cy1, cx2, cy2, cx3, cy3,
                               tbb[t, 0], tbb[t, 1], tbb[t, 2], tbb[t, 3]):
                        _resolve_point(p, sbe, q, corner, pos, ea, vt, cf, True, tbe, t, tpos, tedge, tsurf, tzero,
                                       tzero, False, times)
                cx0, cy0, cx1, cy1, cx2, cy2, cx3, cy3 = _corners(pos, sbp, q)
                for corner in range(4):
                    p = tbp[t, corner]
                    link = tlink[t, corner]
                    if own and link >= 0 and (link == sbp[q, 0] or link == sbp[q, 1] or link == sbp[q, 2]
                                              or link == sbp[q, 3]):
                        continue
                    if _inside(tpos[p, 0], tpos[p, 1], cx0, cy0, cx1, cy1, cx2, cy2, cx3, cy3,
                               bb[q, 0], bb[q, 1], bb[q, 2], bb[q, 3]):
                        _resolve_point(p, tbe, t, corner, tpos, tedge, tzero, tzero, False, sbe, q, pos, ea, esurf, vt,
                                       cf, True, times)
    # rest lengths re-anchored towards their goals; the lengths they are measured from are those of
    # RK4's first stage (its positions are these), so that stage's spring forces are computed here too
    for j in range(ne_near):
        dx = pos[ea[j, 0], 0] - pos[ea[j, 1], 0]
        dy = pos[ea[j, 0], 1] - pos[ea[j, 1], 1]
        dist = math.sqrt(dx * dx + dy * dy)
        rest[j] = dist + (goal[j] - dist) * CONVERGENCE
        mag = (dist - rest[j]) * k[j] / dist
        fe[j, 0] = dx * mag
        fe[j, 1] = dy * mag
    # RK4 with the collision forces held
    for i in range(n):
        x0[i, 0] = pos[i, 0]
        x0[i, 1] = pos[i, 1]
        v0[i, 0] = vel[i, 0]
        v0[i, 1] = vel[i, 1]
    _accelerations(x0, v0, cf, n, far, fe, inc, start, n_a, acc)
    for i in range(n):
        for c in range(2):
            kp = v0[i, c] * DT
            kv = acc[i, c] * DT
            sp[i, c] = kp
            sv[i, c] = kv
            xs[i, c] = x0[i, c] + kp * 0.5
            vs[i, c] = v0[i, c] + kv * 0.5
    for step in (0.5, 1.0):  # k2 and k3: the next stage starts half a step, then a whole step, ahead
        if step == 0.5:
            _slope(xs, vs, ne_near, ea, rest, k, cf, n, far, fe, inc, start, n_a, acc)
        else:
            _slope(xs, vs, ne_move, ea, rest, k, cf, n, fixed, fe, inc, start, n_a, acc)
        for i in range(n):
            for c in range(2):
                kp = vs[i, c] * DT
                kv = acc[i, c] * DT
                sp[i, c] = sp[i, c] + 2 * kp
                sv[i, c] = sv[i, c] + 2 * kv
                xs[i, c] = x0[i, c] + kp * step
                vs[i, c] = v0[i, c] + kv * step
    _slope(xs, vs, ne_move, ea, rest, k, cf, n, fixed, fe, inc, start, n_a, acc)
    for i in range(n):
        if fixed[i]:  # pinned: moved through RK4's stages like any point, but its update is zeroed
            continue
        for c in range(2):
            pos[i, c] = x0[i, c] + (sp[i, c] + vs[i, c] * DT) / 6
            vel[i, c] = v0[i, c] + (sv[i, c] + acc[i, c] * DT) / 6
    # edge clamps: every edge within 25% of its length (all at once), then rigid cells' edges within 3% (in turn);
    # an edge between two pinned points moves neither
    for j in range(ne_move):
        dx = pos[ea[j, 0], 0] - pos[ea[j, 1], 0]
        dy = pos[ea[j, 0], 1] - pos[ea[j, 1], 1]
        dist = math.sqrt(dx * dx + dy * dy)
        stress = dist / rest0[j]
        ox = oy = ux = uy = 0.0
        if stress > 1 + BAND:  # the corrections only where they apply (most edges are within the band)
            over = (dist - rest0[j] * (1 + BAND)) / (dist * 2)
            ox = dx * over
            oy = dy * over
        if stress < 1 - BAND:
            under = (dist - rest0[j] * (1 - BAND)) / (dist * 2)
            ux = dx * under
            uy = dy * under
        corr[j, 0] = (ox + ux) * 0.8
        corr[j, 1] = (oy + uy) * 0.8
    for j in range(ne_move):  # (fixed points are not moved here; the rigid pass below does not ask, as Evolution Gym)
        if not fixed[ea[j, 0]]:
            pos[ea[j, 0], 0] -= corr[j, 0]
            pos[ea[j, 0], 1] -= corr[j, 1]
    for j in range(ne_move):
        if not fixed[ea[j, 1]]:
            pos[ea[j, 1], 0] += corr[j, 0]
            pos[ea[j, 1], 1] += corr[j, 1]
    for r in range(nr):
        for m in range(4):
            j = rig[r, m]
            a = ea[j, 0]
            b = ea[j, 1]
            dx = pos[a, 0] - pos[b, 0]
            dy = pos[a, 1] - pos[b, 1]
            dist = math.sqrt(dx * dx + dy * dy)
            stress = dist / rest0[j]
            ox = oy = ux = uy = 0.0
            if not stress < 1 + BAND_RIGID:  # (as Evolution Gym: a NaN stress keeps both)
                over = (dist - rest0[j] * (1 + BAND_RIGID)) / (dist * 2)
                ox = dx * over
                oy = dy * over
            if not stress > 1 - BAND_RIGID:
                under = (dist - rest0[j] * (1 - BAND_RIGID)) / (dist * 2)
                ux = dx * under
                uy = dy * under
            pos[a, 0] -= (ox + ux) * 0.5
            pos[a, 1] -= (oy + uy) * 0.5
            pos[b, 0] += (ox + ux) * 0.5
            pos[b, 1] += (oy + uy) * 0.5
    for i in range(n):
        vt[i, 0] = (pos[i, 0] - x0[i, 0]) / DT
        vt[i, 1] = (pos[i, 1] - x0[i, 1]) / DT
    return count


@_jit
def step_env(b, actions, pos, vel, vt, body, terrain, wp, we, ws, wb):
    """One env step (30 updates) of one environment of body ``b``, in place; returns whether it became unstable.

    ``actions`` and ``pos``/``vel``/``vt`` (points x 2) are the environment's own rows; actions are
    clipped to [0.6, 1.6] here; ``body`` and ``terrain`` are the tables' arrays (:func:`engine.kernel_args`).
    An environment that becomes unstable is put back to its state before the step, as Evolution Gym's
    snapshots are.  Nothing is allocated: every temporary lives in ``wp``/``we``/``ws``/``wb`` (one
    environment's share of :func:`workspace`), so the same function compiles for a CUDA thread, whose caller
    can keep them in the thread's local memory.
    """
    (n_points, n_edges, edges, rest0, spring_k, edge_surface, fixed, n_act, act_edges, n_surface, n_robot_surface,
     surface_owner, surface_points, surface_edges, pairs, n_groups, group_start, n_group_pairs, group_pairs, n_rigid,
     rigid_edges, point_edges, point_start, point_n_a, live, far) = body
    acc = wp[5]
    p0 = wp[8]
    v0 = wp[9]
    t0 = wp[10]
    goal = ws[1]
    count = ws[2]
    n = n_points[b]
    ne = n_edges[b]
    ea = edges[b]
    r0 = rest0[b]
    for e in range(ne):
        goal[e] = r0[e]
        count[e] = 0.0
    for m in range(n_act[b]):
        for k in range(2):
            goal[act_edges[b, m, k]] = 0.0
    for m in range(n_act[b]):
        a = actions[m]
        if a < 0.6:
            a = 0.6
        elif a > 1.6:
            a = 1.6
        for k in range(2):
            e = act_edges[b, m, k]
            goal[e] += a
            count[e] += 1.0
    for e in range(ne):
        if count[e] > 0:
            goal[e] *= r0[e] / count[e]
    scratch = (wp[0], wb, ws[0], we[0], wp[1], wp[2], wp[3], wp[4], wp[5], wp[6], wp[7], we[1])
    for m in range(n):
        for c in range(2):
            acc[m, c] = 0.0  # (the points whose accelerations are never needed keep these)
            p0[m, c] = pos[m, c]
            v0[m, c] = vel[m, c]
            t0[m, c] = vt[m, c]
    for _ in range(SUBSTEPS):
        c = _substep(n, ne, ea, r0, spring_k[b], edge_surface[b], fixed[b], goal, n_surface[b], surface_owner[b],
                     surface_points[b], surface_edges[b], pairs[b], n_groups[b], group_start[b], n_group_pairs[b],
                     group_pairs[b], n_rigid[b], rigid_edges[b], point_edges[b], point_start[b], point_n_a[b], live[b],
                     far[b], terrain,
                     pos, vel, vt, scratch)
        if c > n_robot_surface[b]:
            for m in range(n):
                for d in range(2):
                    pos[m, d] = p0[m, d]
                    vel[m, d] = v0[m, d]
                    vt[m, d] = t0[m, d]
            return True
    return False


#: per environment, the points' temporaries (collision forces, RK4 stages, the state before the step),
#: the edges' (spring forces, clamp corrections) and the springs' (rest lengths, goals, actuator counts)
POINT_TEMPS, EDGE_TEMPS, SPRING_TEMPS = 11, 2, 3


def workspace(n: int, points: int, edges: int, surface: int) -> tuple[np.ndarray, ...]:
    """Temporaries of :func:`step_env` for ``n`` environments on the CPU (boxes: the surface boxels', then
    their groups')."""
    return (np.empty((n, POINT_TEMPS, points, 2)), np.empty((n, EDGE_TEMPS, edges, 2)),
            np.empty((n, SPRING_TEMPS, edges)), np.empty((n, 2, surface, 4)))


#: how many of the arrays after the work arrays are the body tables' (the rest are the terrain's)
BODY_ARRAYS = 26


@_jit
def _step_row(i, active, index, actions, pos, vel, vt, unstable, work_points, work_edges, work_springs, work_boxes,
              *tables):
    if active[i]:
        unstable[i] = step_env(index[i], actions[i], pos[i], vel[i], vt[i], tables[:BODY_ARRAYS], tables[BODY_ARRAYS:],
                               work_points[i], work_edges[i], work_springs[i], work_boxes[i])


@numba.njit(cache=True, error_model="numpy", boundscheck=False, parallel=True)
def step_parallel(active, *args):
    """:func:`step_env` for every active environment, one thread per environment (arrays flat: a parallel
    loop takes no tuple of arrays)."""
    for i in numba.prange(active.shape[0]):
        _step_row(i, active, *args)


@_jit
def step_serial(active, *args):
    """:func:`step_env` for every active environment in turn (small batches: no threads to wake)."""
    for i in range(active.shape[0]):
        _step_row(i, active, *args)
