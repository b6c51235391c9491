"""Contact detection: cell-grid broadphase with a Verlet skin, then the narrowphase.

Public stage: :func:`detect` ``(model, state)``.
"""
from __future__ import annotations

import numpy as np

from ..threads import numba_threads
from .broadphase import (build_pairs_ordered, build_pairs_parallel, cell_sort, max_displacement,
                         max_speed)
from .narrowphase import late_pairs_exist, narrowphase, narrowphase_parallel, tangent_frame
from ..errors import SimulationError

#: Fewest spheres for which ``threads > 1`` also runs the broadphase and the sphere–sphere
#: narrowphase on several threads (below it, one thread: the threads' start-up costs more
#: than the work; measured in ``bench/bench_parallel.py``).
PARALLEL_DETECT_MIN_SPHERES = 2048


def _detect_threads(model) -> int:
    """Threads for the detection stages: ``Options.threads`` above
    :data:`PARALLEL_DETECT_MIN_SPHERES` spheres, else 1."""
    T = model.options.threads
    return T if T > 1 and model.n_spheres >= PARALLEL_DETECT_MIN_SPHERES else 1

__all__ = ["detect", "rebuild_pairs", "tangent_frame", "late_contacts_possible"]


def late_contacts_possible(model, state, free) -> bool:
    """Whether the solve may have closed a pair that the free velocities ``free`` left open.

    ``state.vel6`` holds the solved velocities.  First a global bound: when no body's
    velocity changed by more than alert / (2 h), :func:`engine.step.step` skips the second
    look (a pair it could miss then ends the step overlapping by less than the alert
    distance, and is a contact the next step).  Otherwise the candidate pairs of the bodies
    that changed are tested exactly (:func:`narrowphase.late_pairs_exist`): whether the
    solved velocities close a pair that the free ones left open.
    """
    o = model.options
    found = late_pairs_exist(state.position, free, state.vel6, model.body_radius,
                             model.body_kind, model.body_group, model.body_axis,
                             model.body_height, model.body_caps, model.pair_law, state.pairs,
                             state.n_pairs, model.sphere_ids, model.wall_ids, o.alert, o.dt)
    if found != 1:
        return found == 2
    # nothing found among the candidates, but do they cover the solved motion?
    return state.pairs_ref is None or max_displacement(
        state.position, state.pairs_ref, state.vel6, model.sphere_ids, o.dt) > 0.5 * o.skin


def rebuild_pairs(model, state, lookahead: float = 0.0) -> None:
    """Rebuild the candidate sphere–sphere pairs (surface distance < alert + skin, or
    < alert + 2 ``lookahead`` [m] when that is larger).

    ``lookahead`` is h times the largest sphere speed of the step (:func:`detect`): two
    spheres approaching each other can close up to 2 h v within the step, and with a fixed
    margin fast spheres (h v > skin/2, an impact at a large time step) could pass through
    each other unseen.

    The buffer ``state.pairs`` grows until every pair fits (none is dropped).  With
    ``Options.threads > 1`` (and enough spheres, :func:`_detect_threads`) the grid search runs
    on that many threads, with the same list as one thread.
    """
    o = model.options
    margin = o.alert + max(o.skin, 2.0 * float(lookahead))
    # NaN/Inf, or so far away (1e6 m) that the grid extent overflows: the run blew up
    bad = ~(np.abs(state.position[model.sphere_ids]) < 1e6).all(axis=1)
    if bad.any():
        ids = model.sphere_ids[bad]
        raise SimulationError(
            f"step {state.step + 1}: the predicted positions of {bad.sum()} bodies are not "
            f"finite or beyond 1e6 m (bodies {ids[:10].tolist()}{' ...' if ids.size > 10 else ''}): the "
            f"velocities blew up; lower dt or check the loads")
    order = _build_pairs(model, state, state.position, margin)
    state.pairs_ref = state.position.copy()
    state.pairs_margin = margin
    state.workspace.sphere_order = (state.pairs_ref, order)


