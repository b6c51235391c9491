"""Probes of the mould deposit's stagnating step (issue 31 §2), re-runnable from a clone.

    .venv/bin/python bench/probe_stagnation.py [--scale 0.1] [--step 1]
                                               [--sweeps 10000] [--admm-iters 60]
                                               [--block 1,2,4,8] [--block-budget 3000]
                                               [--laws 30000] [--ipm 6]
                                               [--export step.npz]
    /usr/bin/python3 bench/probe_stagnation.py --siconos step.npz     # Debian's, with Siconos

The scene is ``bench_residual.mould_model`` (the slope sample of seed 0 with its wire in its
mould, h = 1e-4 s, tol 1e-4), stepped ``--step`` times with the engine; then the next step's
problem is set up (free velocities, contacts, Delassus diagonals, warm start) and taken
apart without stepping on:

1. **Sweeps** (plain Gauss–Seidel, ``--sweeps`` of them, from the warm start).  At a few
   sweeps: the Quad residual (our stopping test: each contact's change weighted by its
   Delassus *diagonal*), the change of the local velocities the same sweep made,
   ‖H Δv‖ = ‖W Δp‖ with the *full* W (the part of the impulse change that moves
   something; the rest is a self-equilibrated redistribution), and how far the body
   velocities still are from those of the last sweep.  The velocity error at sweep 1 000
   (against the last) is then described: how alike two touching grains' errors are (the
   correlation over the contacts), the share that one translation per cell of 4, 8 or 16
   mean radii captures (what a coarse rigid-cluster correction could remove), the share
   carried by spins (r ω), and on how many grains it sits.
2. **ADMM** (contact space: W = H M⁻¹ Hᵀ assembled with scipy, W + ρ I factorised by
   SuperLU) with Siconos 4.4's defaults for ``SICONOS_FRICTION_3D_ADMM`` (ρ = 1 in SI
   units, acceleration with restart, η = 0.999, the De Saxcé shift from the unprojected
   impulses), from zero, ``--admm-iters`` iterations.  Its answer r is measured in
   Siconos's natural-map residual (as ``fc3d_compute_error``: velocities in m/s and
   impulses in N s side by side, normalised by ‖q‖), by how far r lies outside the
   Coulomb cones, and in the natural map with each contact's impulse in velocity units
   (W_nn p), beside our sweeps' answer in the same measures.
3. ``--block 1,2,4,8``: Gauss–Seidel **by grain** (a block solve per grain, its
   neighbours held, done by sweeping its contacts K times in a row before the next grain;
   each contact belongs to the blocks of both its grains), against plain sweeps, for the
   same work (``--block-budget`` contact updates per contact).  At a few points: the Quad
   residual of a trial plain sweep (undone afterwards) and the local velocities' distance
   to part 1's last sweep's, ‖H(v − v_ref)‖ / ‖H v_ref‖.  This is the "block solve per
   grain, aimed at the local rolling and sliding" that part 1's error field points to.
4. ``--export``: the step as an npz (W, q, μ and our impulses after 1 000 sweeps), which
   ``--siconos`` solves with Siconos's NSGS and ADMM at tol 1e-6 (run it with Debian's
   ``/usr/bin/python3``, which has ``python3-siconos``).
5. ``--laws N``: the law, not the solver.  The same step in contact space (W, q as part 2,
   the wire's link impulses held in q), N Gauss–Seidel sweeps from the warm start, in the
   buffer order, each contact solved with its diagonal block twice over: with the
   engine's Coulomb law (Signorini, then the disk: non-associated, no dilatancy) and with
   the associated law (the projection on the cone in the block's metric: the convex
   relaxation, CCP, whose sliding contacts dilate).  At a few sweeps: the Quad residual,
   the local velocities' and the impulses' distance to the same law's last sweep, the
   sliding contacts, the natural-map residual.  If only the Coulomb run stalls, what
   stops the sweeps comes with the law, not with W's conditioning alone.
6. ``--ipm N``: the classical way to a Coulomb solution through convex problems (De
   Saxcé's bipotential): N fixed-point iterations, each solving the associated problem
   with the normal velocities shifted by μ ‖u_T‖ of the previous answer, exactly, by a
   primal-dual interior-point method (second-order cones, Nesterov–Todd scaling, Mehrotra
   predictor-corrector; each Newton system in body space, SuperLU).  For each iteration:
   the shift's relative change, the answer's natural-map residual, and the Quad residual
   of 1, 10, 100 and 1 000 Coulomb sweeps (part 5's) started from it.

No timing is used for a conclusion (the wall times printed are indicative).
JSON: bench/results/stagnation-*.json.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


# ---------------------------------------------------------------- the cone, in numpy
def project_cones(x, mu):
    """Projection of the (n, 3) local impulses (p_n, p_t, p_s) on the Coulomb cones."""
    x = np.asarray(x, float).reshape(-1, 3)
    pn, pt, ps = x[:, 0], x[:, 1], x[:, 2]
    nt = np.hypot(pt, ps)
    inside = nt <= mu * pn
    polar = mu * nt <= -pn
    y0 = (pn + mu * nt) / (1.0 + mu * mu)
    f = np.where(nt > 0.0, mu * y0 / np.maximum(nt, 1e-300), 0.0)
    out = np.zeros_like(x)
    out[inside] = x[inside]
    surf = ~inside & ~polar
    out[surf, 0] = y0[surf]
    out[surf, 1] = f[surf] * pt[surf]
    out[surf, 2] = f[surf] * ps[surf]
    return out.ravel()


class Problem:
    """One step's frictional contact problem u = W p + q in contact space (flat 3n)."""

    def __init__(self, W, q, mu):
        self.W, self.q, self.mu = W, np.asarray(q, float), np.asarray(mu, float)
        self.wn = np.repeat(W.diagonal()[0::3], 3)

    def shift(self, p):
        """The De Saxcé term (μ ‖u_T‖, 0, 0) at the velocities p gives."""
        u = (self.W @ p + self.q).reshape(-1, 3)
        s = np.zeros_like(u)
        s[:, 0] = self.mu * np.hypot(u[:, 1], u[:, 2])
        return s.ravel()

    def natural(self, p, scaled=False):
        """Natural-map residual ‖p − P_K(p − û)‖ / ‖q‖ (``fc3d_compute_error``'s), or with
        the impulses in velocity units (W_nn p) when ``scaled``."""
        uh = self.W @ p + self.q + self.shift(p)
        s = self.wn if scaled else 1.0
        e = s * p - s * project_cones((s * p - uh) / s, self.mu)
        return float(np.linalg.norm(e) / np.linalg.norm(self.q))

    def cone_violation(self, p):
        """‖p − P_K(p)‖ / ‖p‖."""
        return float(np.linalg.norm(p - project_cones(p, self.mu)) / np.linalg.norm(p))


