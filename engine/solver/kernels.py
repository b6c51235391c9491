"""The NLGS kernels (Eq. 5), at the bottom of the solver: plain numba functions on
contiguous arrays and scalars, which the accelerations (:mod:`engine.solver.anderson`,
:mod:`engine.solver.chains`, :mod:`engine.solver.parallel`) build on and the solve stage
(:mod:`engine.solver.nlgs`) calls; they import nothing above them.

For each contact α in turn, the sweep computes the current local velocity from the body
velocities, removes its own contribution W_αα p_α to get the local free velocity, calls the
local solver of its law (:mod:`engine.solver.local`) and applies the impulse change to the
two bodies at once (so the next contact sees it: Gauss–Seidel); the wire links follow, in
the same sweep.  The convergence norm is :mod:`engine.solver.nlgs`'s ("Quad").

The sweeps take the step's arrays in three named tuples, built once per solve
(:func:`engine.solver.nlgs._solve_on`): :class:`Contacts`, :class:`Bodies` and
:class:`Links`.  numba types a named tuple of arrays as a tuple type and resolves each
field access at compile time, so a kernel that takes ``C`` reads ``C.frame`` as it read
its ``frame`` argument (bit-identical results, the same sweep speed: docs/engine.md, "The
solver package"); the counts (``n``, ``n_pair``, ``nl``) and the scalars (``relax``,
``tol``, ...) stay plain arguments.
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from ..model import DYN_INV_INERTIA, DYN_INV_MASS, DYN_LINE, DYN_LX, DYN_LY, DYN_LZ
from .local import coulomb, rod, wire

#: The contact arrays of a sweep (the first ``n`` rows are the step's contacts; the
#: contact buffers of :mod:`engine.contact`, in the sweep's body numbering, or the
#: parallel sweep's copies gathered by group):
#: ``i, j`` (n,) int32 bodies; ``frame`` (n, 9) local frames (n, t, s) [-];
#: ``w`` (n, 4) Delassus diagonals (W_nn, W_tt, 1/(W_nn + c), 1/W_tt) [1/kg, kg], c the
#: normal compliance (``Options.contact_compliance`` × W_nn, 0 for rigid contacts);
#: ``gterm`` (n,) gap terms max(g_m, 0)/h, g_m/h for compliant contacts [m/s];
#: ``mu`` (n,) friction [-];
#: ``ri, rj`` (n,) lever arms [m]; ``impulse`` (n, 3) local impulses (p_n, p_t, p_s) [N·s],
#: updated in place.
Contacts = namedtuple("Contacts", "i j frame w gterm mu ri rj impulse")

#: The body arrays of a sweep: ``dyn`` (nb, 8) the rows of ``model.body_dyn`` (inverse mass
#: and inertia, LINE axis) and ``vel6`` (nb, 6) velocities [m/s, rad/s], updated in place.
Bodies = namedtuple("Bodies", "dyn vel6")

#: The wire-link arrays of a sweep: ``i, j`` (nl,) int32 beads; ``normal`` (nl, 3) unit
#: vectors from j to i; ``wl`` (nl, LINK_COLUMNS) the per-link data of
#: :func:`link_prepare`; ``unilateral`` (nl,) 1 for the wires (λ >= 0), 0 for the rods;
#: ``impulse`` (nl,) link impulses λ [N·s] (tension positive), updated in place;
#: ``order`` (nl,) the visiting order (``model.link_order``).
Links = namedtuple("Links", "i j normal wl unilateral impulse order")


@njit(cache=True, inline="always")
def _apply(i, j, ri, rj, px, py, pz, pt, ps, tx, ty, tz, sx, sy, sz, body_dyn, vel6, line_j,
           guard=False):
    """Add the impulse (global P, local tangential pt, ps) to body i and -P to body j.

    ``line_j`` and ``guard`` are compile-time constants at each call site.  ``line_j`` says
    whether j may be a LINE body (a force- or pressure-driven wall), which moves along its
    line only.  ``guard`` (the parallel sweep, :mod:`engine.solver.parallel`) writes only
    mobile bodies, so that an immobile wall shared by two domains is never written by two
    threads; the arithmetic on mobile bodies is the same.
    """
    # rotation: ω_i += I_i⁻¹ (a_i × P), a_i = -r_i n  ->  -r_i/I_i (pt s - ps t); same sign on j
    qx = pt * sx - ps * tx
    qy = pt * sy - ps * ty
    qz = pt * sz - ps * tz
    im = body_dyn[i, DYN_INV_MASS]
    if not guard or im != 0.0:
        ci = -ri * body_dyn[i, DYN_INV_INERTIA]
        vel6[i, 0] += im * px
        vel6[i, 1] += im * py
        vel6[i, 2] += im * pz
        vel6[i, 3] += ci * qx
        vel6[i, 4] += ci * qy
        vel6[i, 5] += ci * qz
    im = body_dyn[j, DYN_INV_MASS]
    if guard and im == 0.0:
        return
    if line_j and body_dyn[j, DYN_LINE] != 0.0:
        lx = body_dyn[j, DYN_LX]
        ly = body_dyn[j, DYN_LY]
        lz = body_dyn[j, DYN_LZ]
        d = im * (px * lx + py * ly + pz * lz)
        vel6[j, 0] -= d * lx
        vel6[j, 1] -= d * ly
        vel6[j, 2] -= d * lz
    else:
        vel6[j, 0] -= im * px
        vel6[j, 1] -= im * py
        vel6[j, 2] -= im * pz
    cj = -rj * body_dyn[j, DYN_INV_INERTIA]
    vel6[j, 3] += cj * qx
    vel6[j, 4] += cj * qy
    vel6[j, 5] += cj * qz


@njit(cache=True)
def _line_factor(body_dyn, b, ex, ey, ez):
    """Share of a unit impulse along e that moves body b (1, or (e·l)² for LINE bodies)."""
    if body_dyn[b, DYN_LINE] != 0.0:
        d = ex * body_dyn[b, DYN_LX] + ey * body_dyn[b, DYN_LY] + ez * body_dyn[b, DYN_LZ]
        return d * d
    return 1.0


@njit(cache=True)
def prepare(n, c_i, c_j, key, frame, gap, ri, rj, w, gterm, impulse, body_dyn, vel6,
            warm_key, warm_impulse, h, nb, eps=0.0):
    """Delassus diagonals, gap terms and warm start for the ``n`` contacts of the step.

    W_αα = H_αᵀ M⁻¹ H_α for spheres (lever arm -r n): W_nn = 1/m_i + 1/m_j,
    W_tt = W_ss = 1/m_i + 1/m_j + r_i²/I_i + r_j²/I_j.  The gap term is max(g_m, 0)/h
    (see :func:`engine.solver.local.coulomb`).

    ``eps`` (``Options.contact_compliance``, >= 0) gives each contact the normal compliance
    c = eps W_nn: the local normal solve divides by W_nn + c (``w[a, 2]`` = 1/(W_nn + c)),
    and with eps > 0 the gap term is g_m/h whatever its sign, so that an overlap is the
    spring's (the unilateral elastic law of Eq. 14 with g_ref = 0, stiffness
    1/(c h²)); with eps = 0 both are as above, bit for bit.  The impulse of a contact that
    existed in the previous step (same key) is restarted from its previous value
    (global frame, projected on the new frame) and applied to the body velocities.

    ``nb`` is the scene's body count (the keys' stride): the previous key is looked up among
    those of the same first body (:func:`warm_index`), a few entries.

    Returns the number of warm-started contacts.
    """
    first = warm_index(warm_key, nb)
    stride = np.int64(4) * nb
    hits = 0
    for a in range(n):
        i = c_i[a]
        j = c_j[a]
        nx, ny, nz = frame[a, 0], frame[a, 1], frame[a, 2]
        tx, ty, tz = frame[a, 3], frame[a, 4], frame[a, 5]
        sx, sy, sz = frame[a, 6], frame[a, 7], frame[a, 8]
        imi = body_dyn[i, DYN_INV_MASS]
        imj = body_dyn[j, DYN_INV_MASS]
        rot = ri[a] * ri[a] * body_dyn[i, DYN_INV_INERTIA] + rj[a] * rj[a] * body_dyn[j, DYN_INV_INERTIA]
        wn = imi * _line_factor(body_dyn, i, nx, ny, nz) + imj * _line_factor(body_dyn, j, nx, ny, nz)
        wt = imi * _line_factor(body_dyn, i, tx, ty, tz) + imj * _line_factor(body_dyn, j, tx, ty, tz)
        ws = imi * _line_factor(body_dyn, i, sx, sy, sz) + imj * _line_factor(body_dyn, j, sx, sy, sz)
        wt = max(wt, ws) + rot
        w[a, 0] = wn
        w[a, 1] = wt
        w[a, 2] = 1.0 / (wn + eps * wn) if wn > 0.0 else 0.0
        w[a, 3] = 1.0 / wt if wt > 0.0 else 0.0
        g = gap[a]
        gterm[a] = g / h if (g > 0.0 or eps > 0.0) else 0.0
        impulse[a, 0] = 0.0
        impulse[a, 1] = 0.0
        impulse[a, 2] = 0.0
        if wn <= 0.0:  # both bodies immobile: nothing to solve
            continue
        # the key among the previous step's keys of the same first body
        k = key[a]
        b = k // stride
        lo = first[b]
        hi = first[b + 1]
        while lo < hi and warm_key[lo] < k:
            lo += 1
        if lo < hi and warm_key[lo] == k:
            gx = warm_impulse[lo, 0]
            gy = warm_impulse[lo, 1]
            gz = warm_impulse[lo, 2]
            pn = gx * nx + gy * ny + gz * nz
            pt = gx * tx + gy * ty + gz * tz
            ps = gx * sx + gy * sy + gz * sz
            if pn > 0.0:
                impulse[a, 0] = pn
                impulse[a, 1] = pt
                impulse[a, 2] = ps
                _apply(i, j, ri[a], rj[a], pn * nx + pt * tx + ps * sx, pn * ny + pt * ty + ps * sy,
                       pn * nz + pt * tz + ps * sz, pt, ps, tx, ty, tz, sx, sy, sz, body_dyn, vel6,
                       True)
                hits += 1
    return hits


@njit(cache=True, inline="always")
def local_velocity(i, j, r_i, r_j, nx, ny, nz, tx, ty, tz, sx, sy, sz, vel6):
    """Local velocity (u_n, u_t, u_s) [m/s] of the contact between bodies i and j (lever
    arms -r n, frame (n, t, s)), from the body velocities ``vel6``: u = Hᵀ v, with
    u_t = t·Δv − s·Ω and u_s = s·Δv + t·Ω (Δv = v_i − v_j, Ω = r_i ω_i + r_j ω_j).  The
    sweep's update (:func:`_contact`) and the natural-map residual
    (:mod:`engine.solver.residual`) both read it here."""
    dvx = vel6[i, 0] - vel6[j, 0]
    dvy = vel6[i, 1] - vel6[j, 1]
    dvz = vel6[i, 2] - vel6[j, 2]
    ox = r_i * vel6[i, 3] + r_j * vel6[j, 3]
    oy = r_i * vel6[i, 4] + r_j * vel6[j, 4]
    oz = r_i * vel6[i, 5] + r_j * vel6[j, 5]
    un = nx * dvx + ny * dvy + nz * dvz
    ut = tx * dvx + ty * dvy + tz * dvz - (sx * ox + sy * oy + sz * oz)
    us = sx * dvx + sy * dvy + sz * dvz + (tx * ox + ty * oy + tz * oz)
    return un, ut, us


@njit(cache=True, inline="always")
def _contact(a, C, B, relax, line_j, guard=False, over=False):
    """Solve contact ``a`` of ``C`` (:class:`Contacts`) given the others (one Gauss–Seidel
    update, moving the velocities of ``B``, :class:`Bodies`); returns its two terms of the
    Quad norm, (‖W Δp‖², ‖W p‖²).  ``line_j``, ``guard``: see :func:`_apply`.
    ``over`` (a compile-time constant at each call site, like them): the over-relaxed
    (ω > 1) update, projected SOR.  Measured on the peers deposit: re-projecting the relaxed
    impulse on the cone (a second disk projection, its square root and division) made the
    sweep 4x slower (18 -> 71 ns per contact) even at ω = 1 when ω was tested at run time
    here, and 4x slower for ω > 1 when it was a constant; folding ω into the local
    solver's input, as here, costs nothing measurable, but adds three multiply-adds that
    cost 1-2 ns per contact when done at ω = 1 too.  So the callers pick the variant once
    per sweep (:func:`sweep`, :func:`iterate_hot`), and the ω <= 1 path is the plain
    update."""
    c_i, c_j, frame, w, gterm, mu, ri, rj, impulse = C
    body_dyn, vel6 = B
    wn = w[a, 0]
    if wn <= 0.0:  # both bodies immobile
        return 0.0, 0.0
    wt = w[a, 1]
    i = c_i[a]
    j = c_j[a]
    nx = frame[a, 0]
    ny = frame[a, 1]
    nz = frame[a, 2]
    tx = frame[a, 3]
    ty = frame[a, 4]
    tz = frame[a, 5]
    sx = frame[a, 6]
    sy = frame[a, 7]
    sz = frame[a, 8]
    r_i = ri[a]
    r_j = rj[a]
    un, ut, us = local_velocity(i, j, r_i, r_j, nx, ny, nz, tx, ty, tz, sx, sy, sz, vel6)
    pn0 = impulse[a, 0]
    pt0 = impulse[a, 1]
    ps0 = impulse[a, 2]
    if over:
        # over-relaxed (ω > 1, projected SOR): the local problem is solved for the free
        # velocity u_f + (ω - 1) u, u the local velocity (+ gap term) the impulses give now,
        # i.e. the unprojected update is p0 + ω (p_GS - p0), and the local solver's own
        # projection keeps it on the cone
        r = relax - 1.0
        g = gterm[a]
        pn, pt, ps = coulomb(un - wn * pn0 + g + r * (un + g), ut - wt * pt0 + r * ut,
                             us - wt * ps0 + r * us, w[a, 2], w[a, 3], mu[a])
        dpn = pn - pn0
        dpt = pt - pt0
        dps = ps - ps0
    else:
        pn, pt, ps = coulomb(un - wn * pn0 + gterm[a], ut - wt * pt0, us - wt * ps0,
                             w[a, 2], w[a, 3], mu[a])
        # under-relaxation p <- p0 + ω (p - p0), ω <= 1: a convex combination, in the cone
        dpn = relax * (pn - pn0)
        dpt = relax * (pt - pt0)
        dps = relax * (ps - ps0)
    pn = pn0 + dpn
    pt = pt0 + dpt
    ps = ps0 + dps
    impulse[a, 0] = pn
    impulse[a, 1] = pt
    impulse[a, 2] = ps
    _apply(i, j, r_i, r_j, dpn * nx + dpt * tx + dps * sx, dpn * ny + dpt * ty + dps * sy,
           dpn * nz + dpt * tz + dps * sz, dpt, dps, tx, ty, tz, sx, sy, sz, body_dyn, vel6, line_j,
           guard)
    return ((wn * dpn) ** 2 + (wt * dpt) ** 2 + (wt * dps) ** 2,
            (wn * pn) ** 2 + (wt * pt) ** 2 + (wt * ps) ** 2)


@njit(cache=True, inline="always")
def _span(lo, hi, q, C, B, relax, line_j, guard, over, store):
    """Contacts ``lo..hi`` in order (``line_j``, ``guard``, ``over``: constants at each call
    site, see :func:`_contact`); each ‖W Δp‖² goes to ``q[a]`` when ``store``.  Returns the
    Quad sums.  The parallel sweep's groups run through it too
    (:func:`engine.solver.parallel._run`)."""
    num = 0.0
    den = 0.0
    for a in range(lo, hi):
        x, y = _contact(a, C, B, relax, line_j, guard, over)
        if store:
            q[a] = x
        num += x
        den += y
    return num, den


@njit(cache=True, inline="always")
def _full(n, n_pair, q, C, B, relax, over, store):
    """All ``n`` contacts: the sphere–sphere ones (the first ``n_pair``), then those that may
    touch a driven wall; returns the Quad sums."""
    num, den = _span(0, n_pair, q, C, B, relax, False, False, over, store)
    x, y = _span(n_pair, n, q, C, B, relax, True, False, over, store)
    return num + x, den + y


@njit(cache=True)
def sweep(n, n_pair, C, B, relax):
    """One Gauss–Seidel sweep over the ``n`` contacts of ``C`` (:class:`Contacts`), moving
    the velocities of ``B`` (:class:`Bodies`); returns (Σ‖WΔp‖², Σ‖Wp‖²).

    The first ``n_pair`` contacts are sphere–sphere (no driven wall involved), the others
    sphere–wall: two loops, so that the sphere–sphere loop carries no driven-wall branch;
    over-relaxed sweeps (ω > 1) run their own copy of the loops (see :func:`_contact`).
    Hot loop: scalar arithmetic on contiguous arrays only (no temporaries).
    """
    if relax > 1.0:  # (q unused: store is False)
        return _full(n, n_pair, C.gterm, C, B, relax, True, False)
    return _full(n, n_pair, C.gterm, C, B, relax, False, False)


@njit(cache=True, inline="always")
def _apply_link(i, j, dl, nx, ny, nz, body_dyn, vel6):
    """Add a link impulse change dl (tension positive): −dl n on bead i, +dl n on bead j."""
    imi = body_dyn[i, DYN_INV_MASS] * dl
    imj = body_dyn[j, DYN_INV_MASS] * dl
    vel6[i, 0] -= imi * nx
    vel6[i, 1] -= imi * ny
    vel6[i, 2] -= imi * nz
    vel6[j, 0] += imj * nx
    vel6[j, 1] += imj * ny
    vel6[j, 2] += imj * nz


@njit(cache=True)
def link_prepare(nl, link_i, link_j, ref_len, stiffness, broken, pos, body_dyn, vel6, impulse,
                 normal, gap, wl, h):
    """Per-link data of the step and warm start (Eq. 7-15 after the change of variables 8).

    For link l between beads i and j at the θ-predicted configuration: n = (x_i − x_j)/g,
    g the centre distance, W = 1/m_i + 1/m_j (point contactors at the centres: no lever
    arm), the compliance c = L/(k h²) (0 for rigid laws).  Stored in
    ``wl[l] = (W, 1/(W + c), g, L², h², 1/h)``, all zero for a link that is skipped (broken,
    loose: k = 0, :class:`engine.laws.LooseWire`, or rigid between two immobile beads, whose
    force is undetermined).  An elastic link between
    two immobile beads still gets its force (T = k ε).  The previous step's impulse is
    applied to the beads.
    """
    for l in range(nl):
        i = link_i[l]
        j = link_j[l]
        dx = pos[i, 0] - pos[j, 0]
        dy = pos[i, 1] - pos[j, 1]
        dz = pos[i, 2] - pos[j, 2]
        g = np.sqrt(dx * dx + dy * dy + dz * dz)
        if g > 0.0:
            nx = dx / g
            ny = dy / g
            nz = dz / g
        else:
            nx, ny, nz = 0.0, 0.0, 1.0
        normal[l, 0] = nx
        normal[l, 1] = ny
        normal[l, 2] = nz
        gap[l] = g
        imi = body_dyn[i, DYN_INV_MASS]
        imj = body_dyn[j, DYN_INV_MASS]
        W = imi + imj
        L = ref_len[l]
        k = stiffness[l]
        c = L / (k * h * h) if (k < np.inf and k > 0.0) else 0.0
        if broken[l] or k <= 0.0 or W + c <= 0.0:  # broken, loose (k = 0), or rigid
            # between two immobile beads
            for q in range(wl.shape[1]):
                wl[l, q] = 0.0
            impulse[l] = 0.0
            continue
        wl[l, 0] = W
        wl[l, 1] = 1.0 / (W + c)
        wl[l, 2] = g
        wl[l, 3] = L * L
        wl[l, 4] = h * h
        wl[l, 5] = 1.0 / h
        if impulse[l] != 0.0:
            _apply_link(i, j, impulse[l], nx, ny, nz, body_dyn, vel6)


@njit(cache=True, inline="always")
def lstar(l, normal, wl, wx, wy, wz):
    """(u, L*) of link ``l`` at the relative velocity w = v_i − v_j: its normal velocity
    and the length that keeps its next predicted length exact, L*² = L² − h²‖w_⊥‖²,
    saturated at 0.99 L² (the link turns by up to ~6° per step: continuous, and bounded
    where the step is too coarse; see :func:`link_sweep`)."""
    u = normal[l, 0] * wx + normal[l, 1] * wy + normal[l, 2] * wz
    L2 = wl[l, 3]
    ls2 = L2 - (wx * wx + wy * wy + wz * wz - u * u) * wl[l, 4]
    return u, np.sqrt(ls2 if ls2 > 0.99 * L2 else 0.99 * L2)


@njit(cache=True, inline="always")
def link_update(l, L, B, relax):
    """The Gauss–Seidel update of link ``l`` of ``L`` (:class:`Links`; its local solve:
    :func:`engine.solver.local.rod` and :func:`~engine.solver.local.wire`, see
    :func:`link_sweep`); returns its Quad terms ((W Δλ)², (W λ)²), (0, 0) for a skipped
    link."""
    link_i, link_j, normal, wl, unilateral, impulse, _ = L
    body_dyn, vel6 = B
    iwc = wl[l, 1]
    if iwc == 0.0:  # skipped link (see link_prepare)
        return 0.0, 0.0
    W = wl[l, 0]
    i = link_i[l]
    j = link_j[l]
    nx = normal[l, 0]
    ny = normal[l, 1]
    nz = normal[l, 2]
    u, ls = lstar(l, normal, wl, vel6[i, 0] - vel6[j, 0], vel6[i, 1] - vel6[j, 1],
                  vel6[i, 2] - vel6[j, 2])
    lam0 = impulse[l]
    # the local free velocity u_f = u + W λ0 and the length term (g − L*)/h
    if unilateral[l] != 0:
        lam = wire(u + W * lam0, (wl[l, 2] - ls) * wl[l, 5], iwc, lam0, relax)
    else:
        lam = rod(u + W * lam0, (wl[l, 2] - ls) * wl[l, 5], iwc, lam0, relax)
    dl = lam - lam0
    lam = lam0 + dl
    impulse[l] = lam
    _apply_link(i, j, dl, nx, ny, nz, body_dyn, vel6)
    return (W * dl) ** 2, (W * lam) ** 2


@njit(cache=True)
def link_sweep(nl, L, B, relax):
    """One Gauss–Seidel sweep over the ``nl`` wire links of ``L`` (:class:`Links`), in its
    ``order``; returns (Σ(W Δλ)², Σ(W λ)²).

    Local solver of each law after the change of variables of Eq. (8)
    (:mod:`engine.solver.local`: :func:`~engine.solver.local.rod` for the rods,
    :func:`~engine.solver.local.wire` for the wires): with u = n·(v_i − v_j)
    the current normal velocity and u_f = u + W λ₀ the local free velocity (own impulse
    removed), the impulse λ (tension positive: −λ n acts on i, +λ n on j) is

    * rigid rod (Eq. 9) / elastic rod (Eq. 11): λ = (u_f + (g − L*)/h) / (W + c);
    * rigid wire (Eq. 13) / elastic wire (Eq. 15): the same, clamped to λ >= 0;

    with c = L/(k h²) the compliance of the elastic laws (0 for rigid) and
    L* = √(L² − h²‖w_⊥‖²), w_⊥ the relative velocity across the link.  Eq. (8) with L in
    place of L* makes g + h u = L, the next length to first order only: a link turning at
    w_⊥ then lengthens by h²‖w_⊥‖²/(2L) every step (measured: a 31-bead chain swinging at
    h = 1 ms drifted by 30 % of its link length).  With L*, the rigid laws keep the exact
    next predicted length ‖(x_i − x_j) + h (v_i − v_j)‖ = L, and the elastic ones give
    T = λ/h = k (g + h u − L*)/L ≈ k (ℓ⁺ − L)/L with ℓ⁺ that exact next length.  The link's
    own impulse acts along n, so w_⊥ is the other impulses' doing and the local solve stays
    closed-form.  No tangential reaction.

    Links are visited in ``order`` (``model.link_order``): along each wire, the links at even
    positions first, then the odd ones, so that consecutive updates share no bead and
    overlap in the pipeline (measured: 1.65-2× faster per sweep on a 1 000-bead chain, with
    about the same number of sweeps).

    The correction is saturated at L*² >= 0.99 L² (reached when the link turns by more than
    ~6° in a step).  Measured on a 31-bead rigid chain hanging between two fixed ends at
    h = 1 ms (a step too coarse for its fast early motion): with the correction
    unbounded, or bounded at 0.9 L², the energy grew (+1.5e-4 J in 3 s); bounded at
    0.99 L² it decayed, as it does with L* = L.  At h = 0.1 ms the bound is not reached in
    the tests.
    """
    order = L.order
    num = 0.0
    den = 0.0
    for m in range(nl):
        x, y = link_update(order[m], L, B, relax)
        num += x
        den += y
    return num, den


@njit(cache=True)
def iterate(n, n_pair, nl, C, B, L, relax, tol, max_iter):
    """Sweep the ``n`` contacts of ``C`` then the ``nl`` links of ``L`` (:class:`Contacts`,
    :class:`Links`; the first ``n_pair`` contacts are sphere–sphere, :func:`sweep`) until the
    Quad residual (over both) is below ``tol`` or ``max_iter`` sweeps are done.  A scene
    without links never enters the link loop.

    Returns ``(iterations, residual)``.
    """
    if n == 0 and nl == 0:
        return 0, 0.0
    res = 0.0
    for it in range(max_iter):
        res = sweep_all(n, n_pair, nl, C, B, L, relax)
        if res < tol:
            return it + 1, res
    return max_iter, res


#: A contact is "hot" when its local-velocity change in the last full sweep, ‖W Δp‖², is
#: above this factor times the mean over the contacts (:func:`iterate_hot`).
HOT_FACTOR = 2.0


@njit(cache=True)
def hot_list(n, q, factor, hot, bounds, hbounds):
    """The hot contacts of the last full sweep: those whose ‖W Δp‖² ``q[a]`` exceeds
    ``factor`` times the mean, written in increasing order to ``hot``; returns their count.
    ``bounds`` (sorted contact indices) give ``hbounds[k]``, the number of hot contacts
    below ``bounds[k]`` (where each group of the contact buffer starts in ``hot``)."""
    thr = 0.0
    for a in range(n):
        thr += q[a]
    thr *= factor / n
    m = 0
    k = 0
    nb = bounds.shape[0]
    for a in range(n):
        while k < nb and bounds[k] <= a:
            hbounds[k] = m
            k += 1
        if q[a] > thr:
            hot[m] = a
            m += 1
    while k < nb:
        hbounds[k] = m
        k += 1
    return m


@njit(cache=True)
def iterate_hot(n, n_pair, nl, C, B, L, relax, tol, max_iter, hot_sweeps, factor, q, hot):
    """:func:`iterate` with re-sweeps of the hot contacts (``Options.hot_sweeps``).

    After each full sweep (contacts then links) that has not converged, the contacts whose
    ‖W Δp‖² in it exceeded ``factor`` times the mean are swept again ``hot_sweeps`` times,
    in buffer order: on settling piles the residual sits on a few percent of the contacts
    (sliding contacts whose normal impulse creeps and their neighbours), and the plain
    sweep spends most of its work on the others.  The stopping test is that of
    :func:`iterate`, on the full sweeps only, so the accepted solution meets the same
    criterion.  ``q`` (n,) and ``hot`` (n,) int32 are work arrays.

    Returns ``(iterations, residual)``: full sweeps, not counting the re-sweeps.
    """
    if relax > 1.0:  # the over-relaxed copy of the loops (see :func:`_contact`)
        return _iterate_hot(n, n_pair, nl, C, B, L, relax, tol, max_iter, hot_sweeps, factor,
                            q, hot, True)
    return _iterate_hot(n, n_pair, nl, C, B, L, relax, tol, max_iter, hot_sweeps, factor, q,
                        hot, False)


@njit(cache=True, inline="always")
def _iterate_hot(n, n_pair, nl, C, B, L, relax, tol, max_iter, hot_sweeps, factor, q, hot,
                 over):
    """:func:`iterate_hot`'s loop, ``over`` a constant at each call site."""
    if n == 0 and nl == 0:
        return 0, 0.0
    bounds = np.full(1, n_pair, np.int64)
    hbounds = np.empty(1, np.int64)
    res = 0.0
    for it in range(max_iter):
        num, den = _full(n, n_pair, q, C, B, relax, over, True)
        res = links_then_residual(num, den, nl, L, B, relax)
        if res < tol:
            return it + 1, res
        if n == 0:
            continue
        resweep_hot(n, q, factor, hot, bounds, hbounds, hot_sweeps, C, B, relax, over)
    return max_iter, res


