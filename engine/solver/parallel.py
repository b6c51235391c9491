"""Parallel NLGS: domain-decomposed Gauss–Seidel on ``T`` threads (``Options.threads``).

The bodies are split into ``T`` domains along the contact stream (the broadphase emits
contacts slab by slab through space, :func:`engine.contact.broadphase.build_pairs`, and the
sweep's local body numbering follows that stream, :func:`engine.solver.nlgs.layout`): domain
``s`` holds the bodies first touched by the ``s``-th ``1/T`` of the sphere–sphere contacts.
Each contact then falls in one group:

* **interior** ``s`` (both mobile bodies in domain ``s``, or one in ``s`` and the other
  immobile: a fixed wall or fixed sphere, which no contact ever writes);
* **boundary** ``s`` (one body in domain ``s``, the other in ``s + 1``);
* **shared**: anything else (a contact with a force- or pressure-driven wall, which may
  touch every domain, or a rare contact between non-adjacent domains).

One sweep visits the ``T`` interiors at once (one thread each: no two share a body, so no
two threads write the same body row), then the even boundaries at once, then the odd ones,
then the shared contacts and the wire links on one thread.  Inside each group the order is
the serial one, so each thread runs plain Gauss–Seidel on its domain: the convergence is
that of Gauss–Seidel with a different visiting order (measured in
``bench/bench_parallel.py``: the same sweeps to tolerance within a few per cent), unlike
Jacobi-style schemes.  The groups and the per-thread Quad sums are fixed by the data and
summed in a fixed order, so results do not depend on the thread scheduling (they depend on
``T``, and differ from the serial sweep by the visiting order, i.e. within the tolerance).

The contacts are gathered group by group into contiguous scratch arrays before the sweeps
(each thread streams its own slab) and the impulses scattered back after.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..threads import numba_threads

from ..model import DYN_INV_INERTIA, DYN_INV_MASS, DYN_LINE
from .nlgs import _contact, links_then_residual


@njit(cache=True)
def partition(n, T, c_i, c_j, body_dyn, nloc, group, start, order):
    """Group the ``n`` contacts (see the module docstring) and sort them by group.

    Parameters
    ----------
    T : int >= 2, the number of domains.
    c_i, c_j : (n,) int32 local body indices (:func:`engine.solver.nlgs.layout`).
    body_dyn : (nloc, 8) local body rows.
    group : (n,) int32 ; start : (2T + 1,) int64 ; order : (n,) int32 -- outputs: the group
        of each contact (s interior, T + s boundary, 2T - 1 shared), CSR starts of the
        groups and the contacts sorted by group (stable: serial order inside a group).
    """
    ng = 2 * T
    # domain of each local body: cut where the sphere–sphere part of the stream reaches s/T
    dom = np.empty(nloc, np.int32)
    n_ss = 0
    for a in range(n):
        if body_dyn[c_j[a], DYN_LINE] == 0.0 and body_dyn[c_j[a], DYN_INV_MASS] != 0.0:
            n_ss += 1
    cuts = np.full(T, nloc, np.int64)  # local index where domain s + 1 starts
    seen = 0
    s = 0
    for a in range(n):
        if body_dyn[c_j[a], DYN_LINE] == 0.0 and body_dyn[c_j[a], DYN_INV_MASS] != 0.0:
            while s < T - 1 and seen >= (s + 1) * n_ss // T:
                cuts[s] = max(c_i[a], c_j[a])
                s += 1
            seen += 1
    d = 0
    for b in range(nloc):
        while d < T - 1 and b >= cuts[d]:
            d += 1
        if body_dyn[b, DYN_LINE] != 0.0:
            dom[b] = -2  # mobile wall: may touch every domain
        elif body_dyn[b, DYN_INV_MASS] == 0.0 and body_dyn[b, DYN_INV_INERTIA] == 0.0:
            dom[b] = -1  # immobile: never written
        else:
            dom[b] = d
    for g in range(ng + 1):
        start[g] = 0
    for a in range(n):
        di = dom[c_i[a]]
        dj = dom[c_j[a]]
        if di == -2 or dj == -2:
            g = ng - 1
        elif di == -1 and dj == -1:
            g = 0
        elif di == -1:
            g = dj
        elif dj == -1 or di == dj:
            g = di
        elif di - dj == 1 or dj - di == 1:
            g = T + min(di, dj)
        else:
            g = ng - 1
        group[a] = g
        start[g + 1] += 1
    for g in range(ng):
        start[g + 1] += start[g]
    fill = start[:ng].copy()
    for a in range(n):
        g = group[a]
        order[fill[g]] = a
        fill[g] += 1


@njit(cache=True)
def gather(n, order, c_i, c_j, frame, w, gterm, mu, ri, rj, impulse,
           g_i, g_j, g_frame, g_w, g_gterm, g_mu, g_ri, g_rj, g_impulse):
    """Copy the contact arrays in group order (``g_*[m] = *[order[m]]``)."""
    for m in range(n):
        a = order[m]
        g_i[m] = c_i[a]
        g_j[m] = c_j[a]
        for q in range(9):
            g_frame[m, q] = frame[a, q]
        for q in range(4):
            g_w[m, q] = w[a, q]
        g_gterm[m] = gterm[a]
        g_mu[m] = mu[a]
        g_ri[m] = ri[a]
        g_rj[m] = rj[a]
        for q in range(3):
            g_impulse[m, q] = impulse[a, q]


@njit(cache=True)
def scatter(n, order, g_impulse, impulse):
    """Impulses back to the contact buffers' order."""
    for m in range(n):
        a = order[m]
        for q in range(3):
            impulse[a, q] = g_impulse[m, q]