def admm(pb: Problem, rho: float, iters: int, log_at=(1, 3, 10, 30, 50, 60, 100, 200)):
    """Siconos 4.4's fc3d ADMM (symmetric, accelerated with restart), from zero; returns
    (r, z, log): r the last linear solve's impulses, z their projection on the cones."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spl

    m = pb.q.size
    lu = spl.splu((pb.W + rho * sp.identity(m)).tocsc())
    z = np.zeros(m)
    r = np.zeros(m)
    xi = np.zeros(m)
    zk, xik, zh, xih = z.copy(), xi.copy(), z.copy(), xi.copy()
    ek, tauk, eta = np.inf, 1.0, 0.999
    log = []
    for k in range(1, iters + 1):
        s = pb.shift(r)
        r = lu.solve(rho * (zh - xih) - pb.q - s)
        z = project_cones(r + xih, pb.mu)
        xi = xih + r - z
        e = np.linalg.norm(r - z) ** 2 + (rho * np.linalg.norm(zh - z)) ** 2
        if e < eta * ek:
            tau = 0.5 * (1.0 + np.sqrt(1.0 + 4.0 * tauk * tauk))
            a = (tauk - 1.0) / tau
            zh, xih = (1 + a) * z - a * zk, (1 + a) * xi - a * xik
            tauk, ek = tau, e
        else:
            tauk, ek = 1.0, ek / eta
            zh, xih = z.copy(), xi.copy()
        zk, xik = z.copy(), xi.copy()
        if k in log_at or k == iters:
            log.append(dict(iteration=k, natural_r=pb.natural(r), natural_z=pb.natural(z)))
    return r, z, log


# ---------------------------------------------------------------- part 6: interior point
_J = np.array([1.0, -1.0, -1.0])


def _jdot(a, b):
    """aᵀ J b for each (m, 3) row: the second-order cone's Lorentz product."""
    return (a * b * _J).sum(1)


def _jprod(a, b):
    """The Jordan product a ∘ b of the second-order cone, row by row."""
    out = np.empty_like(a)
    out[:, 0] = (a * b).sum(1)
    out[:, 1:] = a[:, :1] * b[:, 1:] + b[:, :1] * a[:, 1:]
    return out


def _jsolve(lam, r):
    """d with lam ∘ d = r, row by row."""
    l0, l1 = lam[:, 0], lam[:, 1:]
    d0 = (l0 * r[:, 0] - (l1 * r[:, 1:]).sum(1)) / (l0 * l0 - (l1 * l1).sum(1))
    return np.column_stack([d0, (r[:, 1:] - l1 * d0[:, None]) / l0[:, None]])


