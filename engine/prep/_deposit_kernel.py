"""Numba kernel of the 3D geometric deposit (see :mod:`engine.prep.deposit`).

Constraints are integers: ``c >= 0`` is a sphere (an obstacle or a grain already placed);
``c < 0`` is the wall ``-c - 1`` of the container: wall 0 is the floor; for a box, walls
1-4 are x = lo, x = hi, y = lo, y = hi; for a cylinder, wall 1 is its side.  A pocket is
three constraints and a root sign: the centre of a sphere of radius r touching the three.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

EPS_OVERLAP = 1e-10        # relative tolerance of the overlap test (centre distances)
CYL = -2                   # the cylinder side's constraint id


@njit(cache=True, _nrt=False)
def _plane(c, r, phi, wall_n, wall_d, cyl, out):
    """Centre-plane of wall constraint ``c`` for a sphere of radius r: out = (nx, ny, nz, d)
    with n·x = d at tangency (n points into the container)."""
    w = -c - 1
    if cyl[2] > 0 and w == 1:
        cp, sp = math.cos(phi), math.sin(phi)
        out[0], out[1], out[2] = -cp, -sp, 0.0
        out[3] = -(cp * cyl[0] + sp * cyl[1]) - cyl[2] + r
    else:
        out[0], out[1], out[2] = wall_n[w, 0], wall_n[w, 1], wall_n[w, 2]
        out[3] = wall_d[w] + r


@njit(cache=True, _nrt=False)
def _solve_once(a, b, c, sg, r, phi, X, Y, Z, R, wall_n, wall_d, cyl, work, out):
    """One solve with the cylinder side (if any) frozen as its tangent plane at angle phi."""
    cons = (a, b, c)
    # the first sphere constraint is the origin and the quadratic; the rest are linear
    s0 = -1
    for k in range(3):
        if cons[k] >= 0:
            s0 = cons[k]
            break
    if s0 < 0:
        # three planes: Cramer's rule
        for k in range(3):
            _plane(cons[k], r, phi, wall_n, wall_d, cyl, work[k])
        a11, a12, a13, b1 = work[0, 0], work[0, 1], work[0, 2], work[0, 3]
        a21, a22, a23, b2 = work[1, 0], work[1, 1], work[1, 2], work[1, 3]
        a31, a32, a33, b3 = work[2, 0], work[2, 1], work[2, 2], work[2, 3]
        det = a11 * (a22 * a33 - a23 * a32) - a12 * (a21 * a33 - a23 * a31) + a13 * (a21 * a32 - a22 * a31)
        if abs(det) < 1e-12:
            return False
        out[0] = (b1 * (a22 * a33 - a23 * a32) - a12 * (b2 * a33 - a23 * b3) + a13 * (b2 * a32 - a22 * b3)) / det
        out[1] = (a11 * (b2 * a33 - a23 * b3) - b1 * (a21 * a33 - a23 * a31) + a13 * (a21 * b3 - b2 * a31)) / det
        out[2] = (a11 * (a22 * b3 - b2 * a32) - a12 * (a21 * b3 - b2 * a31) + b1 * (a21 * a32 - a22 * a31)) / det
        return True
    ox, oy, oz = X[s0], Y[s0], Z[s0]
    R0 = R[s0] + r
    m = 0
    for k in range(3):
        ck = cons[k]
        if ck >= 0:
            if ck == s0:
                continue
            px, py, pz = X[ck] - ox, Y[ck] - oy, Z[ck] - oz
            Rk = R[ck] + r
            work[m, 0], work[m, 1], work[m, 2] = 2.0 * px, 2.0 * py, 2.0 * pz
            work[m, 3] = R0 * R0 - Rk * Rk + px * px + py * py + pz * pz
        else:
            _plane(ck, r, phi, wall_n, wall_d, cyl, work[m])
            work[m, 3] -= work[m, 0] * ox + work[m, 1] * oy + work[m, 2] * oz
        m += 1
    a1x, a1y, a1z, b1 = work[0, 0], work[0, 1], work[0, 2], work[0, 3]
    a2x, a2y, a2z, b2 = work[1, 0], work[1, 1], work[1, 2], work[1, 3]
    dx = a1y * a2z - a1z * a2y
    dy = a1z * a2x - a1x * a2z
    dz = a1x * a2y - a1y * a2x
    dd = dx * dx + dy * dy + dz * dz
    n1 = a1x * a1x + a1y * a1y + a1z * a1z
    n2 = a2x * a2x + a2y * a2y + a2z * a2z
    if dd <= 1e-16 * n1 * n2:
        return False
    # p0 = (b1 (a2 × d) + b2 (d × a1)) / |d|²: the point of the line closest to the origin
    ux = a2y * dz - a2z * dy
    uy = a2z * dx - a2x * dz
    uz = a2x * dy - a2y * dx
    vx = dy * a1z - dz * a1y
    vy = dz * a1x - dx * a1z
    vz = dx * a1y - dy * a1x
    p0x = (b1 * ux + b2 * vx) / dd
    p0y = (b1 * uy + b2 * vy) / dd
    p0z = (b1 * uz + b2 * vz) / dd
    inv = 1.0 / math.sqrt(dd)
    ex, ey, ez = dx * inv, dy * inv, dz * inv
    B = p0x * ex + p0y * ey + p0z * ez
    C = p0x * p0x + p0y * p0y + p0z * p0z - R0 * R0
    disc = B * B - C
    if disc < 0.0:
        return False
    t = -B + sg * math.sqrt(disc)
    out[0] = ox + p0x + t * ex
    out[1] = oy + p0y + t * ey
    out[2] = oz + p0z + t * ez
    return True


@njit(cache=True, _nrt=False)
def solve_pocket(a, b, c, sg, r, X, Y, Z, R, wall_n, wall_d, cyl, work, out):
    """Centre ``out`` (3,) of a sphere of radius r touching constraints a, b, c (root sg).
    A cylinder side is handled by a fixed point on its tangent plane."""
    if not (cyl[2] > 0 and (a == CYL or b == CYL or c == CYL)):
        return _solve_once(a, b, c, sg, r, 0.0, X, Y, Z, R, wall_n, wall_d, cyl, work, out)
    # start from the angle of the first sphere constraint
    phi = 0.0
    for ck in (a, b, c):
        if ck >= 0:
            phi = math.atan2(Y[ck] - cyl[1], X[ck] - cyl[0])
            break
    for _ in range(30):
        if not _solve_once(a, b, c, sg, r, phi, X, Y, Z, R, wall_n, wall_d, cyl, work, out):
            return False
        new = math.atan2(out[1] - cyl[1], out[0] - cyl[0])
        dphi = new - phi
        if dphi > math.pi:
            dphi -= 2 * math.pi
        elif dphi < -math.pi:
            dphi += 2 * math.pi
        phi = new
        if abs(dphi) < 1e-14:
            return True
    return False


@njit(cache=True, _nrt=False)
def _cell(x, lo, inv_h, n):
    k = int(math.floor((x - lo) * inv_h))
    return 0 if k < 0 else (n - 1 if k >= n else k)


@njit(cache=True, _nrt=False)
def inside(x, y, z, r, box, cyl, top):
    """Is a sphere (x, y, z, r) inside the container (boundary included, 1e-12 tolerance)?"""
    tol = 1e-12 * r
    if z < box[4] + r - tol or z > top - r + tol:
        return False
    if cyl[2] > 0:
        dx, dy = x - cyl[0], y - cyl[1]
        lim = cyl[2] - r + tol
        return lim > 0 and dx * dx + dy * dy <= lim * lim
    return (box[0] + r - tol <= x <= box[1] - r + tol) and (box[2] + r - tol <= y <= box[3] - r + tol)


@njit(cache=True, _nrt=False)
def free(x, y, z, r, X, Y, Z, R, head, nxt, glo, inv_h, gn):
    """No sphere overlaps (x, y, z, r) by more than EPS_OVERLAP of the contact distance."""
    return overlapping(x, y, z, r, X, Y, Z, R, head, nxt, glo, inv_h, gn) < 0


@njit(cache=True, _nrt=False)
def _overlaps(x, y, z, r, xq, yq, zq, rq):
    """Does the sphere (x, y, z, r) overlap (xq, yq, zq, rq) beyond EPS_OVERLAP?"""
    lim = (rq + r) * (1.0 - EPS_OVERLAP)
    dx, dy, dz = x - xq, y - yq, z - zq
    return dx * dx + dy * dy + dz * dz < lim * lim


@njit(cache=True, _nrt=False)
def overlapping(x, y, z, r, X, Y, Z, R, head, nxt, glo, inv_h, gn):
    """The first sphere overlapping (x, y, z, r), or -1."""
    i0, j0, k0 = _cell(x, glo[0], inv_h, gn[0]), _cell(y, glo[1], inv_h, gn[1]), _cell(z, glo[2], inv_h, gn[2])
    for i in range(max(i0 - 1, 0), min(i0 + 2, gn[0])):
        for j in range(max(j0 - 1, 0), min(j0 + 2, gn[1])):
            for k in range(max(k0 - 1, 0), min(k0 + 2, gn[2])):
                q = head[(i * gn[1] + j) * gn[2] + k]
                while q >= 0:
                    if _overlaps(x, y, z, r, X[q], Y[q], Z[q], R[q]):
                        return q
                    q = nxt[q]
    return -1


@njit(cache=True, _nrt=False)
def stable(a, b, c, x, y, z, r, X, Y, Z, R, wall_n, cyl, work):
    """Can gravity (−z) be balanced by non-negative normal forces of the three supports?"""
    cons = (a, b, c)
    for k in range(3):
        ck = cons[k]
        if ck >= 0:
            inv = 1.0 / (R[ck] + r)
            work[k, 0], work[k, 1], work[k, 2] = (x - X[ck]) * inv, (y - Y[ck]) * inv, (z - Z[ck]) * inv
        elif cyl[2] > 0 and ck == CYL:
            dx, dy = x - cyl[0], y - cyl[1]
            inv = 1.0 / math.sqrt(dx * dx + dy * dy)
            work[k, 0], work[k, 1], work[k, 2] = -dx * inv, -dy * inv, 0.0
        else:
            w = -ck - 1
            work[k, 0], work[k, 1], work[k, 2] = wall_n[w, 0], wall_n[w, 1], wall_n[w, 2]
    # solve λ0 n0 + λ1 n1 + λ2 n2 = e_z (columns n_k)
    a11, a21, a31 = work[0, 0], work[0, 1], work[0, 2]
    a12, a22, a32 = work[1, 0], work[1, 1], work[1, 2]
    a13, a23, a33 = work[2, 0], work[2, 1], work[2, 2]
    det = a11 * (a22 * a33 - a23 * a32) - a12 * (a21 * a33 - a23 * a31) + a13 * (a21 * a32 - a22 * a31)
    if abs(det) < 1e-9:
        return False
    # Cramer's rule with right-hand side (0, 0, 1)
    l0 = (a12 * a23 - a13 * a22) / det
    l1 = (a13 * a21 - a11 * a23) / det
    l2 = (a11 * a22 - a12 * a21) / det
    return l0 >= -1e-9 and l1 >= -1e-9 and l2 >= -1e-9


@njit(cache=True, _nrt=False)
def _drop(x, y, r, z_floor, X, Y, Z, R, head, nxt, glo, inv_h, gn, give_up):
    """Height at which a sphere of radius r falling along the vertical through (x, y) first
    touches a sphere or the floor (np.inf as soon as it exceeds ``give_up``)."""
    z = z_floor + r
    i0, j0 = _cell(x, glo[0], inv_h, gn[0]), _cell(y, glo[1], inv_h, gn[1])
    for i in range(max(i0 - 1, 0), min(i0 + 2, gn[0])):
        for j in range(max(j0 - 1, 0), min(j0 + 2, gn[1])):
            for k in range(gn[2]):
                q = head[(i * gn[1] + j) * gn[2] + k]
                while q >= 0:
                    d = R[q] + r
                    h2 = (x - X[q]) ** 2 + (y - Y[q]) ** 2
                    if h2 < d * d:
                        zq = Z[q] + math.sqrt(d * d - h2) * (1.0 + 1e-12)
                        if zq > z:
                            z = zq
                            if z >= give_up:
                                return np.inf
                    q = nxt[q]
    return z


@njit(cache=True, _nrt=False)
def _grid_add(q, x, y, z, head, nxt, glo, inv_h, gn):
    i, j, k = _cell(x, glo[0], inv_h, gn[0]), _cell(y, glo[1], inv_h, gn[1]), _cell(z, glo[2], inv_h, gn[2])
    c = (i * gn[1] + j) * gn[2] + k
    nxt[q] = head[c]
    head[c] = q


@njit(cache=True, _nrt=False)
def _before(k1, v1, k2, v2):
    """Heap order: by key, ties by pocket id (so the order never depends on the heap's
    history)."""
    return k1 < k2 or (k1 == k2 and v1 < v2)


@njit(cache=True, _nrt=False)
def _heap_push(keys, vals, o, n, key, val):
    """Push (key, val) on the heap keys[o:o + n], vals[o:o + n]; returns n + 1."""
    i = n
    keys[o + i] = key
    vals[o + i] = val
    while i > 0:
        p = (i - 1) >> 1
        if not _before(keys[o + i], vals[o + i], keys[o + p], vals[o + p]):
            break
        keys[o + p], keys[o + i] = keys[o + i], keys[o + p]
        vals[o + p], vals[o + i] = vals[o + i], vals[o + p]
        i = p
    return n + 1


@njit(cache=True, _nrt=False)
def _heap_pop(keys, vals, o, n):
    """Pop the lowest (key, val) of the heap keys[o:o + n]; returns (key, val, n − 1)."""
    key, val = keys[o], vals[o]
    n -= 1
    keys[o], vals[o] = keys[o + n], vals[o + n]
    i = 0
    while True:
        l = 2 * i + 1
        if l >= n:
            break
        m = l
        if l + 1 < n and _before(keys[o + l + 1], vals[o + l + 1], keys[o + l], vals[o + l]):
            m = l + 1
        if not _before(keys[o + m], vals[o + m], keys[o + i], vals[o + i]):
            break
        keys[o + m], keys[o + i] = keys[o + i], keys[o + m]
        vals[o + m], vals[o + i] = vals[o + i], vals[o + m]
        i = m
    return key, val, n


#: Radius classes.  Pockets are kept in N_CLASSES² heaps by both bounds of the grains they
#: may still take: the largest (pmax: heap row ``hi``, the class whose bound ub[hi] >= pmax)
#: and the smallest (``lo``: the lowest sample radius ub[lo] not known not to fit; every
#: sample below it was found not to fit, for good).  A grain of radius r only looks at the
#: heaps with ub[lo - 1] < r < ub[hi], so it visits neither the pockets that only smaller
#: grains fit nor those that only larger ones fit.
N_CLASSES = 32
N_HEAPS = N_CLASSES * N_CLASSES


@njit(cache=True)
def _class_bounds(r_lo, r_hi):
    """ub (N_CLASSES,) [m]: the upper pmax bound of each class (the last one unbounded)."""
    ub = np.empty(N_CLASSES)
    w = (r_hi - r_lo) / (N_CLASSES - 1)
    for c in range(N_CLASSES - 1):
        ub[c] = r_lo + (c + 1) * w
    ub[N_CLASSES - 1] = np.inf
    return ub


@njit(cache=True, _nrt=False)
def _class_of(p, ub):
    """The first class whose bound is >= p (pmax p [m], np.inf for 'any grain')."""
    c = 0
    while c < N_CLASSES - 1 and ub[c] < p:
        c += 1
    return c


@njit(cache=True, _nrt=False)
def _classify(a, b, c, sg, r_lo, r_hi, X, Y, Z, R, head, nxt, glo, inv_h, gn,
              wall_n, wall_d, cyl, box, top, work, pos):
    """(alive, key) of a pocket: dead if, for the smallest grain (or, when that one has no
    solution, the largest), its position overlaps a sphere or is unstable; key = z − r_lo
    for the smallest grain's centre, or a lower bound."""
    for r in (r_lo, r_hi):
        if solve_pocket(a, b, c, sg, r, X, Y, Z, R, wall_n, wall_d, cyl, work, pos):
            if not stable(a, b, c, pos[0], pos[1], pos[2], r, X, Y, Z, R, wall_n, cyl, work):
                return False, 0.0
            if not free(pos[0], pos[1], pos[2], r, X, Y, Z, R, head, nxt, glo, inv_h, gn):
                return False, 0.0
            if r == r_lo:
                return True, pos[2] - r_lo
            # no solution for the smallest grain: the lowest support is a lower bound
            zmin = pos[2]
            for ck in (a, b, c):
                if ck >= 0 and Z[ck] < zmin:
                    zmin = Z[ck]
            # keep key + r a lower bound of the height for every r <= r_hi (see _best_pocket)
            return True, zmin - r_hi
    return False, 0.0


