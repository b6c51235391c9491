"""Anderson acceleration of the NLGS iterations (``Options.anderson``, default depth 4).

One NLGS sweep (contacts, then links) is a fixed-point map p ↦ G(p) on the impulses of the
step.  On dense packings Gauss–Seidel converges slowly: its error behaves like a diffusion
across the packing, so the sweeps to a given tolerance grow with the square of the number
of grain layers (measured on the 1 000-sphere deposit of ``bench/peers``: 558 sweeps to
tol 1e-4 in a step of the settling pile, whatever the contact order; over-relaxation
ω = 1.6 with re-projection, 265).

Anderson mixing (type II, depth m) keeps the last m differences of iterates
ΔG_k = G(p_{k+1}) − G(p_k) and of residuals ΔF_k = f_{k+1} − f_k, with
f = W (G(p) − p) the local-velocity change of the sweep (the quantity of the Quad norm,
W = diag(W_nn, W_tt, W_tt) per contact, W per link), and takes as next iterate

    p ← Π( G(p) − ΔG γ ),   γ = argmin ‖f − ΔF γ‖²,

with Π the projection of each contact impulse on its Coulomb cone (p_n ≥ 0,
‖p_T‖ ≤ μ p_n) and of each unilateral link impulse on λ ≥ 0.  The body velocities are
moved by the impulse change, so the next sweep starts from a consistent state.  The
convergence test is untouched: the step stops when a plain Gauss–Seidel sweep changes
the local velocities by less than ``tol`` (Quad norm), so the accepted solution satisfies
the same criterion as without acceleration; only the path to it is shorter.

The history restarts when a sweep's residual grows by more than ``RESTART_GROWTH``
(the mixing then extrapolated across a change of contact status), and the mixing stops for
the rest of the step after ``STALL_MIXINGS`` mixings in a row without a new lowest
residual (the remaining sweeps are plain Gauss–Seidel).  The small normal
equations are solved with a Tikhonov shift of 1e-10 of their trace.

With ``T > 1`` threads (``Options.threads``) the mixing runs on the threads too: the
history pass on ``T`` contiguous chunks of the contacts (partial Gram sums added in chunk
order, so the result depends on ``T`` only), and the update, which moves body velocities,
group by group in the race-free phases of the parallel sweep
(:func:`engine.solver.parallel.sweep_groups`).  With one thread the passes are the serial
loops, bit for bit.

Work arrays are kept in :class:`Workspace` (grown on demand, never shrunk), so a step
allocates nothing: m × (3 n_contacts + n_links) × 2 floats of history.  The kernels take
them as a :class:`History` named tuple, beside the sweep's
:class:`~engine.solver.kernels.Contacts`, :class:`~engine.solver.kernels.Bodies` and
:class:`~engine.solver.kernels.Links`.
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit, prange

from ..stop import in_chunks
from .local import project_disk, tension
from .chains import chains_for, link_phase
from .kernels import _apply, _apply_link, sweep
from .parallel import Groups, phases, sweep_groups

#: The mixing's work arrays (:class:`Workspace`) as :func:`iterate_anderson` takes them:
#: ``dg, df`` (m, cap, 3) and ``dgl, dfl`` (m, cap_l) the history columns ΔG, ΔF of the
#: contacts and links; ``x, g, f`` (cap, 3) and ``xl, gl, fl`` (cap_l,) the iterate the
#: last sweep started from, the previous sweep's result and the previous residual;
#: ``gram, mat`` (m, m), ``rhs, gamma`` (m,) the normal equations; ``loop`` (8,) the
#: loop's counters between two chunks of sweeps.
History = namedtuple("History", "dg df dgl dfl x g f xl gl fl gram rhs mat gamma loop")

#: Sweeps between two mixings.  A mixing costs about 1.3 sweeps on the 1 000-sphere
#: deposit (a streaming pass over the history and a pass that moves the velocities); one
#: every 3 sweeps gave the shortest time to rest there (mixing every 1, 2, 3 or 5 sweeps:
#: 44.7, 34.9, 28.0, 29.9 s against 43.1 s plain, one run each).
PERIOD = 3

#: Restart the mixing history when a sweep's residual exceeds this factor times the
#: previous one.
RESTART_GROWTH = 4.0

#: Stop mixing for the rest of the step (plain Gauss–Seidel) after this many mixings in a
#: row that brought no new lowest residual.
STALL_MIXINGS = 10


class Workspace:
    """History buffers of the mixing (capacity in contacts and links, depth m)."""

    def __init__(self):
        self.m = -1
        self.cap_c = -1
        self.cap_l = -1

    def ensure(self, m: int, n: int, nl: int) -> "Workspace":
        if m != self.m or n > self.cap_c or nl > self.cap_l:
            cc = max(n, int(1.5 * max(self.cap_c, 0)), 64)
            cl = max(nl, int(1.5 * max(self.cap_l, 0)), 1)
            self.m, self.cap_c, self.cap_l = m, cc, cl
            self.dg = np.empty((m, cc, 3))
            self.df = np.empty((m, cc, 3))
            self.dgl = np.empty((m, cl))
            self.dfl = np.empty((m, cl))
            self.x = np.empty((cc, 3))       # iterate the last sweep started from
            self.g = np.empty((cc, 3))       # the previous sweep's result
            self.f = np.empty((cc, 3))       # the previous residual vector
            self.xl = np.empty(cl)
            self.gl = np.empty(cl)
            self.fl = np.empty(cl)
            self.gram = np.empty((m, m))
            self.rhs = np.empty(m)
            self.gamma = np.empty(m)
            self.mat = np.empty((m, m))
            self.acc = np.zeros((2, 2))  # unused Quad sums of the serial path
        if not hasattr(self, "loop"):
            self.loop = np.zeros(8)  # the loop's counters between two chunks of sweeps
        return self

    def history(self) -> History:
        """The work arrays as :func:`iterate_anderson` takes them."""
        return History(self.dg, self.df, self.dgl, self.dfl, self.x, self.g, self.f, self.xl,
                       self.gl, self.fl, self.gram, self.rhs, self.mat, self.gamma, self.loop)


@njit(cache=True)
def _solve_small(k, gram, rhs, mat, gamma):
    """γ = (G + ε tr(G)/k I)⁻¹ b for the leading k×k block (Gaussian elimination with
    partial pivoting; k <= m is tiny).  Returns False when the system is singular."""
    tr = 0.0
    for a in range(k):
        tr += gram[a, a]
    if tr <= 0.0:
        return False
    shift = 1e-10 * tr / k
    for a in range(k):
        for b in range(k):
            mat[a, b] = gram[a, b]
        mat[a, a] += shift
        gamma[a] = rhs[a]
    for col in range(k):
        piv = col
        big = abs(mat[col, col])
        for r in range(col + 1, k):
            if abs(mat[r, col]) > big:
                big = abs(mat[r, col])
                piv = r
        if big == 0.0:
            return False
        if piv != col:
            for b in range(k):
                t = mat[col, b]
                mat[col, b] = mat[piv, b]
                mat[piv, b] = t
            t = gamma[col]
            gamma[col] = gamma[piv]
            gamma[piv] = t
        for r in range(col + 1, k):
            fct = mat[r, col] / mat[col, col]
            if fct != 0.0:
                for b in range(col, k):
                    mat[r, b] -= fct * mat[col, b]
                gamma[r] -= fct * gamma[col]
    for col in range(k - 1, -1, -1):
        s = gamma[col]
        for b in range(col + 1, k):
            s -= mat[col, b] * gamma[b]
        gamma[col] = s / mat[col, col]
    return True


@njit(cache=True, inline="always")
def _history_range(a0, a1, c, col, k, w, impulse, x, f, g, df, dg, pg, pr):
    """Contacts a0..a1 of the history pass: new residual f = W (G(x) − x), history columns
    ``col`` of ΔF and ΔG, and their partial Gram row and right-hand side in row ``c`` of
    ``pg``, ``pr``."""
    for b in range(k):
        pg[c, b] = 0.0
        pr[c, b] = 0.0
    for a in range(a0, a1):
        wn = w[a, 0]
        wt = w[a, 1]
        f0 = wn * (impulse[a, 0] - x[a, 0])
        f1 = wt * (impulse[a, 1] - x[a, 1])
        f2 = wt * (impulse[a, 2] - x[a, 2])
        d0 = f0 - f[a, 0]
        d1 = f1 - f[a, 1]
        d2 = f2 - f[a, 2]
        df[col, a, 0] = d0
        df[col, a, 1] = d1
        df[col, a, 2] = d2
        f[a, 0] = f0
        f[a, 1] = f1
        f[a, 2] = f2
        for d in range(3):
            dg[col, a, d] = impulse[a, d] - g[a, d]
            g[a, d] = impulse[a, d]
        for b in range(k):
            e0 = df[b, a, 0]
            e1 = df[b, a, 1]
            e2 = df[b, a, 2]
            pg[c, b] += d0 * e0 + d1 * e1 + d2 * e2
            pr[c, b] += e0 * f0 + e1 * f1 + e2 * f2


@njit(cache=True, inline="always")
def _start_range(a0, a1, w, impulse, x, f, g):
    """Contacts a0..a1 of the first history pass: f = W (G(x) − x), g = G(x)."""
    for a in range(a0, a1):
        wn = w[a, 0]
        wt = w[a, 1]
        f[a, 0] = wn * (impulse[a, 0] - x[a, 0])
        f[a, 1] = wt * (impulse[a, 1] - x[a, 1])
        f[a, 2] = wt * (impulse[a, 2] - x[a, 2])
        for d in range(3):
            g[a, d] = impulse[a, d]


@njit(cache=True, inline="always")
def _copy_range(a0, a1, impulse, x):
    """x ← G(x) on contacts a0..a1."""
    for a in range(a0, a1):
        for d in range(3):
            x[a, d] = impulse[a, d]


@njit(cache=True, inline="always")
def _mix_range(a0, a1, k, gamma, dg, C, B, x, guard):
    """x ← Π(G(x) − ΔG γ) on contacts a0..a1 of ``C``, the body velocities of ``B`` moved by
    the change.  ``guard``: write mobile bodies only (a parallel group,
    :func:`engine.solver.kernels._apply`)."""
    c_i, c_j, frame, w, _, mu, ri, rj, impulse = C
    body_dyn, vel6 = B
    for a in range(a0, a1):
        pn = impulse[a, 0]
        pt = impulse[a, 1]
        ps = impulse[a, 2]
        if w[a, 0] > 0.0:
            for b in range(k):
                gb = gamma[b]
                pn -= gb * dg[b, a, 0]
                pt -= gb * dg[b, a, 1]
                ps -= gb * dg[b, a, 2]
            if pn < 0.0:
                pn = 0.0
            pt, ps = project_disk(pt, ps, mu[a] * pn)
            dpn = pn - impulse[a, 0]
            dpt = pt - impulse[a, 1]
            dps = ps - impulse[a, 2]
            if dpn != 0.0 or dpt != 0.0 or dps != 0.0:
                tx = frame[a, 3]
                ty = frame[a, 4]
                tz = frame[a, 5]
                sx = frame[a, 6]
                sy = frame[a, 7]
                sz = frame[a, 8]
                px = dpn * frame[a, 0] + dpt * tx + dps * sx
                py = dpn * frame[a, 1] + dpt * ty + dps * sy
                pz = dpn * frame[a, 2] + dpt * tz + dps * sz
                if guard:
                    _apply(c_i[a], c_j[a], ri[a], rj[a], px, py, pz, dpt, dps, tx, ty, tz,
                           sx, sy, sz, body_dyn, vel6, True, True)
                else:
                    _apply(c_i[a], c_j[a], ri[a], rj[a], px, py, pz, dpt, dps, tx, ty, tz,
                           sx, sy, sz, body_dyn, vel6, True)
            impulse[a, 0] = pn
            impulse[a, 1] = pt
            impulse[a, 2] = ps
        x[a, 0] = pn
        x[a, 1] = pt
        x[a, 2] = ps


@njit(cache=True)
def _history_chunk(c, T, n, col, k, have_prev, w, impulse, x, f, g, df, dg, pg, pr):
    """The history pass (or the first one, ``have_prev`` False) on chunk ``c`` of ``T``
    contiguous chunks of the contacts; partial sums in row ``c`` of ``pg``, ``pr``."""
    a0 = (n * c) // T
    a1 = (n * (c + 1)) // T
    if have_prev:
        _history_range(a0, a1, c, col, k, w, impulse, x, f, g, df, dg, pg, pr)
    else:
        _start_range(a0, a1, w, impulse, x, f, g)


@njit(cache=True, parallel=True)
def _history_chunks(T, n, col, k, have_prev, w, impulse, x, f, g, df, dg, pg, pr):
    """:func:`_history_chunk` on the ``T`` chunks at once."""
    for c in prange(T):
        _history_chunk(c, T, n, col, k, have_prev, w, impulse, x, f, g, df, dg, pg, pr)


@njit(cache=True)
def _history(par, T, n, col, k, have_prev, w, impulse, x, f, g, df, dg, pg, pr):
    """:func:`_history_chunk` on the ``T`` chunks, at once when ``par``, else in turn (the
    same sums: each chunk has its own row)."""
    if par:
        _history_chunks(T, n, col, k, have_prev, w, impulse, x, f, g, df, dg, pg, pr)
    else:
        for c in range(T):
            _history_chunk(c, T, n, col, k, have_prev, w, impulse, x, f, g, df, dg, pg, pr)


@njit(cache=True, parallel=True)
def _copy_chunks(T, n, impulse, x):
    for c in prange(T):
        _copy_range((n * c) // T, (n * (c + 1)) // T, impulse, x)


@njit(cache=True, parallel=True)
def _mix_phase(first, count, stride, start, k, gamma, dg, C, B, x):
    """The mixing update of groups first, first + stride, ... at once, one per thread."""
    for q in prange(count):
        gi = first + q * stride
        _mix_range(start[gi], start[gi + 1], k, gamma, dg, C, B, x, True)


@njit(cache=True)
def _mix_groups(par, T, start, k, gamma, dg, C, B, x):
    """The mixing update on the contact groups of :func:`engine.solver.parallel.partition`,
    in the phases of its sweep (no two threads write the same body); each phase on the
    threads when ``par``, else its groups in turn (the same result)."""
    ng = 2 * T
    for first, count, stride in phases(T):
        if par and count > 1:
            _mix_phase(first, count, stride, start, k, gamma, dg, C, B, x)
        else:
            for q in range(count):
                gi = first + q * stride
                _mix_range(start[gi], start[gi + 1], k, gamma, dg, C, B, x, True)
    _mix_range(start[ng - 1], start[ng], k, gamma, dg, C, B, x, False)


@njit(cache=True)
def iterate_anderson(n, n_pair, nl, C, B, L, relax, tol, max_iter, m, period, H, T, G, min_par,
                     it0, it1, nc, K):
    """:func:`engine.solver.kernels.iterate` (its first nine arguments) with Anderson mixing
    of depth ``m`` every ``period`` sweeps (module docstring), on the work arrays ``H``
    (:class:`History`).  ``T`` = 1: serial sweeps (:func:`engine.solver.kernels.sweep_all`);
    ``T`` > 1: the domain-decomposed sweeps of :func:`engine.solver.parallel.sweep_groups`
    on contacts gathered by group (``G``: its :class:`~engine.solver.parallel.Groups`;
    ``min_par``: its :data:`engine.solver.parallel.PARALLEL_SWEEP_MIN_CONTACTS`).

    Sweeps ``it0`` to ``it1`` - 1 of the ``max_iter`` of the step: a call with ``it0`` > 0
    goes on from the counters the previous one left in ``H.loop`` (8,) (the history columns
    are in the work arrays), so chunks of sweeps give the result of one call, bit for bit
    (:func:`engine.stop.in_chunks`).  ``nc``, ``K``: the links' phase of each sweep
    (:func:`engine.solver.chains.link_phase`: the chain solve with ``nc`` >= 0, else the
    plain link sweep); the mixing then mixes the chains' answers as it mixes the links'.
    Returns ``(iterations of this call, residual)``."""
    if n == 0 and nl == 0:
        return 0, 0.0
    dg, df, dgl, dfl, x, g, f, xl, gl, fl, gram, rhs, mat, gamma, loop = H
    w = C.w
    impulse = C.impulse
    body_dyn, vel6 = B
    link_i, link_j, l_normal, wl, l_unilateral, l_impulse, _ = L
    start = G.start
    # the passes on threads only where a pass of the sweep is (PARALLEL_SWEEP_MIN_CONTACTS)
    par = T > 1 and start[2 * T - 1] - start[0] >= min_par
    pg = np.zeros((T, m))  # per-chunk partial Gram rows and right-hand sides
    pr = np.zeros((T, m))
    if it0 == 0:
        for a in range(n):
            for d in range(3):
                x[a, d] = impulse[a, d]
        for l in range(nl):
            xl[l] = l_impulse[l]
        k = 0          # history columns filled
        head = 0       # next column to overwrite (ring)
        have_prev = False
        prev_res = np.inf
        best = np.inf
        stall = 0
        mixing = True
    else:
        k = int(loop[0])
        head = int(loop[1])
        have_prev = loop[2] != 0.0
        prev_res = loop[3]
        best = loop[4]
        stall = int(loop[5])
        mixing = loop[6] != 0.0
    res = 0.0
    for it in range(it0, min(it1, max_iter)):
        if T > 1:
            res = sweep_groups(T, G, nl, C, B, L, relax, rhs[:0], min_par, it, nc, K)
        else:
            num, den = sweep(n, n_pair, C, B, relax)
            res = link_phase(num, den, it, nc, K, nl, L, B, relax)
        if res < tol or it == max_iter - 1:
            return it + 1 - it0, res
        if res > RESTART_GROWTH * prev_res:
            k = 0
            head = 0
            have_prev = False
        prev_res = res
        if not mixing or (it + 1) % period != 0:
            continue
        if res < best:
            best = res
            stall = 0
        else:
            stall += 1
            if stall >= STALL_MIXINGS:
                mixing = False  # the mixing does not help this step: plain sweeps on
                continue
        # new residual f = W (G(x) - x); history column from the previous (g, f); the Gram
        # row of the new column and the right-hand side ΔFᵀ f, all in one pass
        if have_prev:
            col = head
            if k < m:
                k += 1
            head = (head + 1) % m
            if T > 1:
                _history(par, T, n, col, k, True, w, impulse, x, f, g, df, dg, pg, pr)
            else:
                _history_range(0, n, 0, col, k, w, impulse, x, f, g, df, dg, pg, pr)
            for b in range(k):
                gram[col, b] = 0.0
                rhs[b] = 0.0
                for c in range(T):
                    gram[col, b] += pg[c, b]
                    rhs[b] += pr[c, b]
            for l in range(nl):
                f0 = wl[l, 0] * (l_impulse[l] - xl[l])
                d0 = f0 - fl[l]
                dfl[col, l] = d0
                fl[l] = f0
                dgl[col, l] = l_impulse[l] - gl[l]
                gl[l] = l_impulse[l]
                for b in range(k):
                    gram[col, b] += d0 * dfl[b, l]
                    rhs[b] += dfl[b, l] * f0
            for b in range(k):
                gram[b, col] = gram[col, b]
        else:
            if T > 1:
                _history(par, T, n, 0, 0, False, w, impulse, x, f, g, df, dg, pg, pr)
            else:
                _start_range(0, n, w, impulse, x, f, g)
            for l in range(nl):
                fl[l] = wl[l, 0] * (l_impulse[l] - xl[l])
                gl[l] = l_impulse[l]
            have_prev = True
        mixed = k > 0 and _solve_small(k, gram, rhs, mat, gamma)
        if not mixed:
            # x <- G(x): nothing to change
            if par:
                _copy_chunks(T, n, impulse, x)
            else:
                _copy_range(0, n, impulse, x)
            for l in range(nl):
                xl[l] = l_impulse[l]
            continue
        # x <- Π(G(x) - ΔG γ), velocities moved by the change
        if T > 1:
            _mix_groups(par, T, start, k, gamma, dg, C, B, x)
        else:
            _mix_range(0, n, k, gamma, dg, C, B, x, False)
        for l in range(nl):
            lam = l_impulse[l]
            if wl[l, 1] != 0.0:
                for b in range(k):
                    lam -= gamma[b] * dgl[b, l]
                if l_unilateral[l] != 0:
                    lam = tension(lam)
                dl = lam - l_impulse[l]
                if dl != 0.0:
                    _apply_link(link_i[l], link_j[l], dl, l_normal[l, 0], l_normal[l, 1],
                                l_normal[l, 2], body_dyn, vel6)
                l_impulse[l] = lam
            xl[l] = lam
    loop[0] = k
    loop[1] = head
    loop[2] = 1.0 if have_prev else 0.0
    loop[3] = prev_res
    loop[4] = best
    loop[5] = stall
    loop[6] = 1.0 if mixing else 0.0
    return min(it1, max_iter) - it0, res


_NO_GROUPS = np.zeros(1, np.int64)


def run_anderson(ws: Workspace, m, n, n_pair, nl, C, B, L, relax, tol, max_iter, T=1, G=None,
                 min_par=0, it0=0, it1=None, chains=None):
    """Call :func:`iterate_anderson` with the buffers of ``ws`` (grown as needed); ``T``,
    ``G`` (:class:`~engine.solver.parallel.Groups`), ``min_par``: the grouped parallel sweep
    (:func:`engine.solver.parallel.iterate_parallel`); ``it0``, ``it1``: the sweeps of this
    call (default all ``max_iter``); ``chains``: (nc, ChainWork) of
    :func:`engine.solver.chains.chains_for` (default: the plain link sweep)."""
    ws.ensure(m, n, nl)
    nc, K = chains_for(False, 0, L.i, L.j) if chains is None else chains
    if T == 1:
        G = Groups(_NO_GROUPS, _NO_GROUPS, ws.acc)
    return iterate_anderson(n, n_pair, nl, C, B, L, relax, tol, max_iter, m, PERIOD,
                            ws.history(), T, G, min_par, int(it0),
                            int(max_iter if it1 is None else it1), nc, K)


def domain_mixer(ws: Workspace, m, max_iter, tol, nl, L):
    """The mixing of depth ``m`` as :func:`engine.solver.parallel.iterate_parallel` runs it
    on its domains (its ``mix``): a function of the gathered contacts, the bodies, the
    groups and the parallel threshold that runs :func:`run_anderson` in chunks
    (:func:`engine.stop.in_chunks`) and returns (iterations, residual).  Kept here so that
    the parallel sweep needs nothing of this module."""
    def mix(T, n, C, B, relax, G, min_par, chains=None):
        return in_chunks(lambda done, m_: run_anderson(
            ws, m, n, n, nl, C, B, L, relax, tol, max_iter, T, G, min_par, it0=done,
            it1=done + m_, chains=chains), max_iter, tol, n + nl)

    return mix


__all__ = ["iterate_anderson", "run_anderson", "domain_mixer", "Workspace", "History", "PERIOD",
           "RESTART_GROWTH", "STALL_MIXINGS"]
