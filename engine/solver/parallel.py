"""Parallel NLGS: domain-decomposed Gauss–Seidel on ``T`` threads (``Options.threads``).

The bodies are split into ``T`` domains along the contact stream (the broadphase emits
contacts slab by slab through space, :func:`engine.contact.broadphase.build_pairs`, and the
sweep's local body numbering follows that stream, :func:`engine.solver.nlgs.layout`): the
bodies in that order are cut where the contacts they touch reach ``s/T`` (each contact
counted half on each of its bodies, or whole on its mobile one when the other is immobile),
so the interiors come out even (:func:`partition`).
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
(each thread streams its own slab) and the impulses scattered back after.  The kernels take
them, as the serial ones do, as a :class:`~engine.solver.kernels.Contacts` named tuple, with
the groups' bounds as a :class:`Groups` one.
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit, prange

from ..stop import in_chunks
from ..threads import numba_threads

from ..model import DYN_INV_INERTIA, DYN_INV_MASS, DYN_LINE
from .chains import chains_for, link_phase
from .kernels import HOT_FACTOR, Contacts, _contact, _span, hot_list

#: The contact groups of :func:`partition` as the grouped sweeps take them: ``start``
#: (2T + 1,) int64 the groups' starts in the gathered contacts, ``mid`` (2T,) int64 where
#: each group's contacts touching an immobile body start, ``acc`` (2T, 2) the groups' Quad
#: sums of the last pass (work array).
Groups = namedtuple("Groups", "start mid acc")


@njit(cache=True, inline="always")
def _mobile(b, body_dyn):
    """Body ``b`` moves (a free or force-driven body; not fixed, nor a static wall)."""
    return body_dyn[b, DYN_INV_MASS] != 0.0 or body_dyn[b, DYN_INV_INERTIA] != 0.0


@njit(cache=True, inline="always")
def _counted(a, c_i, c_j, body_dyn):
    """Contact ``a`` counts where :func:`partition` cuts the bodies: neither body moves
    along a line (such a contact is shared), and one at least is mobile (two immobile
    bodies are not solved)."""
    i = c_i[a]
    j = c_j[a]
    if body_dyn[i, DYN_LINE] != 0.0 or body_dyn[j, DYN_LINE] != 0.0:
        return False
    return _mobile(i, body_dyn) or _mobile(j, body_dyn)


@njit(cache=True)
def partition(n, T, c_i, c_j, body_dyn, nloc, group, start, order, mid):
    """Group the ``n`` contacts (see the module docstring) and sort them by group; inside a
    group, the contacts between two mobile bodies come first (``mid``).

    Parameters
    ----------
    T : int >= 2, the number of domains.
    c_i, c_j : (n,) int32 local body indices (:func:`engine.solver.nlgs.layout`).
    body_dyn : (nloc, 8) local body rows.
    group : (n,) int32 ; start : (2T + 1,) int64 ; order : (n,) int32 -- outputs: the group
        of each contact (s interior, T + s boundary, 2T - 1 shared), CSR starts of the
        groups and the contacts sorted by group (stable: serial order inside a group,
        except that the contacts touching an immobile body go last).
    mid : (2T,) int64 -- output: group g's contacts start[g]..mid[g] are between two
        mobile bodies (swept without the guard of :func:`engine.solver.nlgs._apply`), the
        others touch an immobile body (a fixed wall or sphere that several groups touch).
    """
    ng = 2 * T
    # domain of each local body: the bodies in local order, cut where the contacts they touch
    # reach s/T, each contact between two mobile bodies counted half on each (a contact
    # between two domains then weighs the same on both sides, so the interiors come out
    # even), one with an immobile body (a fixed sphere, a static wall) whole on its mobile
    # one: the interior of that body's domain sweeps it (a heap spread on a floor of fixed
    # beads has many such contacts)
    dom = np.empty(nloc, np.int32)
    load = np.zeros(nloc, np.int64)
    total = 0
    for a in range(n):
        if _counted(a, c_i, c_j, body_dyn):
            i = c_i[a]
            j = c_j[a]
            if not _mobile(i, body_dyn):
                load[j] += 2
            elif not _mobile(j, body_dyn):
                load[i] += 2
            else:
                load[i] += 1
                load[j] += 1
            total += 2
    cuts = np.full(T, nloc, np.int64)  # local index where domain s + 1 starts
    carried = 0
    s = 0
    for b in range(nloc):
        carried += load[b]
        while s < T - 1 and carried * T >= (s + 1) * total:
            cuts[s] = b + 1
            s += 1
    d = 0
    for b in range(nloc):
        while d < T - 1 and b >= cuts[d]:
            d += 1
        if body_dyn[b, DYN_LINE] != 0.0:
            dom[b] = -2  # mobile wall: may touch every domain
        elif not _mobile(b, body_dyn):
            dom[b] = -1  # immobile: never written
        else:
            dom[b] = d
    for g in range(ng + 1):
        start[g] = 0
    n_mm = np.zeros(ng, np.int64)  # contacts between two mobile bodies, per group
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
        if di >= 0 and dj >= 0:
            n_mm[g] += 1
    for g in range(ng):
        start[g + 1] += start[g]
        mid[g] = start[g] + n_mm[g]
    fill = start[:ng].copy()
    fill_im = mid.copy()
    for a in range(n):
        g = group[a]
        if dom[c_i[a]] >= 0 and dom[c_j[a]] >= 0:
            order[fill[g]] = a
            fill[g] += 1
        else:
            order[fill_im[g]] = a
            fill_im[g] += 1


@njit(cache=True)
def gather(n, order, C, G):
    """Copy the contact arrays of ``C`` into those of ``G`` (both
    :class:`~engine.solver.kernels.Contacts`) in group order (``G.x[m] = C.x[order[m]]``)."""
    c_i, c_j, frame, w, gterm, mu, ri, rj, impulse = C
    g_i, g_j, g_frame, g_w, g_gterm, g_mu, g_ri, g_rj, g_impulse = G
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


#: Below this many grouped contacts in a pass, the groups run in turn on the calling
#: thread (the same groups in the same order, so the same result): waking the other
#: threads for each of the three phases costs more than it saves (measured on the
#: wire-under-lid test scene, 374 contacts: 50-400 µs per pass with numba's TBB threading
#: layer, about 10 µs in turn; docs/speed.md).  Read at each solve.
PARALLEL_SWEEP_MIN_CONTACTS = 4096


@njit(cache=True, inline="always")
def phases(T):
    """The race-free order of the ``T`` domains' groups (:func:`partition`), as
    (first group, count, stride) per phase: the ``T`` interiors, the even boundaries, the odd
    boundaries.  The groups of one phase share no mobile body; the shared group, last,
    runs alone."""
    return ((0, T, 1), (T, T // 2, 2), (T + 1, (T - 1) // 2, 2))


@njit(cache=True, inline="always")
def _run(lo, hi, q, C, B, relax, guard):
    """Contacts ``lo..hi`` of a group in order, with or without the immobile-body guard (a
    constant at each call site); each ‖W Δp‖² stored in ``q`` unless ``q`` is empty.
    Returns the Quad sums."""
    return _span(lo, hi, q, C, B, relax, False, guard, False, q.shape[0] > 0)


@njit(cache=True)
def _group(kind, g, start, mid, hot, q, C, B, relax):
    """Sweep group ``g`` on one thread.  ``kind`` 0: its contacts ``start[g]..start[g+1]``,
    each ‖W Δp‖² stored in ``q`` when ``q`` is not empty; returns the Quad sums.  ``kind`` 1:
    the hot contacts ``hot[start[g]..start[g+1]]`` (``start`` is then the hot list's group
    starts); returns zeros.  No LINE body is in a group (those contacts are shared).  The
    contacts from ``mid[g]`` on touch an immobile body (:func:`partition`) and run with the
    guard: a fixed wall or sphere that two domains touch is never written."""
    num = 0.0
    den = 0.0
    m = mid[g]
    if kind == 0:
        num, den = _run(start[g], m, q, C, B, relax, False)
        x, y = _run(m, start[g + 1], q, C, B, relax, True)
        num += x
        den += y
    else:
        for k in range(start[g], start[g + 1]):
            a = hot[k]
            if a < m:
                _contact(a, C, B, relax, False, False)
            else:
                _contact(a, C, B, relax, False, True)
    return num, den


@njit(cache=True)
def _group_acc(kind, g, start, mid, hot, q, C, B, relax, acc):
    """:func:`_group`, its Quad sums written to row ``g`` of ``acc``."""
    x, y = _group(kind, g, start, mid, hot, q, C, B, relax)
    acc[g, 0] = x
    acc[g, 1] = y


@njit(cache=True, parallel=True)
def _phase(kind, first, count, stride, start, mid, hot, q, C, B, relax, acc):
    """Groups first, first + stride, ... (``count`` of them) at once, one per thread."""
    for k in prange(count):
        _group_acc(kind, first + k * stride, start, mid, hot, q, C, B, relax, acc)


@njit(cache=True)
def _in_turn(kind, first, count, stride, start, mid, hot, q, C, B, relax, acc):
    """:func:`_phase` on the calling thread, group after group (the groups of one phase
    share no body: the same result)."""
    for k in range(count):
        _group_acc(kind, first + k * stride, start, mid, hot, q, C, B, relax, acc)


@njit(cache=True)
def _phases(kind, T, start, mid, hot, q, C, B, relax, acc, min_par):
    """One pass over the groups in their race-free order: the ``T`` interiors at once, the
    even boundaries at once, the odd ones, then the shared contacts on one thread (full
    kernel: LINE walls).  A pass of fewer than ``min_par`` grouped contacts
    (:data:`PARALLEL_SWEEP_MIN_CONTACTS`) runs its phases on this thread.  ``kind``,
    ``start``, ``mid``, ``hot``, ``q``: see :func:`_group`.
    Returns the Quad sums (num, den) of a full pass, summed in a fixed order."""
    ng = 2 * T
    in_turn = start[ng - 1] - start[0] < min_par
    for first, count, stride in phases(T):
        if in_turn or count == 1:
            _in_turn(kind, first, count, stride, start, mid, hot, q, C, B, relax, acc)
        elif count > 1:
            _phase(kind, first, count, stride, start, mid, hot, q, C, B, relax, acc)
    return _shared_and_sum(kind, ng, start, hot, q, C, B, relax, acc)


@njit(cache=True)
def _shared_and_sum(kind, ng, start, hot, q, C, B, relax, acc):
    """The shared group on this thread (full kernel: LINE walls), then the Quad sums of the
    pass: the shared ones, then each group's row of ``acc`` in order."""
    num = 0.0
    den = 0.0
    keep = q.shape[0] > 0
    for k in range(start[ng - 1], start[ng]):
        a = k if kind == 0 else hot[k]
        x, y = _contact(a, C, B, relax, True)
        if kind == 0 and keep:
            q[a] = x
        num += x
        den += y
    for g in range(ng - 1):
        num += acc[g, 0]
        den += acc[g, 1]
    return num, den


