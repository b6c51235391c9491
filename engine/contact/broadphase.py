"""Cell-grid broadphase: candidate sphere–sphere pairs closer than a margin.

The spheres are binned in a uniform grid of cubic cells of side ``2 r_max + margin``
(counting sort), then each sphere is tested against the spheres of its 27 neighbouring
cells.  A pair is a candidate when its surface distance is below ``margin`` (= alert
distance + Verlet skin) and its two groups interact (``pair_law >= 0``).  The list is kept
until a body has moved more than half the skin (:func:`engine.contact.detect`).
"""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def cell_sort(pos, ids, cell):
    """Bin the bodies ``ids`` of ``pos`` in cubic cells of side ``cell`` [m].

    Returns ``(lo, dims, start, order)``: grid origin (3,), cells per axis (3,), CSR starts
    (ncell+1,) and the body ids sorted by cell.  The cell side is enlarged when the grid
    would hold more than 8 cells per body (a sparse or exploded sample).
    """
    n = ids.shape[0]
    lo = np.empty(3)
    hi = np.empty(3)
    for d in range(3):
        lo[d] = np.inf
        hi[d] = -np.inf
    for k in range(n):
        b = ids[k]
        for d in range(3):
            x = pos[b, d]
            if x < lo[d]:
                lo[d] = x
            if x > hi[d]:
                hi[d] = x
    dims = np.ones(3, np.int64)
    while True:
        total = 1
        for d in range(3):
            dims[d] = int((hi[d] - lo[d]) / cell) + 1
            total *= dims[d]
        if total <= 8 * n + 64:
            break
        cell *= 1.5
    ncell = dims[0] * dims[1] * dims[2]
    start = np.zeros(ncell + 1, np.int64)
    cid = np.empty(n, np.int64)
    for k in range(n):
        b = ids[k]
        cx = int((pos[b, 0] - lo[0]) / cell)
        cy = int((pos[b, 1] - lo[1]) / cell)
        cz = int((pos[b, 2] - lo[2]) / cell)
        c = (cz * dims[1] + cy) * dims[0] + cx
        cid[k] = c
        start[c + 1] += 1
    for c in range(ncell):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    order = np.empty(n, np.int32)
    for k in range(n):
        c = cid[k]
        order[fill[c]] = ids[k]
        fill[c] += 1
    return lo, dims, start, order, cell


@njit(cache=True)
def build_pairs(pos, radius, group, pair_law, excluded_next, sphere_ids, margin, out):
    """:func:`build_pairs_ordered` without the cell order output."""
    order = np.empty(sphere_ids.shape[0], np.int32)
    return build_pairs_ordered(pos, radius, group, pair_law, excluded_next, sphere_ids, margin,
                               out, order)


@njit(cache=True)
def build_pairs_ordered(pos, radius, group, pair_law, excluded_next, sphere_ids, margin, out,
                        cell_order):
    """Candidate pairs (i < j) of spheres with surface distance < ``margin`` [m].

    The spheres are visited in cell order (the grid's z-major order of cells), so that the
    list, and the contacts that the narrowphase emits from it, run through space slab by
    slab: consecutive contacts touch nearby bodies, which keeps the NLGS sweep's body data
    in cache whatever the body numbering (measured in ``bench/bench_scaling.py``).

    Parameters
    ----------
    pos : (nb, 3) float64 [m]
    radius : (nb,) float64 [m]
    group : (nb,) int16
    pair_law : (ng, ng) int16, -1 = no interaction
    excluded_next : (nb,) int32
        Linked bead pairs (i, excluded_next[i]) that get no contact (-1 = none).
    sphere_ids : (ns,) int32
    margin : float [m]
    out : (cap, 2) int32
        Written up to its capacity.
    cell_order : (ns,) int32
        Filled with the sphere ids in cell order (the narrowphase visits the sphere–wall
        pairs in that order too).

    Returns
    -------
    int
        Number of candidate pairs found; if larger than ``cap`` the caller must grow
        ``out`` and call again (nothing is dropped silently).
    """
    ns = sphere_ids.shape[0]
    cap = out.shape[0]
    for k in range(ns):
        cell_order[k] = sphere_ids[k]
    if ns < 2:
        return 0
    rmax = 0.0
    for k in range(ns):
        r = radius[sphere_ids[k]]
        if r > rmax:
            rmax = r
    lo, dims, start, order, cell = cell_sort(pos, sphere_ids, 2.0 * rmax + margin)
    for k in range(ns):
        cell_order[k] = order[k]
    count = 0
    for k in range(ns):
        i = order[k]  # cell order: consecutive pairs touch nearby bodies (cache locality)
        xi = pos[i, 0]
        yi = pos[i, 1]
        zi = pos[i, 2]
        ri = radius[i]
        gi = group[i]
        cx = int((xi - lo[0]) / cell)
        cy = int((yi - lo[1]) / cell)
        cz = int((zi - lo[2]) / cell)
        for dz in range(-1, 2):
            z = cz + dz
            if z < 0 or z >= dims[2]:
                continue
            for dy in range(-1, 2):
                y = cy + dy
                if y < 0 or y >= dims[1]:
                    continue
                for dx in range(-1, 2):
                    x = cx + dx
                    if x < 0 or x >= dims[0]:
                        continue
                    c = (z * dims[1] + y) * dims[0] + x
                    for m in range(start[c], start[c + 1]):
                        j = order[m]
                        if j <= i:
                            continue
                        if pair_law[gi, group[j]] < 0:
                            continue
                        if excluded_next[i] == j or excluded_next[j] == i:
                            continue
                        ddx = pos[j, 0] - xi
                        ddy = pos[j, 1] - yi
                        ddz = pos[j, 2] - zi
                        reach = ri + radius[j] + margin
                        if ddx * ddx + ddy * ddy + ddz * ddz < reach * reach:
                            if count < cap:
                                out[count, 0] = i
                                out[count, 1] = j
                            count += 1
    return count


@njit(cache=True)
def max_displacement(pos, ref, vel6, ids, lookahead):
    """max over bodies ``ids`` of ‖pos − ref‖ + lookahead·‖v‖ [m] (Verlet rebuild test)."""
    worst = 0.0
    for k in range(ids.shape[0]):
        b = ids[k]
        dx = pos[b, 0] - ref[b, 0]
        dy = pos[b, 1] - ref[b, 1]
        dz = pos[b, 2] - ref[b, 2]
        d = np.sqrt(dx * dx + dy * dy + dz * dz)
        v = np.sqrt(vel6[b, 0] ** 2 + vel6[b, 1] ** 2 + vel6[b, 2] ** 2)
        d += lookahead * v
        if d > worst:
            worst = d
    return worst