def _build_pairs(model, state, position, margin) -> np.ndarray:
    """Fill ``state.pairs`` / ``n_pairs`` with the candidate pairs at ``position`` within
    ``margin``; returns the spheres' cell order."""
    order = np.empty(model.n_spheres, np.int32)
    T = _detect_threads(model)
    while True:
        args = (position, model.body_radius, model.body_group, model.pair_law,
                state.link_excluded_next, model.sphere_ids, margin, state.pairs, order)
        if T > 1:
            with numba_threads(T) as used:
                n, need = build_pairs_parallel(used, *args)
        else:
            n = need = build_pairs_ordered(*args)
        if need <= state.pairs.shape[0]:
            break
        state.pairs = np.zeros((int(need * 1.3) + 64, 2), np.int32)
    state.n_pairs = n
    return order


def restore_pairs(model, state, ref, margin, n_pairs) -> None:
    """Put back the candidate list built at positions ``ref`` with ``margin`` (the list a
    step being undone replaced, :func:`engine.step.run`): the same pairs, in the same
    order, as that build gave."""
    _build_pairs(model, state, ref, margin)
    if state.n_pairs != n_pairs:  # the build is a function of (ref, margin): never seen
        raise RuntimeError(f"restore_pairs: {state.n_pairs} pairs, the build had {n_pairs}")


def _sphere_order(model, state) -> np.ndarray:
    """The spheres in the cell order of the last broadphase build (the order in which the
    narrowphase visits sphere–wall pairs).  A pure function of ``state.pairs_ref`` (the
    positions of that build): cached beside it, recomputed after a checkpoint load or a
    copy, with the same result."""
    cached = state.workspace.sphere_order
    if cached is not None and cached[0] is state.pairs_ref:
        return cached[1]
    if state.pairs_ref is None or model.n_spheres < 2:
        return model.sphere_ids
    radius = model.body_radius[model.sphere_ids]
    margin = state.pairs_margin or (model.options.alert + model.options.skin)
    order = cell_sort(state.pairs_ref, model.sphere_ids, 2.0 * float(radius.max()) + margin)[3]
    state.workspace.sphere_order = (state.pairs_ref, order)
    return order


def detect(model, state, solved=None) -> bool:
    """Find the active contacts at the current configuration (stage 2 of :func:`engine.step`).

    Called when ``state.position`` holds the θ-predicted configuration
    q_i + (1-θ) h v_i and ``state.vel6`` the free velocities.  Rebuilds the candidate list
    when a sphere has moved (or will move within this step) more than skin/2 since the last
    build.  Fills ``state.contacts_buf`` (grown as needed; nothing is dropped).  With
    ``Options.threads > 1`` the sphere–sphere pairs are tested on that many threads; the
    contacts and their order are those of one thread.

    ``solved`` (``(nb, 6)`` velocities, or None): after a solve, a pair that these
    velocities bring within the alert distance in the step is active as well (the free
    velocities stay in ``state.vel6``).  :func:`engine.step.step` calls it so when
    :func:`late_contacts_possible` says the solve may have closed a new pair.

    Returns
    -------
    bool
        True if the candidate list was rebuilt.
    """
    o = model.options
    h = o.dt
    rebuilt = False
    sph = model.sphere_ids
    moved = (np.inf if state.pairs_ref is None
             else max_displacement(state.position, state.pairs_ref, state.vel6, sph, h))
    if solved is not None and moved <= 0.5 * o.skin:
        moved = max_displacement(state.position, state.pairs_ref, solved, sph, h)
    if moved > 0.5 * o.skin:
        look = h * max_speed(state.vel6, sph)
        if solved is not None:
            look = max(look, h * max_speed(solved, sph))
        rebuild_pairs(model, state, look)
        rebuilt = True
    c = state.contacts_buf
    spheres = _sphere_order(model, state)
    T = _detect_threads(model)
    while True:
        args = (state.position, state.vel6, state.vel6 if solved is None else solved,
                solved is not None, model.body_radius, model.body_kind,
                model.body_group, model.body_axis, model.body_height, model.body_caps,
                model.pair_law, model.law_param, state.pairs, state.n_pairs,
                spheres, model.wall_ids, o.alert, h,
                c.i, c.j, c.sub, c.key, c.frame, c.gap, c.mu, c.ri, c.rj)
        if T > 1:
            with numba_threads(T) as used:
                k, n_pair, need = narrowphase_parallel(used, *args)
        else:
            k, n_pair = narrowphase(*args)
            need = k
        if need <= c.cap:
            break
        c.allocate(int(need * 1.3) + 64)
    c.count = k
    c.n_pair = n_pair
    return rebuilt
