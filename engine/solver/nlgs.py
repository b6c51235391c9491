"""Nonlinear Gauss–Seidel (NLGS) on the contacts of one step (Eq. 5).

For each contact α in turn, the sweep computes the current local velocity from the body
velocities, removes its own contribution W_αα p_α to get the local free velocity, calls the
local solver of its law (:mod:`engine.solver.local`) and applies the impulse change to the
two bodies at once (so the next contact sees it: Gauss–Seidel).  Wire links join the same
sweep, after the contacts, in the wire issue.

Convergence ("Quad" norm, as LMGC90's ``Quad`` check): after each sweep,

    residual = sqrt( Σ_α ‖W_αα Δp_α‖² / Σ_α ‖W_αα p_α‖² ),

the root-mean-square change of local velocity produced by the sweep relative to the
root-mean-square local velocity that the impulses carry.  The step has converged when
``residual < tol``.  A sweep that leaves every impulse at zero has residual 0.
"""
from __future__ import annotations

import numpy as np

from ..stop import in_chunks
# the kernels (engine.solver.kernels), also reachable here by their old names
from .kernels import (HOT_FACTOR, Bodies, Contacts, Links, _apply, _apply_link, _contact, _full,
                      _iterate_hot, _line_factor, _local_index, _span, hot_list, iterate,
                      iterate_hot, layout, link_prepare, link_sweep, link_update,
                      links_then_residual, lstar, prepare, resweep_hot, sweep, sweep_all,
                      warm_index, warm_store)  # noqa: F401


#: Scenes with at least this many bodies are swept on the local layout of :func:`layout`
#: (below, every body row stays in cache anyway and the gather/scatter would only cost).
LAYOUT_MIN_BODIES = 4096


def solve(model, state, break_links: bool = True):
    """NLGS stage of :func:`engine.step` on the contacts found by :func:`engine.contact.detect`.

    Warm-starts from the previous step, sweeps to ``tol``/``max_iter``, updates
    ``state.vel6`` in place and stores the impulses for the next warm start.  Brittle links
    over their maximum tension then break (:func:`break_links`), unless ``break_links`` is
    False (:func:`engine.step.step` breaks them once, after its last solve of the step).

    With ``options.threads == 1`` (the default) the sweep is the serial Gauss–Seidel of
    :func:`iterate`; scenes of :data:`LAYOUT_MIN_BODIES` bodies or more run it on a local
    copy of the body data in contact order (:func:`layout`; bit-identical results).  With
    ``threads > 1`` it is the domain-decomposed Gauss–Seidel of
    :mod:`engine.solver.parallel`.

    Returns
    -------
    (iterations, residual) : (int, float)
    """
    o = model.options
    c = state.contacts_buf
    n = c.count
    nl = model.n_links
    threads = o.threads
    if threads == 1 and model.n_bodies < LAYOUT_MIN_BODIES:
        it, res = _solve_on(model, state, c.i, c.j, model.body_dyn, state.vel6, state.position,
                            model.link_i, model.link_j, 1)
    else:
        nb = model.n_bodies
        loc = np.full(nb, -1, np.int32)
        perm = np.empty(nb, np.int32)
        li = np.empty(n, np.int32)
        lj = np.empty(n, np.int32)
        lli = np.empty(nl, np.int32)
        llj = np.empty(nl, np.int32)
        k = layout(n, c.i, c.j, nl, model.link_i, model.link_j, loc, perm, li, lj, lli, llj)
        p = perm[:k]
        vel = state.vel6[p]
        pos = state.position[p] if nl else state.position[:0]
        it, res = _solve_on(model, state, li, lj, model.body_dyn[p], vel, pos, lli, llj, threads)
        state.vel6[p] = vel
    state.warm_key, state.warm_impulse = warm_store(n, c.key, c.frame, c.impulse, model.n_bodies)
    if nl and break_links:
        _break_links(model, state, o.dt)
    return int(it), float(res)