#: Every sample radius ub[0..N_CLASSES-2] may fit (a new pocket's mask).
ALL_SAMPLES = (1 << (N_CLASSES - 1)) - 1


@njit(cache=True, _nrt=False)
def _low_bit(mask):
    """The lowest sample a pocket may still take (its ``lo`` class); N_CLASSES - 1 when no
    sample fits."""
    j = 0
    while j < N_CLASSES - 1 and not (mask >> j) & 1:
        j += 1
    return j


@njit(cache=True, _nrt=False)
def _heap_of(pmax, mask, ub):
    """The heap of a pocket: lo * N_CLASSES + hi."""
    return _low_bit(mask) * N_CLASSES + _class_of(pmax, ub)


@njit(cache=True, _nrt=False)
def _fits(a, b, c, sg, r, X, Y, Z, R, head, nxt, glo, inv_h, gn, wall_n, wall_d, cyl, box,
          top, work, pos):
    """Does a grain of radius r fit the pocket (a tangent position inside the container,
    stable, overlapping nothing)?"""
    return (solve_pocket(a, b, c, sg, r, X, Y, Z, R, wall_n, wall_d, cyl, work, pos)
            and inside(pos[0], pos[1], pos[2], r, box, cyl, top)
            and stable(a, b, c, pos[0], pos[1], pos[2], r, X, Y, Z, R, wall_n, cyl, work)
            and free(pos[0], pos[1], pos[2], r, X, Y, Z, R, head, nxt, glo, inv_h, gn))