@njit(cache=True, inline="always")
def resweep_hot(n, q, factor, hot, bounds, hbounds, hot_sweeps, C, B, relax, over):
    """Sweep the hot contacts of the last full sweep (:func:`hot_list` on its ``q``)
    ``hot_sweeps`` times (``over``: a constant at each call site, see :func:`_contact`)."""
    m = hot_list(n, q, factor, hot, bounds, hbounds)
    m_pair = hbounds[0]  # hot sphere–sphere contacts come first (hot is in buffer order)
    for _ in range(hot_sweeps):
        for k in range(m_pair):
            _contact(hot[k], C, B, relax, False, False, over)
        for k in range(m_pair, m):
            _contact(hot[k], C, B, relax, True, False, over)


@njit(cache=True)
def sweep_all(n, n_pair, nl, C, B, L, relax):
    """One sweep of the contacts then the links (:func:`iterate`'s arguments); returns the
    Quad residual of the sweep."""
    num, den = sweep(n, n_pair, C, B, relax)
    return links_then_residual(num, den, nl, L, B, relax)


@njit(cache=True, inline="always")
def links_then_residual(num, den, nl, L, B, relax):
    """The end of every sweep: the links' sweep (if any) added to the contacts' Quad sums
    ``num``, ``den``, and the Quad residual sqrt(num / den) / ω (0 when nothing carries an
    impulse).  A relaxed sweep changes the impulses by ω times the Gauss–Seidel update
    (less where an over-relaxed one is projected back on the cone), so dividing by ω
    measures the Gauss–Seidel update: the same stopping test whatever ω (at ω = 1, exactly
    the plain residual)."""
    if nl > 0:
        lnum, lden = link_sweep(nl, L, B, relax)
        num += lnum
        den += lden
    return np.sqrt(num / den) / relax if den > 0.0 else 0.0