def _solve_on(model, state, ci, cj, body_dyn, vel6, pos, link_i, link_j, threads):
    """prepare, link_prepare and iterate on the given body numbering (global or local).

    The sweeps take the arrays as three named tuples built here once
    (:class:`~engine.solver.kernels.Contacts`, :class:`~engine.solver.kernels.Bodies`,
    :class:`~engine.solver.kernels.Links`)."""
    o = model.options
    c = state.contacts_buf
    n = c.count
    nl = model.n_links
    prepare(n, ci, cj, c.key, c.frame, c.gap, c.ri, c.rj, c.w, c.gterm, c.impulse,
            body_dyn, vel6, state.warm_key, state.warm_impulse, o.dt, model.n_bodies,
            o.contact_compliance)
    wl = _EMPTY_WL
    if nl:
        wl = np.empty((nl, LINK_COLUMNS))
        link_prepare(nl, link_i, link_j, model.link_ref_length, model.link_stiffness,
                     state.link_broken, pos, body_dyn, vel6,
                     state.link_impulse, state.link_normal, state.link_gap, wl, o.dt)
    C = Contacts(ci, cj, c.frame, c.w, c.gterm, c.mu, c.ri, c.rj, c.impulse)
    B = Bodies(body_dyn, vel6)
    L = Links(link_i, link_j, state.link_normal, wl, model.link_unilateral, state.link_impulse,
              model.link_order)
    from .chains import chains_for, iterate_chains

    # the links' phase: each wire's chain solved (Options.chain_solve), or the link sweep
    chains = chains_for(o.chain_solve, nl, link_i, link_j)
    if o.chain_solve and nl and threads == 1 and o.anderson == 0:
        nc, cw = chains
        q, hot = np.empty(n), np.empty(n, np.int32)
        return in_chunks(lambda done, m: iterate_chains(
            n, c.n_pair, nc, C, B, L, cw, o.relax, o.tol, m, done, o.hot_sweeps, HOT_FACTOR,
            q, hot), o.max_iter, o.tol, n + nl)
    ws = None
    if o.anderson > 0:
        from .anderson import Workspace, run_anderson

        ws = state.workspace.anderson
        if ws is None:
            ws = state.workspace.anderson = Workspace()
        if threads == 1:
            return in_chunks(lambda done, m: run_anderson(
                ws, o.anderson, n, c.n_pair, nl, C, B, L, o.relax, o.tol, o.max_iter,
                it0=done, it1=done + m, chains=chains), o.max_iter, o.tol, n + nl)
    if o.hot_sweeps > 0 and threads == 1:  # unmixed (Options refuses anderson > 0)
        q, hot = np.empty(n), np.empty(n, np.int32)
        return in_chunks(lambda done, m: iterate_hot(
            n, c.n_pair, nl, C, B, L, o.relax, o.tol, m, o.hot_sweeps, HOT_FACTOR, q, hot),
            o.max_iter, o.tol, n + nl)
    if threads == 1:
        return in_chunks(lambda done, m: iterate(n, c.n_pair, nl, C, B, L, o.relax, o.tol, m),
                         o.max_iter, o.tol, n + nl)
    from .parallel import iterate_parallel

    mix = None
    if o.anderson > 0:
        from .anderson import domain_mixer

        mix = domain_mixer(ws, o.anderson, o.max_iter, o.tol, nl, L)
    return iterate_parallel(threads, n, nl, C, B, L, o.relax, o.tol, o.max_iter, mix,
                            o.hot_sweeps, chains)


#: Columns of the per-link work array ``wl`` filled by :func:`link_prepare`.
LINK_COLUMNS = 6
_EMPTY_WL = np.zeros((0, LINK_COLUMNS))


def _break_links(model, state, h: float) -> None:
    """Brittle wires: links whose tension of this step exceeds their maximum break for good
    (their beads then touch like any two spheres: the candidate list is rebuilt)."""
    over = (~state.link_broken) & (state.link_impulse > model.link_max_tension * h)
    if over.any():
        state.link_broken |= over
        state.link_excluded_next[model.link_i[over]] = -1
        state.pairs_ref = None  # rebuild the candidate pairs with the freed beads