@njit(cache=True, _nrt=False)
def _raise_floor(a, b, c, sg, r, mask, ub, X, Y, Z, R, head, nxt, glo, inv_h, gn, wall_n,
                 wall_d, cyl, box, top, work, pos):
    """(mask, j) of a pocket where a grain of radius r does not fit: the sample radii below
    r are tried from the lowest one still set up, each that does not fit cleared (for good:
    spheres are only added, the rest is fixed by the supports), until one fits; j is that
    one (or the first sample >= r).  The pocket's ``lo`` class rises with them."""
    j = _low_bit(mask)
    while j < N_CLASSES - 1 and ub[j] < r:
        if (mask >> j) & 1:
            if _fits(a, b, c, sg, ub[j], X, Y, Z, R, head, nxt, glo, inv_h, gn, wall_n,
                     wall_d, cyl, box, top, work, pos):
                break
            mask &= ~(1 << j)
        j += 1
    return mask, j


@njit(cache=True, _nrt=False)
def _largest_fit(a, b, c, sg, r_min, r_max, mask, ub, X, Y, Z, R, head, nxt, glo, inv_h, gn,
                 wall_n, wall_d, cyl, box, top, work, pos):
    """(j, mask): the largest sample radius r_min < ub[j] < r_max that still fits the
    pocket (−1 if none), trying them from the largest down; each sample that does not fit
    is cleared from the mask (for good: spheres are only added, the rest is fixed by the
    supports)."""
    for j in range(N_CLASSES - 2, -1, -1):
        if ub[j] <= r_min:
            break
        if ub[j] >= r_max or not (mask >> j) & 1:
            continue
        if _fits(a, b, c, sg, ub[j], X, Y, Z, R, head, nxt, glo, inv_h, gn, wall_n, wall_d,
                 cyl, box, top, work, pos):
            return j, mask
        mask &= ~(1 << j)
    return -1, mask


