"""The position correction of a step: overlaps removed without adding energy.

The velocity Signorini condition of the NLGS (``u_n + max(g_m, 0)/h >= 0``,
:mod:`engine.solver.local`) holds an overlap but never pushes it out, and a step solved to a
finite ``tol`` leaves a small closing velocity behind: what each step leaves accumulates
(docs/tradeoff.md).  Light bodies sink furthest: a wire bead pressed by a tense wire into
the grains reached 40-49 % of its radius in a triaxial test.

After the step's positions q_{i+1} are set, :func:`correct_positions` moves the bodies so
that no contact overlaps by more than ``Options.overlap_tol`` of its smaller sphere radius:
the post-stabilization of Cline & Pai (2003), a split impulse.  It solves, by projected
Gauss–Seidel on the step's contacts (normal direction only, frictionless), the linear
complementarity problem

    g + W λ >= 0,   λ >= 0,   λ · (g + W λ) = 0,      Δq = M⁻¹ H λ,

with g the contacts' gaps at q_{i+1} (linearized in the step's frames: g_m + θ h u_n) and
W = Hᵀ M⁻¹ H.  Only positions move; velocities, impulses and the warm start are the step's,
so the correction adds no kinetic energy (a pseudo-impulse, not an impulse).  A contact is
pushed out to exactly zero overlap; one whose overlap is within the tolerance is left as it
is (no correction, no cost beyond the one look at its gap).  Imposed walls do not move; a
driven wall (pressure or force, LINE) moves along its line by its share (holding it
instead threw a light bead pinched between the top plate and a grain out of a sample at
4 m/s).  The wire's links keep their lengths to first order.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ..laws import LOOSE_WIRE
from ..model import DYN_INV_MASS, DYN_LINE, DYN_LX, DYN_LY, DYN_LZ
from .kernels import _line_factor

__all__ = ["correct_positions", "project"]


@njit(cache=True)
def _share(body_dyn, b, nx, ny, nz):
    """The inverse mass of body b along n in the projection: a sphere's; a driven wall's
    (LINE) along its line, (n·l)² / m; 0 for an imposed one."""
    return body_dyn[b, DYN_INV_MASS] * _line_factor(body_dyn, b, nx, ny, nz)


@njit(cache=True)
def _move(b, nx, ny, nz, d, body_dyn, dx):
    """Move body b by its share M⁻¹ n d of the pseudo-impulse d (a driven wall along its
    line)."""
    im = body_dyn[b, DYN_INV_MASS]
    if im == 0.0:
        return
    if body_dyn[b, DYN_LINE] != 0.0:
        lx = body_dyn[b, DYN_LX]
        ly = body_dyn[b, DYN_LY]
        lz = body_dyn[b, DYN_LZ]
        s = im * d * (nx * lx + ny * ly + nz * lz)
        dx[b, 0] += s * lx
        dx[b, 1] += s * ly
        dx[b, 2] += s * lz
    else:
        dx[b, 0] += im * d * nx
        dx[b, 1] += im * d * ny
        dx[b, 2] += im * d * nz


@njit(cache=True)
def project(n, ci, cj, frame, gap, ri, rj, body_dyn, vel6, h_theta, rel_tol, max_sweeps,
            dx, lam, active, nl, li, lj, lkeep, lnormal):
    """Projected Gauss–Seidel on the overlaps of the ``n`` contacts at the step's end.

    ``gap`` (n,) the gaps at q_m [m]; the gap at q_{i+1} is g_m + θ h u_n (``h_theta``,
    ``vel6`` the solved velocities).  A contact is active when its end gap is below
    −``rel_tol`` × its smaller radius (r_j = 0 for a wall: the sphere's), or once it has a
    pseudo-impulse.  Each sweep over the active contacts sets λ_α = max(0, λ_α − r_α/W_nn),
    r_α the gap with the corrections so far, and moves the two bodies by M⁻¹ n Δλ (into
    ``dx`` (nb, 3), zeroed by the caller).  Contacts that the corrections close join the
    active set at the next sweep.  Stops when no active contact is below −``rel_tol`` × its
    radius, or after ``max_sweeps``.  Returns (sweeps, the largest remaining overlap
    relative to the smaller radius, active contacts).

    The ``nl`` wire links ``li``–``lj`` with ``lkeep`` = 1 keep their lengths (to first
    order: n_l · (Δx_i − Δx_j) = 0, ``lnormal`` (nl, 3) their unit vectors from j to i),
    a bilateral row after the contacts in each sweep: a bead pushed out of a grain takes
    its neighbours along instead of stretching its links, whose elastic energy (or, for a
    rigid wire, whose constraint) the correction would otherwise change."""
    n_act = 0
    for a in range(n):
        r = ri[a] if rj[a] <= 0.0 else min(ri[a], rj[a])
        i = ci[a]
        j = cj[a]
        un = (frame[a, 0] * (vel6[i, 0] - vel6[j, 0]) + frame[a, 1] * (vel6[i, 1] - vel6[j, 1])
              + frame[a, 2] * (vel6[i, 2] - vel6[j, 2]))
        g = gap[a] + h_theta * un
        gap[a] = g                        # the end gap, kept for the sweeps (the caller's copy)
        lam[a] = 0.0
        active[a] = 1 if g < -rel_tol * r else 0
        n_act += active[a]
    if n_act == 0:
        return 0, 0.0, 0
    worst = 0.0
    sweeps = 0
    for sweep in range(max_sweeps):
        sweeps = sweep + 1
        worst = 0.0
        for a in range(n):
            i = ci[a]
            j = cj[a]
            nx = frame[a, 0]
            ny = frame[a, 1]
            nz = frame[a, 2]
            g = gap[a] + (nx * (dx[i, 0] - dx[j, 0]) + ny * (dx[i, 1] - dx[j, 1])
                          + nz * (dx[i, 2] - dx[j, 2]))
            r = ri[a] if rj[a] <= 0.0 else min(ri[a], rj[a])
            if active[a] == 0:
                if g >= -rel_tol * r:
                    continue
                active[a] = 1
                n_act += 1
            w = _share(body_dyn, i, nx, ny, nz) + _share(body_dyn, j, nx, ny, nz)
            if w <= 0.0:
                continue
            new = lam[a] - g / w
            if new < 0.0:
                new = 0.0
            d = new - lam[a]
            if d != 0.0:
                lam[a] = new
                _move(i, nx, ny, nz, d, body_dyn, dx)
                _move(j, nx, ny, nz, -d, body_dyn, dx)
            if -g / r > worst:
                worst = -g / r
        for k in range(nl):
            if lkeep[k] == 0:
                continue
            i = li[k]
            j = lj[k]
            nx = lnormal[k, 0]
            ny = lnormal[k, 1]
            nz = lnormal[k, 2]
            w = _share(body_dyn, i, nx, ny, nz) + _share(body_dyn, j, nx, ny, nz)
            if w <= 0.0:
                continue
            c = (nx * (dx[i, 0] - dx[j, 0]) + ny * (dx[i, 1] - dx[j, 1])
                 + nz * (dx[i, 2] - dx[j, 2]))
            if c != 0.0:
                _move(i, nx, ny, nz, -c / w, body_dyn, dx)
                _move(j, nx, ny, nz, c / w, body_dyn, dx)
        if worst <= rel_tol:
            break
    return sweeps, worst, n_act


def correct_positions(model, state) -> tuple[int, int]:
    """The position correction stage of :func:`engine.step` (module doc), after the
    positions q_{i+1} are set: no-op when ``Options.overlap_tol`` is None.  Returns
    (sweeps, active contacts)."""
    o = model.options
    tol = o.overlap_tol
    c = state.contacts_buf
    n = c.count
    if tol is None or n == 0:
        return 0, 0
    ws = state.workspace
    nb = model.n_bodies
    if ws.projection is None or ws.projection[0].shape[0] != nb or ws.projection[1].size < n:
        cap = max(n, 16) * 2
        ws.projection = (np.zeros((nb, 3)), np.zeros(cap), np.zeros(cap, np.int8),
                         np.zeros(cap))
    dx, lam, active, gap = ws.projection
    dx[:] = 0.0
    gap[:n] = c.gap[:n]
    nl = model.n_links
    if nl:
        keep = ((~state.link_broken) & (model.link_law != LOOSE_WIRE)).astype(np.int8)
        d = state.position[model.link_i] - state.position[model.link_j]
        d /= np.maximum(np.linalg.norm(d, axis=1), 1e-300)[:, None]
    else:
        keep, d = np.zeros(0, np.int8), np.zeros((0, 3))
    sweeps, _, n_act = project(n, c.i, c.j, c.frame, gap, c.ri, c.rj, model.body_dyn,
                               state.vel6, o.theta * o.dt, tol, o.overlap_sweeps, dx, lam,
                               active, nl, model.link_i, model.link_j, keep, d)
    if n_act:
        state.position += dx
    return sweeps, n_act