def _nt_scaling(x, y):
    """Nesterov–Todd scaling of each cone: (W, W⁻¹, λ) with W y = W⁻¹ x = λ."""
    xn, yn = np.sqrt(_jdot(x, x)), np.sqrt(_jdot(y, y))
    xb, yb = x / xn[:, None], y / yn[:, None]
    g = np.sqrt(0.5 * (1.0 + (xb * yb).sum(1)))
    wb = (xb + yb * _J) / (2.0 * g[:, None])
    v = wb.copy()
    v[:, 0] += 1.0
    v /= np.sqrt(2.0 * (wb[:, 0] + 1.0))[:, None]
    beta = np.sqrt(xn / yn)
    Jm = np.diag(_J)
    W = beta[:, None, None] * (2.0 * v[:, :, None] * v[:, None, :] - Jm)
    Jv = v * _J
    Wi = (1.0 / beta)[:, None, None] * (2.0 * Jv[:, :, None] * Jv[:, None, :] - Jm)
    return W, Wi, np.einsum("kij,kj->ki", W, y)


def _max_step(x, d):
    """The largest α with x + α d in the cones (inf if none binds)."""
    a, b, c = _jdot(d, d), 2.0 * _jdot(x, d), _jdot(x, x)
    alpha = np.full(len(x), np.inf)
    disc = b * b - 4.0 * a * c
    with np.errstate(invalid="ignore", divide="ignore"):
        sq = np.sqrt(np.maximum(disc, 0.0))
        for r in ((-b - sq) / (2.0 * a), (-b + sq) / (2.0 * a)):
            ok = (disc >= 0.0) & (np.abs(a) > 1e-300) & (r > 0.0)
            alpha = np.where(ok, np.minimum(alpha, r), alpha)
        lin = -c / b
    alpha = np.where((np.abs(a) <= 1e-300) & (lin > 0.0), np.minimum(alpha, lin), alpha)
    neg = d[:, 0] < 0.0
    alpha = np.where(neg, np.minimum(alpha, -x[:, 0] / np.where(neg, d[:, 0], -1.0)), alpha)
    return float(alpha.min())


def _block_diag(B):
    import scipy.sparse as sp

    m = len(B)
    rows = np.repeat(np.arange(3 * m).reshape(m, 3, 1), 3, 2)
    cols = np.repeat(np.arange(3 * m).reshape(m, 1, 3), 3, 1)
    return sp.csr_matrix((B.ravel(), (rows.ravel(), cols.ravel())), shape=(3 * m, 3 * m))