@njit(cache=True, _nrt=False)
def _fit_above(a, b, c, sg, r, mask, ub, X, Y, Z, R, head, nxt, glo, inv_h, gn, wall_n,
               wall_d, cyl, box, top, work, pos):
    """(pmax, mask) of a pocket where a grain of radius r does not fit: pmax is the class
    bound above the largest sample radius > r that still fits (r when none does).  A grain
    between two samples that fits where neither does is the only one this misses."""
    j, mask = _largest_fit(a, b, c, sg, r, np.inf, mask, ub, X, Y, Z, R, head, nxt, glo,
                           inv_h, gn, wall_n, wall_d, cyl, box, top, work, pos)
    return (ub[j + 1] if j >= 0 else r), mask


@njit(cache=True, _nrt=False)
def _fit_below(a, b, c, sg, r, pm, mask, ub, X, Y, Z, R, head, nxt, glo, inv_h, gn, wall_n,
               wall_d, cyl, box, top, work, pos):
    """(pmax, mask) of a pocket where a grain of radius r < pm does not fit: if no sample
    between r and pm still fits, pmax becomes the class bound above the largest sample
    below r that does (or r); if none fits at all, the mask is 0 (the pocket is dead)."""
    j, mask = _largest_fit(a, b, c, sg, -np.inf, pm, mask, ub, X, Y, Z, R, head, nxt, glo,
                           inv_h, gn, wall_n, wall_d, cyl, box, top, work, pos)
    if j < 0:
        return r, 0
    if ub[j] > r:
        return pm, mask
    return (ub[j + 1] if ub[j + 1] < r else r), mask