@njit(cache=True)
def sweep_groups(T, G, nl, C, B, L, relax, q, min_par, sweeps, nc, K):
    """One sweep of the grouped contacts ``C`` (:class:`~engine.solver.kernels.Contacts`
    gathered by group, :class:`Groups` ``G``: interiors, even boundaries, odd boundaries,
    shared) then the ``nl`` links of ``L`` on one thread (with ``nc`` >= 0, the chain
    solve of the ``nc`` chains of ``K``, ``sweeps`` the step's sweeps before this one:
    :func:`engine.solver.chains.link_phase`); returns the Quad residual of the sweep.  Each
    contact's ‖W Δp‖² goes to ``q`` unless ``q`` is empty."""
    num, den = _phases(0, T, G.start, G.mid, C.i[:0], q, C, B, relax, G.acc, min_par)
    return link_phase(num, den, sweeps, nc, K, nl, L, B, relax)


@njit(cache=True)
def iterate_groups(T, n, nl, G, C, B, L, relax, tol, max_iter, hot_sweeps, factor, q, hot,
                   hstart, min_par, done, nc, K):
    """Sweeps (:func:`sweep_groups`) until the Quad residual is below ``tol``; returns
    (iterations, residual).  With ``hot_sweeps`` > 0, after each full sweep that has not
    converged the hot contacts (:func:`engine.solver.nlgs.hot_list`, ``factor``) are swept
    ``hot_sweeps`` more times in the same race-free group order, as
    :func:`engine.solver.nlgs.iterate_hot` does on one thread.  ``q`` (n,), ``hot`` (n,)
    int32 and ``hstart`` (2T + 1,) int64 are work arrays (``q`` may be empty when
    ``hot_sweeps`` is 0); ``min_par``: see :func:`_phases`; ``done`` the step's sweeps of
    earlier calls, ``nc`` and ``K`` the chains (:func:`sweep_groups`)."""
    if n == 0 and nl == 0:
        return 0, 0.0
    res = 0.0
    for it in range(max_iter):
        res = sweep_groups(T, G, nl, C, B, L, relax, q, min_par, done + it, nc, K)
        if res < tol:
            return it + 1, res
        if hot_sweeps == 0 or n == 0:
            continue
        hot_list(n, q, factor, hot, G.start, hstart)
        for _ in range(hot_sweeps):
            _phases(1, T, hstart, G.mid, hot, q, C, B, relax, G.acc, min_par)
    return max_iter, res