def soc_ipm(A, c, tol=1e-9, iters=80):
    """min ½ xᵀ A Aᵀ x + cᵀ x over a product of 3D second-order cones (x flat, 3 per
    cone): primal-dual interior point with Nesterov–Todd scaling and Mehrotra's
    predictor-corrector, each Newton system (A Aᵀ + W⁻²) solved through the Woodbury
    identity in the space of A's columns (I + Aᵀ W² A, SuperLU).  Returns (x, iterations)."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spl

    m = len(c) // 3
    cn = max(np.linalg.norm(c), 1e-300)
    x = np.zeros((m, 3))
    x[:, 0] = np.sqrt(cn / np.sqrt(m))
    y = x.copy()
    e = np.zeros((m, 3))
    e[:, 0] = 1.0
    At = A.T.tocsr()
    for k in range(iters):
        rd = A @ (At @ x.ravel()) + c - y.ravel()
        gap = (x * y).sum() / m
        if k == 0:
            gap0 = gap
        if gap < 1e-10 * gap0 and np.linalg.norm(rd) / cn < tol:
            break
        W, Wi, lam = _nt_scaling(x, y)
        Wi2 = np.einsum("kij,kjl->kil", Wi, Wi)
        G = _block_diag(np.einsum("kij,kjl->kil", W, W))     # (W⁻²)⁻¹
        lu = spl.splu((sp.identity(A.shape[1]) + (At @ G) @ A).tocsc(),
                      permc_spec="MMD_AT_PLUS_A")

        def newton(rc):
            d = _jsolve(lam, rc)
            wd = np.einsum("kij,kj->ki", Wi, d)
            g = G @ (wd.ravel() - rd)
            dx = (g - G @ (A @ lu.solve(At @ g))).reshape(m, 3)
            return dx, wd - np.einsum("kij,kj->ki", Wi2, dx)

        ll = _jprod(lam, lam)
        dxa, dya = newton(-ll)
        a = min(1.0, _max_step(x, dxa), _max_step(y, dya))
        sigma = (((x + a * dxa) * (y + a * dya)).sum() / m / gap) ** 3
        corr = _jprod(np.einsum("kij,kj->ki", Wi, dxa), np.einsum("kij,kj->ki", W, dya))
        dx, dy = newton(sigma * gap * e - ll - corr)
        a = min(1.0, 0.99 * _max_step(x, dx), 0.99 * _max_step(y, dy))
        x, y = x + a * dx, y + a * dy
    return x.ravel(), k


def probe_ipm(pb, H, minv, outers, law_sweeps_from):
    """Part 6 (module doc): [rows per outer iteration]."""
    import scipy.sparse as sp

    n = pb.mu.size
    sc = 1.0 / np.sqrt(pb.W.diagonal()[0::3])
    D = np.column_stack([sc / pb.mu, sc, sc]).ravel()        # p = D x, x in the unit cones
    A = (sp.diags(D) @ H @ sp.diags(np.sqrt(minv))).tocsr()
    shift = np.zeros(3 * n)
    rows = []
    for outer in range(outers):
        t = time.perf_counter()
        x, its = soc_ipm(A, D * (pb.q + shift))
        p = D * x
        new = pb.shift(p)
        change = float(np.linalg.norm(new - shift) / max(np.linalg.norm(new), 1e-300))
        shift = new
        row = dict(outer=outer, ipm_iterations=int(its), seconds=time.perf_counter() - t,
                   shift_change=change, natural=pb.natural(p),
                   natural_scaled=pb.natural(p, True), cone_violation=pb.cone_violation(p),
                   coulomb_sweeps_from_it=law_sweeps_from(p))
        rows.append(row)
        print(f"outer {outer}: {its} interior-point iterations ({row['seconds']:.0f} s), "
              f"shift change {change:.2e}, natural (scaled) {row['natural_scaled']:.2e}; "
              "Coulomb sweeps from it:", " ".join(f"{k}: {q:.1e}" for k, q in
                                                  row["coulomb_sweeps_from_it"]), flush=True)
    return rows


# ---------------------------------------------------------------- the engine's step
def _block_pass():
    """The njit kernel of part 3 (built on first use: ``--siconos`` runs without numba)."""
    from numba import njit

    from engine.solver import kernels as K

    @njit(cache=False)
    def block_pass(order, n_pair, C, B):
        # each contact solved by the engine's own update, in the order given
        for k in range(order.size):
            a = order[k]
            if a < n_pair:
                K._contact(a, C, B, 1.0, False, False, False)
            else:
                K._contact(a, C, B, 1.0, True, False, False)
    return block_pass


def block_order(model, c, n, repeats):
    """The contacts grain by grain (mobile grains in index order), each grain's list
    ``repeats`` times in a row."""
    ci, cj = c.i[:n].astype(np.int64), c.j[:n].astype(np.int64)
    mob = model.body_dyn[:, 0] > 0
    ends = np.concatenate([ci[mob[ci]], cj[mob[cj]]])
    ids = np.concatenate([np.flatnonzero(mob[ci]), np.flatnonzero(mob[cj])])
    o = np.argsort(ends, kind="stable")
    ends, ids = ends[o], ids[o]
    ptr = np.searchsorted(ends, np.arange(model.n_bodies + 1))
    parts = [np.tile(ids[ptr[b]:ptr[b + 1]], repeats) for b in range(model.n_bodies)
             if ptr[b + 1] > ptr[b]]
    return np.concatenate(parts).astype(np.int64)


def probe_blocks(model, s, c, n, sweep, H, start, vref, repeats_list, budget):
    """Part 3 (module doc): {label: [(work in sweeps, trial Quad, velocity error)]}."""
    block_pass = _block_pass()
    C, B = sweep.C, sweep.B
    uref = np.linalg.norm(H @ vref.ravel())
    vel0, imp0, links0 = start

    def trial():
        v, p, lk = s.vel6.copy(), c.impulse.copy(), s.link_impulse.copy()
        quad = float(sweep())
        s.vel6[:], c.impulse[:], s.link_impulse[:] = v, p, lk
        return quad

    out = {}
    for repeats in [0] + list(repeats_list):
        s.vel6[:], c.impulse[:], s.link_impulse[:] = vel0, imp0, links0
        order = block_order(model, c, n, repeats) if repeats else None
        work, mark, log = 0.0, 1.0, []
        while work < budget:
            if repeats:
                block_pass(order, c.n_pair, C, B)
                sweep.links()
                work += order.size / n
            else:
                sweep()
                work += 1.0
            if work >= mark or work >= budget:
                err = float(np.linalg.norm(H @ (s.vel6 - vref).ravel()) / uref)
                log.append(dict(work_sweeps=round(work, 2), quad=trial(), velocity_error=err))
                mark = max(2 * mark, np.floor(work) + 1)
        label = f"block K={repeats}" if repeats else "plain"
        out[label] = log
        print(label + ":", " ".join(f"[{r['work_sweeps']:.0f} sweeps: Quad {r['quad']:.2e}, "
                                     f"velocities {r['velocity_error']:.2f}]" for r in log[-5:]),
              flush=True)
    return out


def _law_sweeps():
    """The njit kernel of part 5 (built on first use, as part 3's)."""
    from numba import njit

    @njit(cache=False)
    def law_sweeps(indptr, indices, data, q, mu, p, wd, sweeps, associated, quad):
        # Gauss-Seidel in contact space on u = W p + q, contacts in buffer order; the
        # local problem with W's diagonal block: the engine's Coulomb update (Signorini,
        # then the disk, as engine.solver.local.coulomb but dividing by W's diagonal where
        # the engine multiplies by its inverse: the committed runs were made so, and the
        # wandering Coulomb sweeps part from those runs after ~10 000 sweeps when the last
        # bit changes), or the associated law's (the projection of -f on the cone in
        # the metric of the diagonal block: CCP, the friction cone's normality rule)
        n = mu.size
        for k in range(sweeps):
            num = 0.0
            den = 0.0
            for a in range(n):
                r = 3 * a
                u0 = q[r]
                for e in range(indptr[r], indptr[r + 1]):
                    u0 += data[e] * p[indices[e]]
                u1 = q[r + 1]
                for e in range(indptr[r + 1], indptr[r + 2]):
                    u1 += data[e] * p[indices[e]]
                u2 = q[r + 2]
                for e in range(indptr[r + 2], indptr[r + 3]):
                    u2 += data[e] * p[indices[e]]
                wn = wd[r]
                wt = wd[r + 1]
                fn = u0 - wn * p[r]
                ft = u1 - wt * p[r + 1]
                fs = u2 - wt * p[r + 2]
                if associated:
                    sn = np.sqrt(wn)
                    st = np.sqrt(wt)
                    zn = -fn / sn
                    zt = -ft / st
                    zs = -fs / st
                    m = mu[a] * st / sn
                    nt = np.sqrt(zt * zt + zs * zs)
                    if nt <= m * zn:
                        pass
                    elif m * nt <= -zn:
                        zn = 0.0
                        zt = 0.0
                        zs = 0.0
                    else:
                        y = (zn + m * nt) / (1.0 + m * m)
                        f = m * y / nt
                        zn = y
                        zt *= f
                        zs *= f
                    pn = zn / sn
                    pt = zt / st
                    ps = zs / st
                elif fn >= 0.0:
                    pn = 0.0
                    pt = 0.0
                    ps = 0.0
                else:
                    pn = -fn / wn
                    pt = -ft / wt
                    ps = -fs / wt
                    nt = np.sqrt(pt * pt + ps * ps)
                    if nt > mu[a] * pn:
                        f = mu[a] * pn / nt
                        pt *= f
                        ps *= f
                dn = pn - p[r]
                dt = pt - p[r + 1]
                ds = ps - p[r + 2]
                num += (wn * dn) ** 2 + (wt * dt) ** 2 + (wt * ds) ** 2
                den += (wn * pn) ** 2 + (wt * pt) ** 2 + (wt * ps) ** 2
                p[r] = pn
                p[r + 1] = pt
                p[r + 2] = ps
            quad[k] = np.sqrt(num / den) if den > 0.0 else 0.0
    return law_sweeps


def contact_sweeps(pb):
    """``run(p, sweeps, associated)``: part 5's sweeps on ``pb`` (:class:`Problem`) from the
    impulses ``p`` (flat, updated in place); returns each sweep's Quad residual."""
    law_sweeps = _law_sweeps()
    W = pb.W.tocsr()
    W.sort_indices()
    wd = W.diagonal().copy()

    def run(p, sweeps, associated):
        quad = np.zeros(sweeps)
        law_sweeps(W.indptr, W.indices, W.data, pb.q, pb.mu, p, wd, sweeps, associated, quad)
        return quad
    run.wd = wd
    return run


def probe_laws(model, pb, H, vfree, minv, p0, nsweeps, run):
    """Part 5 (module doc): {law: [rows at a few sweeps]}; ``run`` of
    :func:`contact_sweeps`."""
    wd = run.wd
    mob = model.body_dyn[:, 0] > 0
    marks = sorted({k for k in (1, 10, 100, 300, 1000, 3000, 10000, 20000) if k < nsweeps}
                   | {nsweeps})
    out = {}
    for law, assoc in (("coulomb", False), ("associated", True)):
        p = p0.copy()
        snaps, done = {}, 0
        for k in marks:
            quad = run(p, k - done, assoc)
            done = k
            snaps[k] = (p.copy(), float(quad[-1]))
        pref = snaps[nsweeps][0]
        vref = vfree + minv * (H.T @ pref)
        uref = np.linalg.norm(H @ vref)
        rows = []
        for k, (pk, quad) in snaps.items():
            v = vfree + minv * (H.T @ pk)
            dv = (v - vref).reshape(-1, 6)[mob, :3]
            pr = pk.reshape(-1, 3)
            slide = (pr[:, 0] > 0) & (np.hypot(pr[:, 1], pr[:, 2]) >= 0.999 * pb.mu * pr[:, 0])
            rows.append(dict(sweep=k, quad=quad,
                             velocity_error=float(np.linalg.norm(H @ (v - vref)) / uref),
                             rms_speed_error=float(np.sqrt((dv ** 2).sum(1).mean())),
                             impulse_error=float(np.linalg.norm(wd * (pk - pref))
                                                 / np.linalg.norm(wd * pref)),
                             impulse_norm=float(np.linalg.norm(wd * pk)),
                             sliding=int(slide.sum()), natural=pb.natural(pk),
                             natural_scaled=pb.natural(pk, True)))
        vv = vref.reshape(-1, 6)[mob, :3]
        out[law] = dict(rows=rows, rms_speed=float(np.sqrt((vv ** 2).sum(1).mean())))
        print(f"{law}: rms grain speed {1e3 * out[law]['rms_speed']:.3f} mm/s at the last sweep")
        for r in rows:
            print(f"  sweep {r['sweep']:6d}: Quad {r['quad']:.1e}, velocities "
                  f"{r['velocity_error']:.3f} from the last sweep's (rms "
                  f"{1e3 * r['rms_speed_error']:.4f} mm/s), impulses {r['impulse_error']:.2f},"
                  f" sliding {r['sliding']}, natural (scaled) {r['natural_scaled']:.1e}",
                  flush=True)
    return out


def setup(scale, steps, scene="mould"):
    """The mould deposit (or, ``scene="peers"``, the peers' deposit of ``make bench-peers``
    at tol 1e-4 with its plain sweeps; ``scale`` unused) stepped ``steps`` times, and the
    next step's problem prepared."""
    sys.path.insert(0, str(HERE.parent))
    sys.path.insert(0, str(HERE))
    from bench_residual import mould_model, peers_model, prepared_step
    from engine import step
    from engine.solver import kernels as K

    if scene == "peers":
        model, state = peers_model(1e-4)
    else:
        model, state = mould_model(scale, True, hot_sweeps=2)
    for _ in range(steps):
        step(model, state)
    s, C, B, L = prepared_step(model, state)
    c = s.contacts_buf
    n, nl = c.count, model.n_links

    def sweep():
        return K.sweep_all(n, c.n_pair, nl, C, B, L, 1.0)
    sweep.C, sweep.B = C, B
    sweep.links = lambda: K.link_sweep(nl, L, B, 1.0)
    return model, s, c, n, sweep


def local_operator(model, c, n):
    """H (3n × 6 nb, u = H v, :func:`engine.solver.kernels.local_velocity`) and M⁻¹ (6 nb)
    as scipy sparse / numpy."""
    import scipy.sparse as sp

    from engine.model import DYN_INV_INERTIA, DYN_INV_MASS, DYN_LINE

    dyn = model.body_dyn
    if dyn[:, DYN_LINE].any():
        raise ValueError("probe_stagnation: scenes with LINE walls are not handled")
    F = c.frame[:n]
    ci, cj = c.i[:n].astype(np.int64), c.j[:n].astype(np.int64)
    ri, rj = c.ri[:n, None], c.rj[:n, None]
    N, T, S = F[:, 0:3], F[:, 3:6], F[:, 6:9]
    rows, cols, vals = [], [], []

    def add(row, body, off, vec):
        for d in range(3):
            rows.append(row)
            cols.append(6 * body + off + d)
            vals.append(np.ascontiguousarray(vec[:, d]))

    a = 3 * np.arange(n)
    add(a, ci, 0, N), add(a, cj, 0, -N)
    add(a + 1, ci, 0, T), add(a + 1, cj, 0, -T), add(a + 1, ci, 3, -ri * S), add(a + 1, cj, 3, -rj * S)
    add(a + 2, ci, 0, S), add(a + 2, cj, 0, -S), add(a + 2, ci, 3, ri * T), add(a + 2, cj, 3, rj * T)
    nb = model.n_bodies
    H = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(3 * n, 6 * nb))
    minv = np.hstack([np.repeat(dyn[:, DYN_INV_MASS], 3).reshape(nb, 3),
                      np.repeat(dyn[:, DYN_INV_INERTIA], 3).reshape(nb, 3)]).ravel()
    return H, minv


