"""Cell-grid broadphase: candidate sphere–sphere pairs closer than a margin.

The spheres are binned in a uniform grid of cubic cells of side ``2 r_max + margin``
(counting sort), then each sphere is tested against the spheres of its 27 neighbouring
cells.  A pair is a candidate when its surface distance is below ``margin`` (= alert
distance + Verlet skin) and its two groups interact (``pair_law >= 0``).  The list is kept
until a body has moved more than half the skin (:func:`engine.contact.detect`).
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange


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
    if ns < 2:
        cell_order[:] = sphere_ids
        return 0
    lo, dims, start, order, cell = _grid(pos, radius, sphere_ids, margin, cell_order)
    return _pairs_range(0, ns, order, start, lo, dims, cell, pos, radius, group, pair_law,
                        excluded_next, margin, out, 0, out.shape[0])


@njit(cache=True)
def _grid(pos, radius, sphere_ids, margin, cell_order):
    """The cell grid of the spheres (cell side 2 r_max + margin): :func:`cell_sort`'s
    (lo, dims, start, order, cell), with the cell order also copied to ``cell_order``."""
    rmax = 0.0
    for k in range(sphere_ids.shape[0]):
        r = radius[sphere_ids[k]]
        if r > rmax:
            rmax = r
    lo, dims, start, order, cell = cell_sort(pos, sphere_ids, 2.0 * rmax + margin)
    cell_order[:] = order
    return lo, dims, start, order, cell


@njit(cache=True, inline="always")
def _pairs_range(k0, k1, order, start, lo, dims, cell, pos, radius, group, pair_law,
                 excluded_next, margin, out, o0, o1):
    """The candidate pairs (i, j > i) of the spheres ``order[k0:k1]`` (cell order), written
    to ``out[o0:o1]`` in that order; returns how many were found (possibly more than fit)."""
    count = 0
    for k in range(k0, k1):
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
                            if o0 + count < o1:
                                out[o0 + count, 0] = i
                                out[o0 + count, 1] = j
                            count += 1
    return count


@njit(cache=True)
def chunk_regions(n_items, cap, T, bounds, base):
    """Split ``n_items`` into ``T`` contiguous chunks (``bounds``, (T+1,)) and an output
    buffer of ``cap`` rows into ``T`` regions of equal size (``base``, (T+1,))."""
    for c in range(T + 1):
        bounds[c] = (n_items * c) // T
        base[c] = (cap * c) // T


@njit(cache=True)
def chunks_needed(base, counts):
    """(found, needed): the total that the ``T`` chunks found and, when a chunk overflowed
    its region of the output buffer (``base``, from :func:`chunk_regions`), a buffer size at
    which every chunk fits (regions of ``cap / T`` rows)."""
    T = counts.shape[0]
    found = 0
    need = 0
    over = False
    for c in range(T):
        found += counts[c]
        if counts[c] > base[c + 1] - base[c]:
            over = True
        if (counts[c] + 1) * T > need:
            need = (counts[c] + 1) * T
    return found, (need if over else found)


@njit(cache=True, parallel=True)
def build_pairs_parallel(T, pos, radius, group, pair_law, excluded_next, sphere_ids, margin,
                         out, cell_order):
    """:func:`build_pairs_ordered` on ``T`` threads, with the same output.

    The cell-ordered spheres are cut into ``T`` contiguous chunks; chunk ``c`` writes its
    pairs into its own region of ``out`` (``cap·c/T`` onwards), then the regions are moved
    down to follow each other (8 bytes per pair), which gives the serial list exactly.

    Returns
    -------
    (int, int)
        Pairs found, and the capacity ``out`` needs (larger than the count when a chunk
        overflowed its region: the caller grows ``out`` to it and calls again).
    """
    ns = sphere_ids.shape[0]
    cap = out.shape[0]
    if ns < 2:
        cell_order[:] = sphere_ids
        return 0, 0
    lo, dims, start, order, cell = _grid(pos, radius, sphere_ids, margin, cell_order)
    bounds = np.empty(T + 1, np.int64)
    base = np.empty(T + 1, np.int64)
    counts = np.zeros(T, np.int64)
    chunk_regions(ns, cap, T, bounds, base)
    for c in prange(T):
        counts[c] = _pairs_range(bounds[c], bounds[c + 1], order, start, lo, dims, cell, pos,
                                 radius, group, pair_law, excluded_next, margin, out, base[c],
                                 base[c + 1])
    found, need = chunks_needed(base, counts)
    if need > cap:
        return found, need
    put = counts[0]
    for c in range(1, T):
        src = base[c]
        for m in range(counts[c]):
            out[put + m, 0] = out[src + m, 0]
            out[put + m, 1] = out[src + m, 1]
        put += counts[c]
    return found, found


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


@njit(cache=True)
def max_speed(vel6, ids):
    """max over bodies ``ids`` of ‖v‖ (translational) [m/s]."""
    worst = 0.0
    for k in range(ids.shape[0]):
        b = ids[k]
        v = vel6[b, 0] ** 2 + vel6[b, 1] ** 2 + vel6[b, 2] ** 2
        if v > worst:
            worst = v
    return np.sqrt(worst)