def iterate_parallel(T, n, nl, C, B, L, relax, tol, max_iter, mix=None, hot_sweeps=0,
                     chains=None):
    """:func:`engine.solver.nlgs.iterate` on ``T`` domains (module docstring), its arguments
    as :func:`~engine.solver.kernels.iterate`'s.

    ``C.i, C.j`` and ``B`` are in the local numbering of
    :func:`engine.solver.nlgs.layout`.  Runs on min(T, numba's thread count) threads; the
    result depends on ``T`` only.  With ``mix`` (:func:`engine.solver.anderson.domain_mixer`)
    the sweeps are mixed as in :mod:`engine.solver.anderson` (its passes on the same
    threads).  Without it, with ``hot_sweeps`` > 0 the hot contacts are re-swept after each
    full sweep (:func:`iterate_groups`).  ``chains``: (nc, :class:`~engine.solver.chains.
    ChainWork`) of :func:`engine.solver.chains.chains_for`, the links' phase of each sweep
    (default: the plain link sweep).
    """
    if chains is None:
        chains = chains_for(False, 0, L.i, L.j)
    nc, K = chains
    T = int(T)
    body_dyn = B.dyn
    nloc = body_dyn.shape[0]
    group = np.empty(n, np.int32)
    start = np.empty(2 * T + 1, np.int64)
    mid = np.empty(2 * T, np.int64)
    order = np.empty(n, np.int32)
    partition(n, T, C.i, C.j, body_dyn, nloc, group, start, order, mid)
    gC = Contacts(np.empty(n, np.int32), np.empty(n, np.int32), np.empty((n, 9)),
                  np.empty((n, 4)), np.empty(n), np.empty(n), np.empty(n), np.empty(n),
                  np.empty((n, 3)))
    gather(n, order, C, gC)
    G = Groups(start, mid, np.zeros((2 * T, 2)))
    with numba_threads(T):
        if mix is not None:
            it, res = mix(T, n, gC, B, relax, G, PARALLEL_SWEEP_MIN_CONTACTS, chains)
        else:
            hot_sweeps = int(hot_sweeps)
            m = n if hot_sweeps > 0 else 0
            q, hot, hstart = np.empty(m), np.empty(m, np.int32), np.empty(2 * T + 1, np.int64)
            it, res = in_chunks(lambda done, m_: iterate_groups(
                T, n, nl, G, gC, B, L, relax, tol, m_, hot_sweeps, HOT_FACTOR, q, hot, hstart,
                PARALLEL_SWEEP_MIN_CONTACTS, done, nc, K), max_iter, tol, n + nl)
    scatter(n, order, gC.impulse, C.impulse)
    return it, res


__all__ = ["iterate_parallel", "partition", "iterate_groups", "sweep_groups", "Groups"]