def probe_sweeps(model, s, c, n, sweep, nsweeps, H):
    """Part 1 (module doc)."""
    mob = model.body_dyn[:, 0] > 0
    wd = c.w[:n][:, [0, 1, 1]]
    marks = sorted({k for k in (1, 10, 100, 300, 1000, 3000, 10000, 30000) if k < nsweeps}
                   | {nsweeps})
    rows, snap = [], {}
    pv, pp = s.vel6.copy(), c.impulse[:n].copy()
    for k in range(1, nsweeps + 1):
        quad = sweep()
        if k in marks:
            v, p = s.vel6, c.impulse[:n]
            den = np.sqrt(((wd * p) ** 2).sum())
            dv = H @ (v - pv).ravel()
            rows.append(dict(sweep=k, quad=float(quad),
                             diagonal_change=float(np.sqrt(((wd * (p - pp)) ** 2).sum()) / den),
                             full_change=float(np.linalg.norm(dv) / den)))
            snap[k] = v.copy()
        pv, pp = s.vel6.copy(), c.impulse[:n].copy()
    vref = snap[nsweeps]
    uref = np.linalg.norm(H @ vref.ravel())
    for row in rows:
        v = snap[row["sweep"]]
        row["velocity_error"] = float(np.linalg.norm(H @ (v - vref).ravel()) / uref)
        row["max_speed_error"] = float(np.abs(v[mob, :3] - vref[mob, :3]).max())
    k = 1000 if 1000 in snap and nsweeps > 1000 else marks[0]
    e = snap[k] - vref
    e[~mob] = 0.0
    ci, cj = c.i[:n], c.j[:n]
    pair = mob[ci] & mob[cj]
    t = e[:, :3]
    corr = float((t[ci[pair]] * t[cj[pair]]).sum()
                 / (0.5 * ((t[ci[pair]] ** 2).sum() + (t[cj[pair]] ** 2).sum())))
    radius = model.body_dyn[:, 2]
    spin = ((e[:, 3:] ** 2).sum(1) * radius ** 2).sum()
    trans = (t ** 2).sum(1)
    field = dict(at_sweep=k, reference_sweep=nsweeps, neighbour_correlation=corr,
                 spin_share=float(spin / (spin + trans.sum())), cells=[])
    rmean = radius[mob].mean()
    x = s.position
    tm = t[mob]
    for cells in (4, 8, 16):
        key = np.floor(x[mob, :3] / (cells * rmean)).astype(np.int64)
        _, lab = np.unique(key, axis=0, return_inverse=True)
        lab = lab.ravel()
        cnt = np.bincount(lab)
        means = np.stack([np.bincount(lab, tm[:, d]) / cnt for d in range(3)], 1)
        field["cells"].append(dict(cell_radii=cells, clusters=int(cnt.size),
                                   bodies_per_cluster=float(cnt.mean()),
                                   translation_captured=float(
                                       1 - ((tm - means[lab]) ** 2).sum() / (tm ** 2).sum())))
    act = c.impulse[:n, 0] > 0
    z = np.bincount(ci[act], minlength=model.n_bodies) + np.bincount(cj[act], minlength=model.n_bodies)
    order = np.argsort(-trans)
    cum = np.cumsum(trans[order]) / trans.sum()
    half = int(np.searchsorted(cum, 0.5)) + 1
    field.update(half_on_bodies=half, half_on_share=float(half / mob.sum()),
                 their_coordination_median=float(np.median(z[order[:half]])),
                 coordination_median=float(np.median(z[mob])))
    return rows, field