@njit(cache=True)
def warm_store(n, key, frame, impulse, nb):
    """Sorted keys and global-frame impulses of the step's contacts, for the next warm start.

    A contact's key is ``(i nb + j) 4 + sub`` (:func:`engine.contact.narrowphase._emit`), so
    the sort is a counting sort on its first body ``i`` followed by an insertion sort of each
    body's few keys: O(n + nb) with streaming passes, where a comparison sort of randomly
    numbered bodies' keys costs ~100 ns per contact at 64k bodies.
    """
    stride = np.int64(4) * nb
    end = np.zeros(nb + 1, np.int64)
    for a in range(n):
        end[key[a] // stride + 1] += 1
    for b in range(nb):
        end[b + 1] += end[b]
    order = np.empty(n, np.int64)
    for a in range(n):
        b = key[a] // stride
        order[end[b]] = a
        end[b] += 1  # end[b] ends as the end of bucket b (= the start of b + 1)
    lo = 0
    for b in range(nb):
        hi = end[b]
        for x in range(lo + 1, hi):
            a = order[x]
            k = key[a]
            y = x - 1
            while y >= lo and key[order[y]] > k:
                order[y + 1] = order[y]
                y -= 1
            order[y + 1] = a
        lo = hi
    keys = np.empty(n, np.int64)
    glob = np.empty((n, 3))
    for m in range(n):
        a = order[m]
        keys[m] = key[a]
        for d in range(3):
            glob[m, d] = (impulse[a, 0] * frame[a, d] + impulse[a, 1] * frame[a, 3 + d]
                          + impulse[a, 2] * frame[a, 6 + d])
    return keys, glob


@njit(cache=True)
def warm_index(warm_key, nb):
    """CSR start of each first body's keys in the sorted ``warm_key`` ((nb + 1,) int64)."""
    stride = np.int64(4) * nb
    first = np.zeros(nb + 1, np.int64)
    for m in range(warm_key.shape[0]):
        first[warm_key[m] // stride + 1] += 1
    for b in range(nb):
        first[b + 1] += first[b]
    return first


@njit(cache=True)
def layout(n, c_i, c_j, nl, link_i, link_j, loc, perm, li, lj, lli, llj):
    """Local numbering of the bodies that the step's contacts and links touch, in the order
    the sweep first touches them (contacts, then links).

    The sweep then reads and writes contiguous local copies of ``vel6`` and ``body_dyn``
    (gathered before, scattered after): a pure change of memory layout, every floating-point
    operation is the same, so results are bit-identical; but body data that the contact
    stream touches together sit together in memory whatever the user's body numbering.

    Parameters
    ----------
    loc : (nb,) int32, all -1 on entry; left with the local index of each touched body.
    perm : (nb,) int32 ; filled with the global id of each local index.
    li, lj : (n,) int32 ; lli, llj : (nl,) int32 -- the local contact and link ends.

    Returns
    -------
    int
        Number of touched bodies (local indices 0 .. k-1).
    """
    k = 0
    for a in range(n):
        li[a], k = _local_index(c_i[a], loc, perm, k)
        lj[a], k = _local_index(c_j[a], loc, perm, k)
    for m in range(nl):
        lli[m], k = _local_index(link_i[m], loc, perm, k)
        llj[m], k = _local_index(link_j[m], loc, perm, k)
    return k


@njit(cache=True, inline="always")
def _local_index(b, loc, perm, k):
    """Local index of body ``b`` (numbered ``k`` on first touch); returns it and the next k."""
    if loc[b] < 0:
        loc[b] = k
        perm[k] = b
        k += 1
    return loc[b], k
