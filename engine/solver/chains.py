"""Each wire solved as one chain inside the NLGS loop (``Options(chain_solve=True)``).

Gauss–Seidel passes tension along a chain one link per sweep: a 1 000-bead chain needs
thousands of sweeps a step.  A wire is a chain: given the contacts' current impulses, its
links' impulses λ (tension positive: −λ n on bead i, +λ n on bead j) satisfy one linear
system, each link coupled to its two neighbours through the shared beads only.  With
u_l = n_l·(v_i − v_j) the link's normal velocity, u_l = u_l⁰ − Σ_l' A_ll' λ_l' where u⁰ is
the velocity without the chain's impulses and

    A_ll = W_l = 1/m_i + 1/m_j,    A_l,l+1 = −s s' (1/m_b) n_l·n_l+1,

b the bead both links hold and s, s' = +1 / −1 as b is their first / second bead (−1 / +1
for the impulse's sign on it).  The local law of every link (Eq. 9, 11, 13, 15 after the
change of variables of Eq. 8, :func:`engine.solver.nlgs.link_sweep`) is then

    rods (Eq. 9, 11):  (A + C) λ = b,      b_l = u_l⁰ + (g_l − L*_l)/h,
    wires (Eq. 13, 15): λ >= 0, (A + C) λ − b >= 0, λ·((A + C) λ − b) = 0,

C = diag(L/(k h²)) the compliance of the elastic laws (0 for the rigid ones) and L* the
length that keeps the next predicted length exact: it depends on the velocities the solve
changes, so the chain is solved, L* taken at the velocities of that answer, and solved
again, until the impulses stop changing (a few rounds; the sweep takes each link's L* at
the velocities of its own update).  The matrix
is tridiagonal (an open wire: Thomas' algorithm) or cyclic tridiagonal (a closed wire:
Sherman–Morrison on top of Thomas); the wires' complementarity is solved by block
principal pivoting on the active set (the links in tension), which ends in a few passes
on these diagonally dominant matrices, or, if it cycles, by Murty's least-index rule, one
link flipped a pass, which ends for a positive definite matrix; after 4 m passes of it
the solve projects its last answer on λ >= 0 and the NLGS loop goes on.  Impulses whose
(W + c) λ is round-off against the chain's velocities are set to 0: a falling slack wire's
came out at 1e-33 N s, and the Quad residual of such impulses (noise over noise) kept
two of its steps at 9 000-10 000 sweeps.  A singular system (a straight rigid chain
between two immobile beads, whose tension is undetermined: a pivot below 1e-12 of its
diagonal) gets the plain Gauss–Seidel pass on its links instead, as the link sweep does.
Broken links and rigid links between two immobile beads (``wl[l, 1] == 0``) stay at 0
and split the chain.  After :data:`CHAIN_SWEEPS` sweeps in a step the links go back to
the plain link sweep (a safeguard).  Relaxation ω applies to the chain's answer as to
a link's: λ ← λ₀ + ω (λ* − λ₀), then λ >= 0 for the wires.

At its fixed point the chain solve and the link sweep satisfy the same equations, so the
converged impulses are the same (tested at tol 1e-10); the residual is the same Quad norm
(the links' Σ(W Δλ)² and Σ(W λ)² added to the contacts').

Kernels take plain contiguous arrays, the sweep's as the named tuples of
:mod:`engine.solver.kernels` and the work arrays (size n_links, allocated once per step by
the caller, :func:`chain_workspace`) as a :class:`ChainWork` one.
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from ..model import DYN_INV_MASS
from .kernels import (_apply_link, _full, link_sweep, link_update, links_then_residual,
                      lstar, resweep_hot)
from .local import tension

#: The chain solve's arrays (:func:`chain_workspace`): ``starts`` (nl + 1,) int64 and
#: ``closed`` (nl,) int8 the chains (:func:`link_chains`); the work arrays of
#: :func:`chain_sweep`, size n_links: ``d, e, rhs, lam`` the system's diagonal,
#: off-diagonal, right side and answer, ``act`` (int8) the active set, ``z, cp, dp`` the
#: solver's scratch, ``uf`` the free velocities u⁰, ``lp`` the previous round's answer.
ChainWork = namedtuple("ChainWork", "starts closed d e rhs lam act z cp dp uf lp")


#: A pivot below this fraction of its diagonal is singular (:func:`_thomas`).
SINGULAR = 1e-12

#: A link impulse whose (W + c) λ is below this fraction of the chain's largest right side
#: (a velocity) is round-off: it is set to 0.
ROUNDOFF = 1e-12

#: Rounds of "solve, then L* at the answer" per chain solve (module doc).
LSTAR_ROUNDS = 12

#: Passes of block principal pivoting before Murty's one-link-a-pass rule takes over, and
#: the cap of Murty's passes per link of the chain (then the answer is projected on λ >= 0).
BLOCK_PASSES = 8
MURTY_PASSES_PER_LINK = 4


@njit(cache=True)
def link_chains(nl, link_i, link_j, starts, closed):
    """Split the links into chains, the maximal runs of consecutive links that share a
    bead (``link_j[k - 1] == link_i[k]``: the scene stores each wire's links in order).
    ``starts[c]`` and ``starts[c + 1]`` bound chain c; ``closed[c]`` is 1 when its last
    link ends on its first link's first bead (a closed wire, 3 links or more).  Returns the
    number of chains."""
    nc = 0
    for k in range(nl):
        if k == 0 or link_i[k] != link_j[k - 1]:
            starts[nc] = k
            nc += 1
    starts[nc] = nl
    for c in range(nc):
        a = starts[c]
        b = starts[c + 1]
        closed[c] = 1 if (b - a >= 3 and link_j[b - 1] == link_i[a]) else 0
    return nc


@njit(cache=True, inline="always")
def _coupling(l, l2, link_i, link_j, normal, body_dyn):
    """A_{l,l2} of two links sharing one bead (0 if they share none)."""
    i1 = link_i[l]
    j1 = link_j[l]
    i2 = link_i[l2]
    j2 = link_j[l2]
    if j1 == i2 or j1 == j2:
        bb = j1
        s = -1.0
    elif i1 == i2 or i1 == j2:
        bb = i1
        s = 1.0
    else:
        return 0.0
    s2 = -1.0 if bb == i2 else 1.0
    dot = (normal[l, 0] * normal[l2, 0] + normal[l, 1] * normal[l2, 1]
           + normal[l, 2] * normal[l2, 2])
    return -s * s2 * body_dyn[bb, DYN_INV_MASS] * dot


@njit(cache=True, inline="always")
def _thomas(a, b, d, e, rhs, act, out, cp, dp):
    """Solve rows a..b-1 of the tridiagonal system (diagonal d, off-diagonal e[l] between
    l and l+1, right side rhs), rows with ``act != 1`` replaced by λ = 0 (and their
    couplings dropped).  Writes ``out`` (which may be ``rhs`` itself: the forward pass
    reads every row before the backward pass writes); returns False on a singular pivot
    (a straight rigid chain between two immobile ends: its tension is undetermined)."""
    prev = 0.0                                  # effective coupling to the row before
    for l in range(a, b):
        if act[l] == 1:
            dd = d[l]
            rr = rhs[l]
            nxt = e[l] if (l + 1 < b and act[l + 1] == 1) else 0.0
        else:
            dd = 1.0
            rr = 0.0
            nxt = 0.0
        den = dd - prev * cp[l - 1] if l > a else dd
        if not abs(den) > SINGULAR * dd:
            return False
        cp[l] = nxt / den
        dp[l] = (rr - prev * dp[l - 1]) / den if l > a else rr / den
        prev = nxt
    out[b - 1] = dp[b - 1]
    for l in range(b - 2, a - 1, -1):
        out[l] = dp[l] - cp[l] * out[l + 1]
    return True


@njit(cache=True, inline="always")
def _solve_chain(a, b, cyc, d, e, rhs, act, lam, z, cp, dp):
    """λ on rows a..b-1 of the (cyclic if ``cyc``) tridiagonal system with the inactive
    rows at 0.  The cyclic one couples rows b-1 and a by ``e[b - 1]``."""
    ec = e[b - 1] if (cyc and act[a] == 1 and act[b - 1] == 1) else 0.0
    if ec == 0.0:
        return _thomas(a, b, d, e, rhs, act, lam, cp, dp)
    # Sherman–Morrison: M = T' + u vᵀ, u = (γ, 0.., ec), v = (1, 0.., ec/γ), T' the open
    # tridiagonal with d_a − γ and d_{b-1} − ec²/γ
    gam = -d[a]
    da, dl = d[a], d[b - 1]
    d[a] = da - gam
    d[b - 1] = dl - ec * ec / gam
    ok = _thomas(a, b, d, e, rhs, act, lam, cp, dp)              # T' y = rhs
    # T' z = u: the same matrix, right side u = (γ, 0.., ec), solved in place in z
    for l in range(a, b):
        z[l] = 0.0
    z[a] = gam
    z[b - 1] = ec
    if ok:
        ok = _thomas(a, b, d, e, z, act, z, cp, dp)
    d[a] = da
    d[b - 1] = dl
    if not ok or not abs(1.0 + z[a] + ec * z[b - 1] / gam) > SINGULAR:
        return False
    vy = lam[a] + ec * lam[b - 1] / gam
    vz = z[a] + ec * z[b - 1] / gam
    f = vy / (1.0 + vz)
    for l in range(a, b):
        lam[l] -= f * z[l]
    return True


@njit(cache=True, inline="always")
def _dlam(k, act, lam, impulse):
    """The change of link k's impulse the tentative answer makes (0 for a skipped link)."""
    if act[k] == -1:
        return 0.0
    return (lam[k] if act[k] == 1 else 0.0) - impulse[k]


@njit(cache=True, inline="always")
def _on_bead(bb, k, link_i, link_j):
    """The sign of link k's impulse on bead bb: −1 on its first bead, +1 on its second, 0
    when bb is not one of its beads."""
    if bb == link_i[k]:
        return -1.0
    if bb == link_j[k]:
        return 1.0
    return 0.0


@njit(cache=True)
def _length_terms(a, b, cyc, link_i, link_j, normal, wl, impulse, body_dyn, vel6, act, lam,
                  uf, rhs):
    """rhs = uf + (g − L*)/h with L* at the velocities of the tentative answer ``lam``:
    the beads' velocities now, plus what the changes of the link and of its two
    neighbours (the links that hold its beads) would add."""
    for l in range(a, b):
        if act[l] == -1:
            continue
        prv = l - 1 if l > a else (b - 1 if cyc else -1)
        nxt = l + 1 if l + 1 < b else (a if cyc else -1)
        i = link_i[l]
        j = link_j[l]
        wx = vel6[i, 0] - vel6[j, 0]
        wy = vel6[i, 1] - vel6[j, 1]
        wz = vel6[i, 2] - vel6[j, 2]
        for k in (prv, l, nxt):
            if k < 0:
                continue
            dk = _dlam(k, act, lam, impulse)
            if dk == 0.0:
                continue
            f = (body_dyn[i, DYN_INV_MASS] * _on_bead(i, k, link_i, link_j)
                 - body_dyn[j, DYN_INV_MASS] * _on_bead(j, k, link_i, link_j)) * dk
            wx += f * normal[k, 0]
            wy += f * normal[k, 1]
            wz += f * normal[k, 2]
        ls = lstar(l, normal, wl, wx, wy, wz)[1]
        rhs[l] = uf[l] + (wl[l, 2] - ls) * wl[l, 5]


@njit(cache=True)
def chain_sweep(nc, K, L, B, relax):
    """Solve each of the ``nc`` chains of ``K`` (:class:`ChainWork`) exactly given the other
    impulses (module doc) and apply the change to the beads of ``B``; returns
    (Σ(W Δλ)², Σ(W λ)²) of the links ``L`` as :func:`~engine.solver.kernels.link_sweep`
    does."""
    starts, closed, d, e, rhs, lam, act, z, cp, dp, uf, lp = K
    link_i, link_j, normal, wl, unilateral, impulse, _ = L
    body_dyn, vel6 = B
    num = 0.0
    den = 0.0
    for c in range(nc):
        a = starts[c]
        b = starts[c + 1]
        cyc = closed[c] != 0
        # the system at the current velocities: diagonal W + c, right side u⁰ + (g − L*)/h
        for l in range(a, b):
            iwc = wl[l, 1]
            if iwc == 0.0:                       # skipped (broken, or immobile ends)
                d[l] = 1.0
                rhs[l] = 0.0
                act[l] = -1
                continue
            i = link_i[l]
            j = link_j[l]
            u, ls = lstar(l, normal, wl, vel6[i, 0] - vel6[j, 0], vel6[i, 1] - vel6[j, 1],
                          vel6[i, 2] - vel6[j, 2])
            d[l] = 1.0 / iwc
            uf[l] = u + wl[l, 0] * impulse[l]
            rhs[l] = (wl[l, 2] - ls) * wl[l, 5]
            act[l] = 1 if (unilateral[l] == 0 or impulse[l] > 0.0) else 0
        last = b if cyc else b - 1
        for l in range(a, last):
            l2 = l + 1 if l + 1 < b else a
            if wl[l, 1] == 0.0 or wl[l2, 1] == 0.0:
                e[l] = 0.0
            else:
                e[l] = _coupling(l, l2, link_i, link_j, normal, body_dyn)
        if not cyc:
            e[b - 1] = 0.0
        # u⁰ = u + Σ A λ₀: the off-diagonal part (the diagonal one is in uf already)
        for l in range(a, b):
            if act[l] == -1:
                continue
            if l + 1 < b:
                uf[l] += e[l] * impulse[l + 1]
            elif cyc:
                uf[l] += e[l] * impulse[a]
            if l > a:
                uf[l] += e[l - 1] * impulse[l - 1]
            elif cyc:
                uf[l] += e[b - 1] * impulse[b - 1]
            rhs[l] += uf[l]
        # L* depends on the velocities the solve changes: solve, take L* at the answer, solve
        # again, until the impulses stop changing (a few rounds; as the sweep takes each
        # link's L* at the velocities of its own update)
        for l in range(a, b):
            lp[l] = 0.0
        singular = False
        for rnd in range(LSTAR_ROUNDS):
            # the wires' complementarity: block principal pivoting on the active set (every
            # violated link flipped at once), then, if that has not settled, Murty's least-
            # index rule (one link a pass: finite for this positive definite matrix)
            m = b - a
            for p in range(BLOCK_PASSES + MURTY_PASSES_PER_LINK * m):
                if not _solve_chain(a, b, cyc, d, e, rhs, act, lam, z, cp, dp):
                    singular = True
                    break
                single = p >= BLOCK_PASSES
                changed = 0
                for l in range(a, b):
                    flip = False
                    if act[l] == 1:
                        flip = unilateral[l] != 0 and lam[l] < 0.0
                    elif act[l] == 0:
                        r = rhs[l]
                        if l + 1 < b:
                            r -= e[l] * lam[l + 1] if act[l + 1] == 1 else 0.0
                        elif cyc and act[a] == 1:
                            r -= e[l] * lam[a]
                        if l > a:
                            r -= e[l - 1] * lam[l - 1] if act[l - 1] == 1 else 0.0
                        elif cyc and act[b - 1] == 1:
                            r -= e[b - 1] * lam[b - 1]
                        flip = r > 0.0               # slack, but the chain pulls it taut
                    if flip:
                        act[l] = 1 - act[l]
                        changed += 1
                        if single:
                            break
                if changed == 0:
                    break
            if singular:
                break
            top = 0.0
            moved = 0.0
            for l in range(a, b):
                if act[l] == -1:
                    continue
                x = lam[l] if act[l] == 1 else 0.0
                top = max(top, abs(x))
                moved = max(moved, abs(x - lp[l]))
                lp[l] = x
            if rnd > 0 and moved <= 1e-12 * top:
                break
            if rnd + 1 < LSTAR_ROUNDS:
                _length_terms(a, b, cyc, link_i, link_j, normal, wl, impulse, body_dyn, vel6,
                              act, lam, uf, rhs)
        if singular:          # an undetermined tension: the plain Gauss–Seidel pass on it
            for l in range(a, b):
                x, y = link_update(l, L, B, relax)
                num += x
                den += y
            continue
        # the chain's velocity scale: a link whose (W + c) λ is round-off against it carries no
        # tension (a slack wire's impulses came out at 1e-33 N s, and the Quad residual of
        # such impulses, noise over noise, stayed of order 1 for thousands of sweeps)
        vmax = 0.0
        for l in range(a, b):
            if act[l] != -1 and abs(rhs[l]) > vmax:
                vmax = abs(rhs[l])
        for l in range(a, b):
            if act[l] == -1:
                continue
            lam0 = impulse[l]
            new = lam[l] if act[l] == 1 else 0.0
            if abs(d[l] * new) <= ROUNDOFF * vmax:     # (W + c) λ: a velocity
                new = 0.0
            new = lam0 + relax * (new - lam0)
            if unilateral[l] != 0:
                new = tension(new)
            dl = new - lam0
            impulse[l] = new
            _apply_link(link_i[l], link_j[l], dl, normal[l, 0], normal[l, 1], normal[l, 2],
                        body_dyn, vel6)
            W = wl[l, 0]
            num += (W * dl) ** 2
            den += (W * new) ** 2
    return num, den


#: Chain sweeps a step gets before its links go back to the plain Gauss–Seidel link sweep
#: for the rest of the step (a safeguard: not reached on the tests' chains since round-off
#: impulses are set to 0, see :data:`ROUNDOFF`).
CHAIN_SWEEPS = 30


@njit(cache=True, inline="always")
def _links(sweeps, nc, K, L, B, relax):
    """The links' part of a sweep: the chain solve for the step's first
    :data:`CHAIN_SWEEPS` sweeps, the plain link sweep after them; returns its Quad sums."""
    if sweeps < CHAIN_SWEEPS:
        return chain_sweep(nc, K, L, B, relax)
    return link_sweep(L.i.shape[0], L, B, relax)


@njit(cache=True, inline="always")
def link_phase(num, den, sweeps, nc, K, nl, L, B, relax):
    """The end of every sweep of the parallel and mixed paths: the links' part added to
    the contacts' Quad sums ``num``, ``den``, and the Quad residual.  With ``nc`` >= 0
    (``Options.chain_solve``) the links are the ``nc`` chains of ``K`` (:func:`_links`:
    the chain solve for the step's first :data:`CHAIN_SWEEPS` sweeps, ``sweeps`` counting
    those done before this one); with ``nc`` = :data:`NO_CHAINS` the plain link sweep, which
    is :func:`engine.solver.kernels.links_then_residual` bit for bit."""
    if nc < 0:
        return links_then_residual(num, den, nl, L, B, relax)
    if nc > 0:
        lnum, lden = _links(sweeps, nc, K, L, B, relax)
        num += lnum
        den += lden
    return np.sqrt(num / den) / relax if den > 0.0 else 0.0


#: ``nc`` of :func:`link_phase` when the chain solve is off.
NO_CHAINS = -1


@njit(cache=True)
def iterate_chains(n, n_pair, nc, C, B, L, K, relax, tol, max_iter, done, hot_sweeps, factor, q,
                   hot):
    """:func:`engine.solver.kernels.iterate`'s sweeps (its arguments ``n, n_pair, C, B, L``;
    ``nc`` chains in ``K``, :func:`chain_workspace`): sweep the contacts, then solve each
    chain (:func:`chain_sweep`), until the Quad
    residual (over both) is below ``tol`` or ``max_iter`` sweeps are done; after
    :data:`CHAIN_SWEEPS` sweeps of the step (``done`` counts those of earlier calls), the
    links are swept by the plain :func:`~engine.solver.nlgs.link_sweep` instead.  With
    ``hot_sweeps`` > 0 the hot contacts are re-swept after each full sweep, as
    :func:`engine.solver.nlgs.iterate_hot` does (``q`` (n,), ``hot`` (n,) int32: work
    arrays); the stopping test stays on the full sweeps.  Returns ``(iterations,
    residual)``."""
    if relax > 1.0:                       # the over-relaxed copy of the contact loops
        return _chains_loop(n, n_pair, nc, C, B, L, K, relax, tol, max_iter, done, hot_sweeps,
                            factor, q, hot, True)
    return _chains_loop(n, n_pair, nc, C, B, L, K, relax, tol, max_iter, done, hot_sweeps,
                        factor, q, hot, False)


@njit(cache=True)
def _chains_loop(n, n_pair, nc, C, B, L, K, relax, tol, max_iter, done, hot_sweeps, factor, q,
                 hot, over):
    """:func:`iterate_chains`' loop (``over``: over-relaxation, relax > 1)."""
    if n == 0 and nc == 0:
        return 0, 0.0
    bounds = np.full(1, n_pair, np.int64)
    hbounds = np.empty(1, np.int64)
    res = 0.0
    for it in range(max_iter):
        num, den = _full(n, n_pair, q, C, B, relax, over, True)
        if nc > 0:
            lnum, lden = _links(done + it, nc, K, L, B, relax)
            num += lnum
            den += lden
        res = np.sqrt(num / den) / relax if den > 0.0 else 0.0
        if res < tol:
            return it + 1, res
        if n > 0 and hot_sweeps > 0:
            resweep_hot(n, q, factor, hot, bounds, hbounds, hot_sweeps, C, B, relax, over)
    return max_iter, res


def chain_workspace(nl: int, link_i, link_j):
    """(nc, :class:`ChainWork`) for :func:`iterate_chains`: the number of chains and their
    arrays."""
    starts = np.empty(nl + 1, np.int64)
    closed = np.zeros(max(nl, 1), np.int8)
    nc = link_chains(nl, link_i, link_j, starts, closed)
    work = [np.zeros(max(nl, 1)) for _ in range(4)]          # d, e, rhs, lam
    act = np.zeros(max(nl, 1), np.int8)
    more = [np.zeros(max(nl, 1)) for _ in range(5)]          # z, cp, dp, uf, lp
    return nc, ChainWork(starts, closed, *work, act, *more)


def chains_for(chain_solve: bool, nl: int, link_i, link_j):
    """(nc, :class:`ChainWork`) as :func:`link_phase` takes them: the step's chains when
    ``chain_solve`` and there are links, else (:data:`NO_CHAINS`, a one-row workspace)."""
    global _OFF
    if chain_solve and nl:
        return chain_workspace(nl, link_i, link_j)
    if _OFF is None:              # never written with NO_CHAINS: one for every caller
        _OFF = NO_CHAINS, chain_workspace(0, link_i[:0], link_j[:0])[1]
    return _OFF


_OFF = None