def siconos(npz):
    """Part 3: Siconos's NSGS and ADMM on an exported step (run with Debian's python3)."""
    import scipy.sparse as sp
    import siconos.numerics as sn

    d = np.load(npz)
    W = sp.csc_matrix((d["Wdata"], d["Windices"].astype(np.int64),
                       d["Windptr"].astype(np.int64)), shape=tuple(d["shape"]))
    q, mu = d["q"], d["mu"]
    pb = Problem(W, q, mu)
    fc = sn.FrictionContactProblem(3, mu.size, sn.NumericsMatrix(W), q, mu)
    out = dict(case=str(npz), contacts=int(mu.size), tol=1e-6, solvers={})
    for name, maxit in (("NSGS", 3000), ("ADMM", 1000)):
        o = sn.SolverOptions(getattr(sn, "SICONOS_FRICTION_3D_" + name))
        o.iparam[sn.SICONOS_IPARAM_MAX_ITER] = maxit
        o.dparam[sn.SICONOS_DPARAM_TOL] = 1e-6
        r, u = np.zeros(q.size), np.zeros(q.size)
        t = time.perf_counter()
        sn.fc3d_driver(fc, r, u, o)
        print(f"Siconos {name}: {o.iparam[sn.SICONOS_IPARAM_ITER_DONE]} iterations, "
              f"{time.perf_counter() - t:.1f} s; natural {pb.natural(r):.2e}, outside the cones "
              f"{pb.cone_violation(r):.2e}, natural with W_nn p {pb.natural(r, True):.2e}",
              flush=True)
        out["solvers"][name] = dict(iterations=int(o.iparam[sn.SICONOS_IPARAM_ITER_DONE]),
                                    natural=pb.natural(r), cone_violation=pb.cone_violation(r),
                                    natural_scaled=pb.natural(r, True))
    sys.path.insert(0, str(HERE))
    from record import machine, write

    out["machine"] = machine()
    print("wrote", write("stagnation-siconos", out))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", choices=("mould", "peers"), default="mould",
                    help="the mould deposit (default) or the peers' deposit (bench/peers)")
    ap.add_argument("--scale", type=float, default=0.1)
    ap.add_argument("--step", type=int, default=1, help="engine steps before the probed one")
    ap.add_argument("--sweeps", type=int, default=10000)
    ap.add_argument("--admm-iters", type=int, default=60,
                    help="part 2's ADMM iterations (0: skip it, e.g. at the paper scale, "
                         "where W + I is large to factorise)")
    ap.add_argument("--block", default="", help="part 3: block repeats K, e.g. 1,2,4,8")
    ap.add_argument("--block-budget", type=int, default=3000,
                    help="part 3: contact updates per contact for each variant")
    ap.add_argument("--laws", type=int, default=0,
                    help="part 5: this many contact-space sweeps with the Coulomb and the "
                         "associated law (0: skip)")
    ap.add_argument("--ipm", type=int, default=0,
                    help="part 6: this many De Saxce fixed-point iterations, each an "
                         "interior-point solve (0: skip)")
    ap.add_argument("--export", default=None, help="write the step's problem to this npz")
    ap.add_argument("--siconos", default=None, help="solve an exported npz with Siconos")
    a = ap.parse_args(argv)
    if a.siconos:
        return siconos(a.siconos)
    if a.sweeps < 1000 or a.admm_iters < 0 or a.step < 0 or a.laws < 0 or a.ipm < 0:
        ap.error("--sweeps must be >= 1000, --admm-iters >= 0, --step >= 0, --laws >= 0, --ipm >= 0")
    try:
        repeats = [int(k) for k in a.block.split(",") if k.strip()]
    except ValueError:
        ap.error(f"--block must be a comma-separated list of integers, got {a.block!r}")
    if any(k < 1 or k > 64 for k in repeats) or a.block_budget < 1:
        ap.error("--block repeats must be in [1, 64] and --block-budget >= 1")
    sys.path.insert(0, str(HERE))
    from record import Busy, machine, write

    busy = Busy()
    model, s, c, n, sweep = setup(a.scale, a.step, a.scene)
    H, minv = local_operator(model, c, n)
    vel0, imp0, links0 = s.vel6.copy(), c.impulse.copy(), s.link_impulse.copy()
    print(f"{a.scene}, scale {a.scale}, seed 0, step index {a.step} (after {a.step} engine steps):"
          f" {model.n_bodies} bodies, {n} contacts, {model.n_links} links", flush=True)
    # our answer after 1 000 sweeps, and the problem in contact space with the wire's link
    # impulses held at their values then (in q), as the exported one
    for _ in range(1000):
        sweep()
    ours = c.impulse[:n].ravel().copy()
    vfree = s.vel6.ravel() - minv * (H.T @ ours)
    q = H @ vfree
    q[0::3] += c.gterm[:n]
    import scipy.sparse as sp
    W = (H @ sp.diags(minv) @ H.T).tocsc()
    pb = Problem(W, q, c.mu[:n].copy())
    ours_m = dict(natural=pb.natural(ours), natural_scaled=pb.natural(ours, True))
    s.vel6[:], c.impulse[:], s.link_impulse[:] = vel0, imp0, links0
    t = time.perf_counter()
    rows, field = probe_sweeps(model, s, c, n, sweep, a.sweeps, H)
    print(f"{a.sweeps} sweeps in {time.perf_counter() - t:.0f} s", flush=True)
    vref = s.vel6.copy()
    for r in rows:
        print(f"sweep {r['sweep']:6d}: Quad {r['quad']:.2e}, full ||W dp|| {r['full_change']:.2e}"
              f", velocities {r['velocity_error']:.2f} from the last sweep's (max "
              f"{1e3 * r['max_speed_error']:.2f} mm/s)")
    print("error field:", field)
    run = contact_sweeps(pb) if a.laws or a.ipm else None
    laws = None
    if a.laws:
        laws = probe_laws(model, pb, H, vfree, minv, imp0[:n].ravel().copy(), a.laws, run)
    ipm = None
    if a.ipm:
        def coulomb_from(p):
            quad = run(p.copy(), 1000, False)
            return [(k, float(quad[k - 1])) for k in (1, 10, 100, 1000)]
        ipm = probe_ipm(pb, H, minv, a.ipm, coulomb_from)
    blocks = None
    if a.block:
        blocks = probe_blocks(model, s, c, n, sweep, H, (vel0, imp0, links0), vref,
                              repeats, a.block_budget)
    admm_m = None
    if a.admm_iters:
        t = time.perf_counter()
        r, z, log = admm(pb, 1.0, a.admm_iters)
        admm_m = dict(rho=1.0, iterations=a.admm_iters, seconds=time.perf_counter() - t,
                      log=log, natural_r=pb.natural(r), natural_z=pb.natural(z),
                      cone_violation_r=pb.cone_violation(r),
                      natural_scaled_r=pb.natural(r, True), natural_scaled_z=pb.natural(z, True))
        print("ADMM:", {k: v for k, v in admm_m.items() if k != "log"})
    print("ours after 1 000 sweeps:", ours_m)
    if a.export:
        np.savez(a.export, Wdata=W.data, Windices=W.indices, Windptr=W.indptr,
                 shape=W.shape, q=q, mu=pb.mu, r=ours, gterm=c.gterm[:n].copy(),
                 Hdata=H.tocsr().data, Hindices=H.tocsr().indices, Hindptr=H.tocsr().indptr,
                 Hshape=H.shape, minv=minv, vfree=vfree, mobile=model.body_dyn[:, 0] > 0)
        print("wrote", a.export)
    out = dict(machine=machine(), scene=a.scene, scale=a.scale, seed=0, step_index=a.step,
               bodies=model.n_bodies, contacts=n, sweeps=rows, error_field=field,
               ours_after_1000=ours_m, admm=admm_m, blocks=blocks, laws=laws, ipm=ipm,
               block_budget=a.block_budget if blocks else None, busy=busy.finish())
    print("wrote", write("stagnation", out))


if __name__ == "__main__":
    main()