@njit(cache=True)
def _group_sweep(lo, hi, c_i, c_j, frame, w, gterm, mu, ri, rj, impulse, body_dyn, vel6, relax):
    num = 0.0
    den = 0.0
    for a in range(lo, hi):
        # no LINE body in a group (those contacts are shared); guard: a fixed wall shared
        # by two domains is never written
        x, y = _contact(a, c_i, c_j, frame, w, gterm, mu, ri, rj, impulse, body_dyn, vel6,
                        relax, False, True)
        num += x
        den += y
    return num, den


@njit(cache=True, parallel=True)
def _phase(first, count, stride, start, c_i, c_j, frame, w, gterm, mu, ri, rj, impulse,
           body_dyn, vel6, relax, acc):
    """Groups first, first + stride, ... (``count`` of them) at once, one per thread; each
    writes its Quad sums to its own row of ``acc``."""
    for k in prange(count):
        g = first + k * stride
        x, y = _group_sweep(start[g], start[g + 1], c_i, c_j, frame, w, gterm, mu, ri, rj,
                            impulse, body_dyn, vel6, relax)
        acc[g, 0] = x
        acc[g, 1] = y


@njit(cache=True)
def sweep_groups(T, start, c_i, c_j, frame, w, gterm, mu, ri, rj, impulse, body_dyn, vel6, relax,
                 nl, link_i, link_j, l_normal, wl, l_unilateral, l_impulse, l_order, acc):
    """One sweep of the grouped contacts (interiors, even boundaries, odd boundaries,
    shared) then the links; returns the Quad residual of the sweep."""
    ng = 2 * T
    nbd = T - 1
    _phase(0, T, 1, start, c_i, c_j, frame, w, gterm, mu, ri, rj, impulse, body_dyn, vel6,
           relax, acc)
    for parity in range(2):
        cnt = (nbd - parity + 1) // 2
        if cnt == 1:
            g = T + parity
            x, y = _group_sweep(start[g], start[g + 1], c_i, c_j, frame, w, gterm, mu, ri, rj,
                                impulse, body_dyn, vel6, relax)
            acc[g, 0] = x
            acc[g, 1] = y
        elif cnt > 1:
            _phase(T + parity, cnt, 2, start, c_i, c_j, frame, w, gterm, mu, ri, rj, impulse,
                   body_dyn, vel6, relax, acc)
    num = 0.0
    den = 0.0
    for a in range(start[ng - 1], start[ng]):  # shared: full serial kernel (LINE walls)
        x, y = _contact(a, c_i, c_j, frame, w, gterm, mu, ri, rj, impulse, body_dyn, vel6,
                        relax, True)
        num += x
        den += y
    for g in range(ng - 1):
        num += acc[g, 0]
        den += acc[g, 1]
    return links_then_residual(num, den, nl, link_i, link_j, l_normal, wl, l_unilateral,
                               l_impulse, body_dyn, vel6, relax, l_order)