@njit(cache=True, _nrt=False)
def _aux_down(ak, av, ah, na, i):
    """Sift entry i of the heap of heap tops (ak, av, ah)[:na] down."""
    while True:
        l = 2 * i + 1
        if l >= na:
            return
        m = l
        if l + 1 < na and _before(ak[l + 1], av[l + 1], ak[l], av[l]):
            m = l + 1
        if not _before(ak[m], av[m], ak[i], av[i]):
            return
        ak[m], ak[i] = ak[i], ak[m]
        av[m], av[i] = av[i], av[m]
        ah[m], ah[i] = ah[i], ah[m]
        i = m


@njit(cache=True, _nrt=False)
def _best_pocket(r, r_lo, r_hi, ub, hk, hv, off, nh, tk, tv, pa, pb, pc, ps, pmax, pblk,
                 pmask, pfl, back, backk, ak, av, ah, X, Y, Z, R, head, nxt, glo, inv_h, gn,
                 wall_n, wall_d, cyl, box, top, work, pos):
    """The lowest pocket that takes a grain of radius r: (pocket or −1, count of the
    pockets to push back, in back/backk with their keys).

    Pockets are popped in key order from the heaps that may take r until no lower one can
    beat the best found.  A key is z − ρ, the height of the centre of a grain of some
    radius ρ <= r less ρ: a stable pocket rises at least as fast as the grain grows
    (dz/dr = Σλ_k >= 1 with e_z = Σ λ_k n_k, |n_k| = 1), so key + r bounds its height
    from below.  The heaps visited are merged through a heap of their tops (ak, av, ah).
    The lowest centre wins, ties to the lowest pocket id, whatever the order of the heaps.
    """
    best, bestz, bestk, nback = -1, np.inf, 0.0, 0
    g = 0                               # samples below r: ub[0..g-1]
    while g < N_CLASSES - 1 and ub[g] < r:
        g += 1
    c0 = 0
    while ub[c0] <= r:
        c0 += 1
    na = 0
    for lo in range(g + 1):
        for hi in range(c0, N_CLASSES):
            h = lo * N_CLASSES + hi
            if nh[h] > 0:
                ak[na], av[na], ah[na] = tk[h], tv[h], h
                na += 1
    for i in range(na // 2 - 1, -1, -1):
        _aux_down(ak, av, ah, na, i)
    while na > 0 and ak[0] + r <= bestz:
        h = ah[0]
        o = off[h]
        key, v, nh[h] = _heap_pop(hk, hv, o, nh[h])
        if nh[h] > 0:
            tk[h], tv[h] = hk[o], hv[o]
            ak[0], av[0] = tk[h], tv[h]
        else:
            tk[h], tv[h] = np.inf, -1
            na -= 1
            ak[0], av[0], ah[0] = ak[na], av[na], ah[na]
        _aux_down(ak, av, ah, na, 0)
        a, b, c, sg = pa[v], pb[v], pc[v], ps[v]
        keep, cand, fit, failed, blocked = True, False, False, False, False
        if r < pmax[v]:
            if not solve_pocket(a, b, c, sg, r, X, Y, Z, R, wall_n, wall_d, cyl, work, pos):
                failed = True
            elif pos[2] <= bestz and not inside(pos[0], pos[1], pos[2], r, box, cyl, top):
                fit, failed = True, True
            elif pos[2] <= bestz:
                # the sphere that blocked it last still does (spheres are never removed):
                # nothing new is learnt, no grid search
                q = pblk[v]
                known = q >= 0 and _overlaps(pos[0], pos[1], pos[2], r, X[q], Y[q], Z[q], R[q])
                if not known:
                    q = overlapping(pos[0], pos[1], pos[2], r, X, Y, Z, R, head, nxt, glo,
                                    inv_h, gn)
                if q >= 0:
                    failed, blocked = True, True
                    # a sphere above the centre: larger grains, which sit higher, hit it too
                    # (skip them)
                    above = Z[q] > pos[2]
                    if above and r < pmax[v]:
                        pmax[v] = r
                    if not known:
                        # a new blocking sphere: dead if the smallest grain no longer fits;
                        # beside or below the centre, which larger grains may fit is sampled
                        pblk[v] = q
                        pfl[v] = -1
                        fit = not above
                        keep, key = _classify(a, b, c, sg, r_lo, r_hi, X, Y, Z, R, head, nxt,
                                              glo, inv_h, gn, wall_n, wall_d, cyl, box, top,
                                              work, pos)
                elif (pos[2] < bestz or v < best):
                    if stable(a, b, c, pos[0], pos[1], pos[2], r, X, Y, Z, R, wall_n, cyl, work):
                        cand = True
                    else:
                        failed = True
        if fit and keep and r < pmax[v]:
            pmax[v], pmask[v] = _fit_above(a, b, c, sg, r, pmask[v], ub, X, Y, Z, R, head, nxt,
                                           glo, inv_h, gn, wall_n, wall_d, cyl, box, top, work,
                                           pos)
        if failed and keep:
            # which smaller grains do not fit either: the pocket's lo class rises
            lo = _low_bit(pmask[v])
            if lo != pfl[v] and ub[lo] < r:
                pmask[v], pfl[v] = _raise_floor(a, b, c, sg, r, pmask[v], ub, X, Y, Z, R,
                                                head, nxt, glo, inv_h, gn, wall_n, wall_d,
                                                cyl, box, top, work, pos)
                new = _low_bit(pmask[v])
                if pmask[v] == 0:
                    keep = False
                elif new > lo and solve_pocket(a, b, c, sg, ub[new - 1], X, Y, Z, R, wall_n,
                                               wall_d, cyl, work, pos):
                    # only grains above ub[new - 1] visit it now: a higher bound
                    kz = pos[2] - ub[new - 1]
                    if kz > key:
                        key = kz
        if blocked and keep and not fit and r < pmax[v]:
            # do larger grains still fit?  If not, the largest sample below r that fits
            # bounds the pocket from above (after _fit_above, which has just found the
            # largest that fits, this would only test that sample again)
            pmax[v], pmask[v] = _fit_below(a, b, c, sg, r, pmax[v], pmask[v], ub, X, Y, Z, R,
                                           head, nxt, glo, inv_h, gn, wall_n, wall_d, cyl, box,
                                           top, work, pos)
            if pmask[v] == 0:
                keep = False
        if cand:
            if best >= 0:
                back[nback], backk[nback] = best, bestk
                nback += 1
            best, bestz, bestk = v, pos[2], key
        elif keep:
            back[nback], backk[nback] = v, key
            nback += 1
    return best, nback


@njit(cache=True, _nrt=False)
def _back_heaps(back, nback, pmax, pmask, ub, bh, need):
    """The heap of each popped pocket (bh) and how many go back on each heap (need)."""
    for h in range(N_HEAPS):
        need[h] = 0
    for q in range(nback):
        h = _heap_of(pmax[back[q]], pmask[back[q]], ub)
        bh[q] = h
        need[h] += 1


@njit(cache=True, _nrt=False)
def _push_back(back, backk, bh, nback, hk, hv, off, nh, tk, tv):
    """Push the popped pockets back, each on its heap (room reserved)."""
    for q in range(nback):
        h = bh[q]
        o = off[h]
        nh[h] = _heap_push(hk, hv, o, nh[h], backk[q], back[q])
        tk[h], tv[h] = hk[o], hv[o]


@njit(cache=True, _nrt=False)
def _neighbours(s, n_obs, support_obs, reach, r_hi, X, Y, Z, R, head, nxt, glo, inv_h, gn,
                nbr):
    """The spheres within reach of sphere s, in nbr; their count, or −1 if nbr is full."""
    xs, ys, zs, rs = X[s], Y[s], Z[s], R[s]
    nn = 0
    span = int(math.ceil((2 * (r_hi if r_hi > rs else rs) + 2 * reach) * inv_h))
    i0, j0, k0 = (_cell(xs, glo[0], inv_h, gn[0]), _cell(ys, glo[1], inv_h, gn[1]),
                  _cell(zs, glo[2], inv_h, gn[2]))
    for i in range(max(i0 - span, 0), min(i0 + span + 1, gn[0])):
        for j in range(max(j0 - span, 0), min(j0 + span + 1, gn[1])):
            for k in range(max(k0 - span, 0), min(k0 + span + 1, gn[2])):
                q = head[(i * gn[1] + j) * gn[2] + k]
                while q >= 0:
                    if q != s and (support_obs or q >= n_obs):
                        d = rs + R[q] + 2 * reach
                        dx, dy, dz = xs - X[q], ys - Y[q], zs - Z[q]
                        if dx * dx + dy * dy + dz * dz <= d * d:
                            if nn >= nbr.shape[0]:
                                return -1
                            nbr[nn] = q
                            nn += 1
                    q = nxt[q]
    return nn


@njit(cache=True, _nrt=False)
def _wall_gap(w, x, y, z, r, wall_n, wall_d, cyl):
    """Gap [m] between the sphere (x, y, z, r) and wall w (the cylinder's side for w = 1
    in a cylinder, else the plane of wall_n[w], wall_d[w])."""
    if cyl[2] > 0 and w == 1:
        return cyl[2] - math.sqrt((x - cyl[0]) ** 2 + (y - cyl[1]) ** 2) - r
    return wall_n[w, 0] * x + wall_n[w, 1] * y + wall_n[w, 2] * z - wall_d[w] - r


@njit(cache=True, _nrt=False)
def _walls_near(s, reach, X, Y, Z, R, wall_n, wall_d, nwall, cyl, walls):
    """The walls within reach of sphere s (as constraint ids) in walls; their count."""
    nw = 0
    for w in range(nwall):
        if _wall_gap(w, X[s], Y[s], Z[s], R[s], wall_n, wall_d, cyl) <= 2 * reach:
            walls[nw] = -w - 1
            nw += 1
    return nw


@njit(cache=True, _nrt=False)
def _new_pockets(s, nn, nw, nbr, walls, reach, r_lo, r_hi, npk, pa, pb, pc, ps, pmax, pblk,
                 pmask, pfl, hk, hv, off, nh, tk, tv, X, Y, Z, R, head, nxt, glo, inv_h, gn, wall_n,
                 wall_d, cyl, box, top, work, pos):
    """The live pockets of the triples (s, a, b), (s, a, wall), (s, wall, wall), stored from
    pocket npk on and pushed on the heap of the pockets that may take any grain (lo 0,
    hi N_CLASSES - 1; room for 2 per pair reserved); returns the new pocket count."""
    top_c = N_CLASSES - 1           # = _heap_of(np.inf, ALL_SAMPLES, ub)
    o = off[top_c]
    for ia in range(nn + nw):
        ca = nbr[ia] if ia < nn else walls[ia - nn]
        for ib in range(ia + 1, nn + nw):
            cb = nbr[ib] if ib < nn else walls[ib - nn]
            if ca >= 0 and cb >= 0:
                d = R[ca] + R[cb] + 2 * reach
                dx, dy, dz = X[ca] - X[cb], Y[ca] - Y[cb], Z[ca] - Z[cb]
                if dx * dx + dy * dy + dz * dz > d * d:
                    continue
            elif ca >= 0 or cb >= 0:
                sp = ca if ca >= 0 else cb
                w = -(cb if ca >= 0 else ca) - 1
                if _wall_gap(w, X[sp], Y[sp], Z[sp], R[sp], wall_n, wall_d, cyl) > 2 * reach:
                    continue
            for sg in (-1.0, 1.0):
                alive, key = _classify(s, ca, cb, sg, r_lo, r_hi, X, Y, Z, R, head, nxt,
                                       glo, inv_h, gn, wall_n, wall_d, cyl, box, top, work, pos)
                if not alive:
                    continue
                pa[npk], pb[npk], pc[npk], ps[npk], pmax[npk] = s, ca, cb, sg, np.inf
                pblk[npk] = -1
                pmask[npk] = ALL_SAMPLES
                pfl[npk] = -1
                nh[top_c] = _heap_push(hk, hv, o, nh[top_c], key, npk)
                npk += 1
    tk[top_c], tv[top_c] = (hk[o], hv[o]) if nh[top_c] > 0 else (np.inf, -1)
    return npk


@njit(cache=True)
def _grown(a, n, size):
    """a copy of a[:n] in an array of ``size``."""
    b = np.empty(size, a.dtype)
    b[:n] = a[:n]
    return b


@njit(cache=True)
def _reserve(hk, hv, off, cap, nh, used, c, need):
    """Room for ``need`` more entries on class c's heap: (hk, hv, used), the pool grown
    and compacted when the class's segment must move and the pool is full."""
    if cap[c] - nh[c] >= need:
        return hk, hv, used
    new = max(2 * cap[c], nh[c] + need)
    if used + new > hk.shape[0]:
        size = 2 * (cap.sum() + new)
        k2 = np.empty(size)
        v2 = np.empty(size, np.int64)
        used = 0
        for d in range(N_HEAPS):
            k2[used:used + nh[d]] = hk[off[d]:off[d] + nh[d]]
            v2[used:used + nh[d]] = hv[off[d]:off[d] + nh[d]]
            off[d] = used
            used += cap[d]
        hk, hv = k2, v2
    hk[used:used + nh[c]] = hk[off[c]:off[c] + nh[c]]
    hv[used:used + nh[c]] = hv[off[c]:off[c] + nh[c]]
    off[c] = used
    cap[c] = new
    return hk, hv, used + new


@njit(cache=True)
def deposit_kernel(radii, n_obs, X, Y, Z, R, wall_n, wall_d, nwall, cyl, box, top,
                   glo, inv_h, gn, reach, floor_pts, max_pockets, support_obs):
    """Place ``radii`` one by one at the lowest stable pocket (see deposit.geometric).

    X, Y, Z, R hold the ``n_obs`` obstacles first and receive the grains after them.
    Returns (number placed, status, number dropped): status 0 ok, 1 no room below the top,
    2 pocket memory; "dropped" grains found no pocket and were dropped vertically.

    The loops run in the functions above, which take plain arrays and no reference counts
    (``_nrt=False``); this one only allocates and grows.
    """
    nb_tot = X.shape[0]
    head = -np.ones(gn[0] * gn[1] * gn[2], np.int64)
    nxt = -np.ones(nb_tot, np.int64)
    work = np.zeros((3, 4))
    pos = np.zeros(3)
    r_lo, r_hi = radii.min(), radii.max()
    ub = _class_bounds(r_lo, r_hi)
    # the heaps: segments [off[h], off[h] + cap[h]) of one pool
    cap = np.full(N_HEAPS, 16, np.int64)
    off = np.arange(N_HEAPS) * 16
    used = N_HEAPS * 16
    hk = np.empty(2 * used)
    hv = np.empty(2 * used, np.int64)
    nh = np.zeros(N_HEAPS, np.int64)
    tk = np.full(N_HEAPS, np.inf)           # each heap's lowest key and its pocket
    tv = np.full(N_HEAPS, -1, np.int64)
    ak = np.empty(N_HEAPS)                  # the tops of the heaps a grain visits
    av = np.empty(N_HEAPS, np.int64)
    ah = np.empty(N_HEAPS, np.int64)
    need_h = np.zeros(N_HEAPS, np.int64)
    pcap = 1 << 16
    pa = np.empty(pcap, np.int64)
    pb = np.empty(pcap, np.int64)
    pc = np.empty(pcap, np.int64)
    ps = np.empty(pcap, np.float64)
    pmax = np.empty(pcap)          # grains this large or larger overlap something there
    pblk = np.empty(pcap, np.int64)  # the sphere that last blocked the pocket, or -1
    pmask = np.empty(pcap, np.int64)  # bit j: a grain of radius ub[j] may still fit
    pfl = np.empty(pcap, np.int64)    # the lowest sample last found to fit, or -1
    npk = 0
    nbr = np.empty(4096, np.int64)
    back = np.empty(4096, np.int64)
    backk = np.empty(4096)
    bh = np.empty(4096, np.int64)
    walls = np.empty(nwall, np.int64)
    n_placed = 0
    n_drop = 0
    for s in range(n_obs + radii.shape[0]):
        if s >= n_obs:
            r = radii[s - n_obs]
            R[s] = r
            live = nh.sum()
            if back.shape[0] < live + 1:
                back = np.empty(2 * (live + 1), np.int64)
                backk = np.empty(2 * (live + 1))
                bh = np.empty(2 * (live + 1), np.int64)
            best, nback = _best_pocket(r, r_lo, r_hi, ub, hk, hv, off, nh, tk, tv, pa, pb, pc,
                                       ps, pmax, pblk, pmask, pfl, back, backk, ak, av, ah, X,
                                       Y, Z, R, head, nxt, glo, inv_h, gn, wall_n, wall_d, cyl,
                                       box, top, work, pos)
            _back_heaps(back, nback, pmax, pmask, ub, bh, need_h)
            for h in range(N_HEAPS):
                if need_h[h] > 0:
                    hk, hv, used = _reserve(hk, hv, off, cap, nh, used, h, need_h[h])
            _push_back(back, backk, bh, nback, hk, hv, off, nh, tk, tv)
            if best >= 0:
                solve_pocket(pa[best], pb[best], pc[best], ps[best], r, X, Y, Z, R,
                             wall_n, wall_d, cyl, work, pos)
                X[s], Y[s], Z[s] = pos[0], pos[1], pos[2]
            else:
                # no pocket takes it: drop it vertically at the floor point where it lands
                # lowest (resting on one support; the relaxation settles it)
                bz, bq = np.inf, -1
                for q in range(floor_pts.shape[0]):
                    x, y = floor_pts[q, 0], floor_pts[q, 1]
                    if not inside(x, y, box[4] + r, r, box, cyl, np.inf):
                        continue
                    z = _drop(x, y, r, box[4], X, Y, Z, R, head, nxt, glo, inv_h, gn, bz)
                    if z < bz:
                        bz, bq = z, q
                if bq < 0:
                    return n_placed, 1, n_drop
                X[s], Y[s], Z[s] = floor_pts[bq, 0], floor_pts[bq, 1], bz
                n_drop += 1
            if Z[s] > top - r + 1e-12 * r:
                return n_placed, 1, n_drop
            n_placed += 1
        _grid_add(s, X[s], Y[s], Z[s], head, nxt, glo, inv_h, gn)
        if s < n_obs and not support_obs:
            continue
        # new pockets with s: neighbours within reach, walls within reach
        nn = _neighbours(s, n_obs, support_obs, reach, r_hi, X, Y, Z, R, head, nxt, glo,
                         inv_h, gn, nbr)
        while nn < 0:
            nbr = np.empty(2 * nbr.shape[0], np.int64)
            nn = _neighbours(s, n_obs, support_obs, reach, r_hi, X, Y, Z, R, head, nxt, glo,
                             inv_h, gn, nbr)
        nw = _walls_near(s, reach, X, Y, Z, R, wall_n, wall_d, nwall, cyl, walls)
        need = (nn + nw) * (nn + nw - 1)          # at most 2 pockets per pair
        if npk + need > pcap:
            if npk + need > max_pockets and pcap >= max_pockets:
                return n_placed, 2, n_drop
            new = max(2 * pcap, npk + need)
            pa, pb, pc = _grown(pa, npk, new), _grown(pb, npk, new), _grown(pc, npk, new)
            ps, pmax, pblk = _grown(ps, npk, new), _grown(pmax, npk, new), _grown(pblk, npk, new)
            pmask, pfl = _grown(pmask, npk, new), _grown(pfl, npk, new)
            pcap = new
        hk, hv, used = _reserve(hk, hv, off, cap, nh, used, N_CLASSES - 1, need)
        npk = _new_pockets(s, nn, nw, nbr, walls, reach, r_lo, r_hi, npk, pa, pb, pc, ps,
                           pmax, pblk, pmask, pfl, hk, hv, off, nh, tk, tv, X, Y, Z, R, head, nxt, glo,
                           inv_h, gn, wall_n, wall_d, cyl, box, top, work, pos)
    return n_placed, 0, n_drop
