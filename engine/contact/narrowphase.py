"""Narrowphase: gaps, normals and local frames (n, t, s) per shape pair.

Shapes: sphere–sphere, sphere–plane, sphere–cylinder (inner side wall and optional end
caps).  The normal n points from the antagonist j to the candidate i (the direction in
which a compressive impulse pushes i); t and s complete a right-handed orthonormal frame.

A pair becomes an active contact when its gap g at the θ-predicted configuration is below
the alert distance, or when the free relative velocity would close it within the step
(g + h u_n < 0, the horizon of the Signorini condition u_n + max(g, 0)/h >= 0): nothing fast can tunnel through the alert band.

With ``two`` set, a pair is also active when a second velocity field ``vel6b`` would bring it
within the alert distance (g + h u_n < alert): :func:`engine.step.step` uses this after the
solve, with the solved velocities, to find the contacts that the solve itself closed (a grain
stopped under a falling one) and solve again.  The contacts the solve holds at
g + h u_n = 0 stay active under that test, so a second look never drops them.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from .broadphase import chunk_regions, chunks_needed

from ..model import CAP_BOTTOM, CAP_TOP, PLANE


@njit(cache=True)
def tangent_frame(nx, ny, nz):
    """Unit tangents (t, s) completing n into a right-handed frame (n, t, s = n × t)."""
    ax = abs(nx)
    ay = abs(ny)
    az = abs(nz)
    # t = n × e with e the coordinate axis least aligned with n
    if ax <= ay and ax <= az:  # e = x
        tx, ty, tz = 0.0, nz, -ny
    elif ay <= az:  # e = y
        tx, ty, tz = -nz, 0.0, nx
    else:  # e = z
        tx, ty, tz = ny, -nx, 0.0
    inv = 1.0 / np.sqrt(tx * tx + ty * ty + tz * tz)
    tx *= inv
    ty *= inv
    tz *= inv
    sx = ny * tz - nz * ty
    sy = nz * tx - nx * tz
    sz = nx * ty - ny * tx
    return tx, ty, tz, sx, sy, sz


def tangent_frames(normals: np.ndarray) -> np.ndarray:
    """(k, 9) local frames (n, t, s) of ``k`` unit normals (k, 3): :func:`tangent_frame`
    applied row by row, with numpy (the same operations, so the same bits)."""
    n = np.ascontiguousarray(normals, dtype=np.float64).reshape(-1, 3)
    nx, ny, nz = n[:, 0], n[:, 1], n[:, 2]
    ax, ay, az = np.abs(nx), np.abs(ny), np.abs(nz)
    ex = (ax <= ay) & (ax <= az)
    ey = ~ex & (ay <= az)
    ez = ~ex & ~ey
    zero = np.zeros_like(nx)
    tx = np.where(ex, zero, np.where(ey, -nz, ny))
    ty = np.where(ex, nz, np.where(ey, zero, -nx))
    tz = np.where(ex, -ny, np.where(ey, nx, zero))
    inv = 1.0 / np.sqrt(tx * tx + ty * ty + tz * tz)
    tx, ty, tz = tx * inv, ty * inv, tz * inv
    out = np.empty((n.shape[0], 9))
    out[:, 0:3] = n
    out[:, 3], out[:, 4], out[:, 5] = tx, ty, tz
    out[:, 6] = ny * tz - nz * ty
    out[:, 7] = nz * tx - nx * tz
    out[:, 8] = nx * ty - ny * tx
    return out


@njit(cache=True)
def _emit(k, cap, i, j, sub, nb, nx, ny, nz, gap, mu, ri, rj,
          o_i, o_j, o_sub, o_key, o_frame, o_gap, o_mu, o_ri, o_rj):
    if k < cap:
        o_i[k] = i
        o_j[k] = j
        o_sub[k] = sub
        o_key[k] = (np.int64(i) * nb + j) * 4 + sub
        tx, ty, tz, sx, sy, sz = tangent_frame(nx, ny, nz)
        o_frame[k, 0] = nx
        o_frame[k, 1] = ny
        o_frame[k, 2] = nz
        o_frame[k, 3] = tx
        o_frame[k, 4] = ty
        o_frame[k, 5] = tz
        o_frame[k, 6] = sx
        o_frame[k, 7] = sy
        o_frame[k, 8] = sz
        o_gap[k] = gap
        o_mu[k] = mu
        o_ri[k] = ri
        o_rj[k] = rj


@njit(cache=True)
def _wall_gap(x, y, z, r, kind, px, py, pz, ax, ay, az, R, H, caps, sub):
    """Gap and normal between a sphere (x, y, z, r) and surface ``sub`` of a wall.

    Returns ``(valid, gap, nx, ny, nz)``.
    """
    dx = x - px
    dy = y - py
    dz = z - pz
    if kind == PLANE:
        if sub != 0:
            return False, 0.0, 0.0, 0.0, 0.0
        return True, dx * ax + dy * ay + dz * az - r, ax, ay, az
    # cylinder: axial coordinate h in [0, H] from the base centre
    h = dx * ax + dy * ay + dz * az
    if sub == 0:
        if h < 0.0 or h > H:
            return False, 0.0, 0.0, 0.0, 0.0
        rx = dx - h * ax
        ry = dy - h * ay
        rz = dz - h * az
        rho = np.sqrt(rx * rx + ry * ry + rz * rz)
        if rho > 1e-300:
            nx = -rx / rho
            ny = -ry / rho
            nz = -rz / rho
        else:  # on the axis: any radial direction
            tx, ty, tz, sx, sy, sz = tangent_frame(ax, ay, az)
            nx, ny, nz = tx, ty, tz
        return True, R - rho - r, nx, ny, nz
    if sub == 1:
        if (caps & CAP_BOTTOM) == 0:
            return False, 0.0, 0.0, 0.0, 0.0
        return True, h - r, ax, ay, az
    if (caps & CAP_TOP) == 0:
        return False, 0.0, 0.0, 0.0, 0.0
    return True, H - h - r, -ax, -ay, -az


@njit(cache=True)
def narrowphase(pos, vel6, vel6b, two, radius, kind, group, axis, height, caps, pair_law,
                law_param, pairs, n_pairs, sphere_ids, wall_ids, alert, h,
                o_i, o_j, o_sub, o_key, o_frame, o_gap, o_mu, o_ri, o_rj):
    """Active contacts at configuration ``pos`` with free velocities ``vel6``.

    Parameters
    ----------
    pos : (nb, 3) [m] θ-predicted configuration q_i + (1-θ) h v_i.
    vel6 : (nb, 6) free velocities [m/s, rad/s] (for the closing-in-the-step test).
    vel6b : (nb, 6), two : bool
        With ``two``, a pair that ``vel6b`` brings within ``alert`` in the step is active
        too.
    radius, kind, group, axis, height, caps : per-body model arrays.
    pair_law : (ng, ng) int16 ; law_param : (nlaw, 4) float64
    pairs : (cap, 2) int32 candidate sphere pairs, the first ``n_pairs`` valid.
    sphere_ids, wall_ids : int32 body ids; the sphere–wall pairs are visited in the order
        of ``sphere_ids`` (:func:`engine.contact.detect` passes the broadphase's cell order).
    alert : float [m] ; h : float [s] time step
    o_* : output buffers of equal capacity (see :class:`engine.state.ContactBuffers`).

    Returns
    -------
    (int, int)
        Number of active contacts (if above the capacity the caller grows and retries) and
        how many of them, first in the buffers, are sphere–sphere.
    """
    cap = o_i.shape[0]
    k = _pair_contacts(0, n_pairs, pos, vel6, vel6b, two, radius, group, pair_law, law_param,
                       pairs, alert, h, 0, cap,
                       o_i, o_j, o_sub, o_key, o_frame, o_gap, o_mu, o_ri, o_rj)
    n_pair = k
    k = _wall_range(0, sphere_ids.shape[0], k, cap, pos, vel6, vel6b, two, radius, kind, group,
                    axis, height, caps, pair_law, law_param, sphere_ids, wall_ids, alert, h,
                    o_i, o_j, o_sub, o_key, o_frame, o_gap, o_mu, o_ri, o_rj)
    return k, n_pair


@njit(cache=True, inline="always")
def _pair_contacts(m0, m1, pos, vel6, vel6b, two, radius, group, pair_law, law_param, pairs,
                   alert, h, k0, k1, o_i, o_j, o_sub, o_key, o_frame, o_gap, o_mu, o_ri, o_rj):
    """The active sphere–sphere contacts of the candidate pairs ``pairs[m0:m1]``, written in
    that order to rows ``k0:k1`` of the output buffers; returns the row after the last one
    found (possibly beyond ``k1``: the contacts past it are counted, not written)."""
    nb = pos.shape[0]
    k = k0
    for m in range(m0, m1):
        i = pairs[m, 0]
        j = pairs[m, 1]
        dx = pos[i, 0] - pos[j, 0]
        dy = pos[i, 1] - pos[j, 1]
        dz = pos[i, 2] - pos[j, 2]
        dist = np.sqrt(dx * dx + dy * dy + dz * dz)
        ri = radius[i]
        rj = radius[j]
        gap = dist - ri - rj
        if gap > alert:
            inv = 1.0 / dist
            un = (dx * (vel6[i, 0] - vel6[j, 0]) + dy * (vel6[i, 1] - vel6[j, 1])
                  + dz * (vel6[i, 2] - vel6[j, 2])) * inv
            if gap + h * un > 0.0:
                if not two:
                    continue
                un = (dx * (vel6b[i, 0] - vel6b[j, 0]) + dy * (vel6b[i, 1] - vel6b[j, 1])
                      + dz * (vel6b[i, 2] - vel6b[j, 2])) * inv
                if gap + h * un >= alert:
                    continue
        if dist > 1e-300:
            inv = 1.0 / dist
            nx = dx * inv
            ny = dy * inv
            nz = dz * inv
        else:
            nx, ny, nz = 0.0, 0.0, 1.0
        law = pair_law[group[i], group[j]]
        _emit(k, k1, i, j, 0, nb, nx, ny, nz, gap, law_param[law, 0], ri, rj,
              o_i, o_j, o_sub, o_key, o_frame, o_gap, o_mu, o_ri, o_rj)
        k += 1
    return k


@njit(cache=True, inline="always")
def _wall_range(a0, a1, k, cap, pos, vel6, vel6b, two, radius, kind, group, axis, height, caps,
                pair_law, law_param, sphere_ids, wall_ids, alert, h,
                o_i, o_j, o_sub, o_key, o_frame, o_gap, o_mu, o_ri, o_rj):
    """The active sphere–wall contacts of the spheres ``sphere_ids[a0:a1]``, written to rows
    ``k:cap``; returns the row after the last one found (possibly beyond ``cap``: counted,
    not written)."""
    nb = pos.shape[0]
    for a in range(a0, a1):
        i = sphere_ids[a]
        x = pos[i, 0]
        y = pos[i, 1]
        z = pos[i, 2]
        r = radius[i]
        gi = group[i]
        for b in range(wall_ids.shape[0]):
            w = wall_ids[b]
            law = pair_law[gi, group[w]]
            if law < 0:
                continue
            nsub = 1 if kind[w] == PLANE else 3
            for sub in range(nsub):
                valid, gap, nx, ny, nz = _wall_gap(x, y, z, r, kind[w], pos[w, 0], pos[w, 1],
                                                   pos[w, 2], axis[w, 0], axis[w, 1], axis[w, 2],
                                                   radius[w], height[w], caps[w], sub)
                if not valid:
                    continue
                if gap > alert:
                    un = (nx * (vel6[i, 0] - vel6[w, 0]) + ny * (vel6[i, 1] - vel6[w, 1])
                          + nz * (vel6[i, 2] - vel6[w, 2]))
                    if gap + h * un > 0.0:
                        if not two:
                            continue
                        un = (nx * (vel6b[i, 0] - vel6b[w, 0]) + ny * (vel6b[i, 1] - vel6b[w, 1])
                              + nz * (vel6b[i, 2] - vel6b[w, 2]))
                        if gap + h * un >= alert:
                            continue
                _emit(k, cap, i, w, sub, nb, nx, ny, nz, gap, law_param[law, 0], r, 0.0,
                      o_i, o_j, o_sub, o_key, o_frame, o_gap, o_mu, o_ri, o_rj)
                k += 1
    return k


@njit(cache=True, parallel=True)
def narrowphase_parallel(T, pos, vel6, vel6b, two, radius, kind, group, axis, height, caps,
                         pair_law, law_param, pairs, n_pairs, sphere_ids, wall_ids, alert, h,
                         o_i, o_j, o_sub, o_key, o_frame, o_gap, o_mu, o_ri, o_rj):
    """:func:`narrowphase` with the sphere–sphere pairs on ``T`` threads; same output.

    The candidate pairs are cut into ``T`` contiguous chunks; chunk ``c`` writes its contacts
    into its own region of the buffers (rows ``cap·c/T`` onwards) and the regions are then
    moved down to follow each other; the sphere–wall contacts are appended the same way,
    the spheres cut into ``T`` chunks.

    Returns
    -------
    (int, int, int)
        Active contacts, how many are sphere–sphere, and the capacity the buffers need
        (above the count when a chunk overflowed its region: grow to it and call again).
    """
    cap = o_i.shape[0]
    bounds = np.empty(T + 1, np.int64)
    base = np.empty(T + 1, np.int64)
    counts = np.zeros(T, np.int64)
    chunk_regions(n_pairs, cap, T, bounds, base)
    for c in prange(T):
        counts[c] = _pair_contacts(bounds[c], bounds[c + 1], pos, vel6, vel6b, two, radius,
                                   group, pair_law, law_param, pairs, alert, h, base[c], base[c + 1], o_i, o_j,
                                   o_sub, o_key, o_frame, o_gap, o_mu, o_ri, o_rj) - base[c]
    n_pair, need = chunks_needed(base, counts)
    if need > cap:
        return n_pair, n_pair, need
    _compact(0, base, counts, o_i, o_j, o_sub, o_key, o_frame, o_gap, o_mu, o_ri, o_rj)
    # the sphere–wall contacts after them, the same way on the rest of the buffers
    ns = sphere_ids.shape[0]
    chunk_regions(ns, cap - n_pair, T, bounds, base)
    for c in range(T + 1):
        base[c] += n_pair
    for c in prange(T):
        counts[c] = _wall_range(bounds[c], bounds[c + 1], base[c], base[c + 1], pos, vel6,
                                vel6b, two, radius, kind, group, axis, height, caps, pair_law, law_param,
                                sphere_ids, wall_ids, alert, h,
                                o_i, o_j, o_sub, o_key, o_frame, o_gap, o_mu, o_ri, o_rj) - base[c]
    n_wall, need = chunks_needed(base, counts)
    if need > cap - n_pair:
        return n_pair + n_wall, n_pair, n_pair + need
    _compact(n_pair, base, counts, o_i, o_j, o_sub, o_key, o_frame, o_gap, o_mu, o_ri, o_rj)
    k = n_pair + n_wall
    return k, n_pair, k


@njit(cache=True)
def _compact(k, base, counts, o_i, o_j, o_sub, o_key, o_frame, o_gap, o_mu, o_ri, o_rj):
    """Move the rows that chunk ``c`` wrote from ``base[c]`` on down to follow each other
    from row ``k`` on (chunk 0 starts at ``k`` already)."""
    k += counts[0]
    for c in range(1, counts.shape[0]):
        src = base[c]
        for m in range(counts[c]):
            o_i[k] = o_i[src + m]
            o_j[k] = o_j[src + m]
            o_sub[k] = o_sub[src + m]
            o_key[k] = o_key[src + m]
            for d in range(9):
                o_frame[k, d] = o_frame[src + m, d]
            o_gap[k] = o_gap[src + m]
            o_mu[k] = o_mu[src + m]
            o_ri[k] = o_ri[src + m]
            o_rj[k] = o_rj[src + m]
            k += 1


@njit(cache=True)
def late_pairs_exist(pos, free, solved, radius, kind, group, axis, height, caps, pair_law,
                     pairs, n_pairs, sphere_ids, wall_ids, alert, h):
    """0 when no body's velocity changed by more than alert / (2 h) from ``free`` to
    ``solved``; else 2 when a candidate pair of such a body that is not a contact of the step
    (gap above ``alert``, not closed by the free velocities) is closed by the solved ones
    (g + h u_n < 0), and 1 when none is.  A cheap test that lets :func:`engine.step.step`
    skip its second look when the solve closed nothing new (a confined sample's surface
    grains change velocity by ~1 m/s every step, stopped by their contacts)."""
    nb = pos.shape[0]
    lim = (0.5 * alert / h) ** 2
    flag = np.zeros(nb, np.bool_)
    any_flag = False
    for b in range(nb):
        dx = solved[b, 0] - free[b, 0]
        dy = solved[b, 1] - free[b, 1]
        dz = solved[b, 2] - free[b, 2]
        if dx * dx + dy * dy + dz * dz > lim:
            flag[b] = True
            any_flag = True
    if not any_flag:
        return 0
    for m in range(n_pairs):
        i = pairs[m, 0]
        j = pairs[m, 1]
        if not (flag[i] or flag[j]):
            continue
        dx = pos[i, 0] - pos[j, 0]
        dy = pos[i, 1] - pos[j, 1]
        dz = pos[i, 2] - pos[j, 2]
        dist = np.sqrt(dx * dx + dy * dy + dz * dz)
        gap = dist - radius[i] - radius[j]
        if gap <= alert or dist <= 1e-300:
            continue
        inv = 1.0 / dist
        uf = (dx * (free[i, 0] - free[j, 0]) + dy * (free[i, 1] - free[j, 1])
              + dz * (free[i, 2] - free[j, 2])) * inv
        if gap + h * uf <= 0.0:
            continue
        us = (dx * (solved[i, 0] - solved[j, 0]) + dy * (solved[i, 1] - solved[j, 1])
              + dz * (solved[i, 2] - solved[j, 2])) * inv
        if gap + h * us < 0.0:
            return 2
    for a in range(sphere_ids.shape[0]):
        i = sphere_ids[a]
        for b in range(wall_ids.shape[0]):
            w = wall_ids[b]
            if not (flag[i] or flag[w]) or pair_law[group[i], group[w]] < 0:
                continue
            nsub = 1 if kind[w] == PLANE else 3
            for sub in range(nsub):
                valid, gap, nx, ny, nz = _wall_gap(pos[i, 0], pos[i, 1], pos[i, 2], radius[i],
                                                   kind[w], pos[w, 0], pos[w, 1], pos[w, 2],
                                                   axis[w, 0], axis[w, 1], axis[w, 2],
                                                   radius[w], height[w], caps[w], sub)
                if not valid or gap <= alert:
                    continue
                uf = (nx * (free[i, 0] - free[w, 0]) + ny * (free[i, 1] - free[w, 1])
                      + nz * (free[i, 2] - free[w, 2]))
                if gap + h * uf <= 0.0:
                    continue
                us = (nx * (solved[i, 0] - solved[w, 0]) + ny * (solved[i, 1] - solved[w, 1])
                      + nz * (solved[i, 2] - solved[w, 2]))
                if gap + h * us < 0.0:
                    return 2
    return 1