@njit(cache=True)
def iterate_groups(T, n, start, c_i, c_j, frame, w, gterm, mu, ri, rj, impulse, body_dyn,
                   vel6, relax, tol, max_iter, nl, link_i, link_j, l_normal, wl,
                   l_unilateral, l_impulse, l_order, acc):
    """Sweeps (:func:`sweep_groups`) until the Quad residual is below ``tol``; returns
    (iterations, residual)."""
    if n == 0 and nl == 0:
        return 0, 0.0
    res = 0.0
    for it in range(max_iter):
        res = sweep_groups(T, start, c_i, c_j, frame, w, gterm, mu, ri, rj, impulse, body_dyn,
                           vel6, relax, nl, link_i, link_j, l_normal, wl, l_unilateral,
                           l_impulse, l_order, acc)
        if res < tol:
            return it + 1, res
    return max_iter, res


def iterate_parallel(T, n, c_i, c_j, frame, w, gterm, mu, ri, rj, impulse, body_dyn, vel6,
                     relax, tol, max_iter, nl, link_i, link_j, l_normal, wl, l_unilateral,
                     l_impulse, l_order, anderson=0, workspace=None):
    """:func:`engine.solver.nlgs.iterate` on ``T`` domains (module docstring).

    ``c_i, c_j, body_dyn, vel6`` are in the local numbering of
    :func:`engine.solver.nlgs.layout`.  Runs on min(T, numba's thread count) threads; the
    result depends on ``T`` only.  With ``anderson = m > 0`` the sweeps are mixed as in
    :mod:`engine.solver.anderson` (its passes on the same threads), with the
    history buffers of ``workspace``.
    """
    T = int(T)
    nloc = body_dyn.shape[0]
    group = np.empty(n, np.int32)
    start = np.empty(2 * T + 1, np.int64)
    order = np.empty(n, np.int32)
    partition(n, T, c_i, c_j, body_dyn, nloc, group, start, order)
    g_i = np.empty(n, np.int32)
    g_j = np.empty(n, np.int32)
    g_frame = np.empty((n, 9))
    g_w = np.empty((n, 4))
    g_gterm = np.empty(n)
    g_mu = np.empty(n)
    g_ri = np.empty(n)
    g_rj = np.empty(n)
    g_imp = np.empty((n, 3))
    gather(n, order, c_i, c_j, frame, w, gterm, mu, ri, rj, impulse,
           g_i, g_j, g_frame, g_w, g_gterm, g_mu, g_ri, g_rj, g_imp)
    acc = np.zeros((2 * T, 2))
    with numba_threads(T):
        if anderson > 0:
            from .anderson import run_anderson

            it, res = run_anderson(workspace, anderson, n, n, g_i, g_j, g_frame, g_w, g_gterm,
                                   g_mu, g_ri, g_rj, g_imp, body_dyn, vel6, relax, tol, max_iter,
                                   nl, link_i, link_j, l_normal, wl, l_unilateral, l_impulse,
                                   l_order, T, start, acc)
        else:
            it, res = iterate_groups(T, n, start, g_i, g_j, g_frame, g_w, g_gterm, g_mu, g_ri,
                                     g_rj, g_imp, body_dyn, vel6, relax, tol, max_iter, nl,
                                     link_i, link_j, l_normal, wl, l_unilateral, l_impulse,
                                     l_order, acc)
    scatter(n, order, g_imp, impulse)
    return it, res


__all__ = ["iterate_parallel", "partition", "iterate_groups", "sweep_groups"]
