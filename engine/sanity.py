"""What the engine checks of its own results after each step (issue 33 item 5).

A rigid-body NSCD step may end with small overlaps (the velocity Signorini condition holds
at the predicted configuration, not exactly at the end); large ones mean the time step is
too coarse for the speeds, the loads or the masses.  :func:`engine.step.run` looks after
each step at:

* the largest overlap of the step's contacts, as a fraction of the smaller radius of the
  two bodies (:func:`max_overlap`; a sphere–wall contact: the sphere's radius), free
  spheres only (a driven or fixed one goes where it is told).  Above
  :data:`OVERLAP_WARN` the run's summary says so (and a :class:`PhysicsWarning` is issued
  once); above ``Options.max_overlap`` the run stops with a
  :class:`engine.step.SimulationError` naming the step and the two bodies;
* spheres that went through a wall they interact with (:func:`through_walls`: a centre
  behind a plane by more than the radius, outside a cylinder, or beyond a closed end cap):
  a :class:`~engine.step.SimulationError` naming them;
* the kinetic energy the reactions added to the free motion (:func:`reaction_gain`), which
  contacts and rigid links can only take away: when a scene has no other source of energy
  (:func:`energy_sources`) and a step's gain passes :data:`ENERGY_WARN` of the free
  motion's kinetic energy, the summary says so and a :class:`PhysicsWarning` is issued.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .errors import PhysicsWarning  # noqa: F401  (its home until 2026-12-05)
from .model import CAP_BOTTOM, CAP_TOP, FREE, PLANE

#: Overlap [fraction of the smaller radius] above which a run's summary warns.
OVERLAP_WARN = 0.05

#: Relative motion of two touching bodies in one step [fraction of the smaller radius]
#: beyond which the stop's advice is a smaller ``dt`` (:func:`overlap_advice`).
TRAVEL_WARN = 0.05

#: Kinetic energy the reactions may add to the free motion in one step, as a fraction of
#: the free motion's own, before a run's summary warns (:func:`reaction_gain`: in exact
#: arithmetic they add none; measured: never above 0 on falling piles at tol 1e-2 to 1e-8,
#: at most -0.27 % of it on a sand + rigid-wire box, exactly 0 in steps without contacts;
#: 1e-6 is a margin for roundoff).  Rigid links are looked at for a stretch (prestrain) at
#: the start of a run only.
ENERGY_WARN = 1e-6


def overlap_advice(options, travel: float | None = None) -> str:
    """What to change when overlaps grow (the warning's and the stop's advice): without the
    position correction, turn it on; with it, what is left is one step's sinking: a tighter
    ``tol`` (the solve leaves a closing velocity each step), or a smaller ``dt`` if bodies
    move fast.  ``travel``: how far the two bodies of the worst contact move against each
    other in one step, as a fraction of the smaller radius; past :data:`TRAVEL_WARN` the
    step is too coarse for their speed, and a ``dt`` that would bring it there comes
    first."""
    if travel is not None and travel > TRAVEL_WARN:
        dt = options.dt * TRAVEL_WARN / travel
        return (f"the two bodies move {100 * travel:.3g} % of a radius against each other in "
                f"one step of dt = {options.dt:g} s: lower dt to {dt:.2g} s or less (or check "
                f"loads and masses)")
    if options.overlap_tol is None:
        return (f"set overlap_tol = 0.005 (overlaps pushed out after each step), or lower "
                f"tol = {options.tol:g}; lower dt = {options.dt:g} s only if bodies move "
                f"fast; or check loads and masses")
    return (f"each step sinks them again before the correction (overlap_tol = "
            f"{options.overlap_tol:g}): lower tol = {options.tol:g}, or dt = {options.dt:g} s "
            f"if bodies move fast; or check loads and masses")


@njit(cache=True)
def max_overlap(n, gap, ri, rj, c_i, dof):
    """(largest overlap / smaller radius over the ``n`` contacts, its contact index; -1
    without overlap).  ``rj`` is 0 for a wall.  Contacts whose sphere ``c_i`` moves as
    imposed (``dof`` not FREE: fixed or driven, which contacts do not stop) are left out."""
    best = 0.0
    at = -1
    for a in range(n):
        g = gap[a]
        if g < 0.0 and dof[c_i[a]] == FREE:
            r = ri[a]
            if rj[a] > 0.0 and rj[a] < r:
                r = rj[a]
            o = -g / r
            if o > best:
                best = o
                at = a
    return best, at


@njit(cache=True)
def through_walls(pos, radius, group, sphere_ids, walls, pair_law, kind, axis, height, caps,
                  dof):
    """(sphere, wall, where) of the first free sphere (``dof``: a driven or fixed one goes
    where it is told) that went through a wall it interacts with, or (-1, -1, 0).

    ``where``: 0 behind a plane (its centre behind the plane by more than its radius);
    1 outside a cylinder's side wall (centre between the ends, farther from the axis than
    the radius plus its own: the wall holds spheres inside only, one outside is pulled
    through it); 2 and 3 through a closed bottom or top end cap (centre inside the radius,
    beyond the cap by more than its own radius)."""
    for w in walls:
        ax, ay, az = axis[w, 0], axis[w, 1], axis[w, 2]
        px, py, pz = pos[w, 0], pos[w, 1], pos[w, 2]
        gw = group[w]
        cyl = kind[w] != PLANE
        R = radius[w]
        H = height[w]
        for b in sphere_ids:
            if pair_law[group[b], gw] < 0 or dof[b] != FREE:
                continue
            dx = pos[b, 0] - px
            dy = pos[b, 1] - py
            dz = pos[b, 2] - pz
            r = radius[b]
            d = dx * ax + dy * ay + dz * az
            if not cyl:
                if d < -r:
                    return b, w, 0
                continue
            rx = dx - d * ax
            ry = dy - d * ay
            rz = dz - d * az
            rho = np.sqrt(rx * rx + ry * ry + rz * rz)
            if 0.0 <= d <= H:
                if rho > R + r:
                    return b, w, 1
            elif rho < R:
                if d < -r and (caps[w] & CAP_BOTTOM) != 0:
                    return b, w, 2
                if d > H + r and (caps[w] & CAP_TOP) != 0:
                    return b, w, 3
    return -1, -1, 0


@njit(cache=True, fastmath=True)   # a diagnostic sum: reassociation is fine, 2x faster
def reaction_gain(vel6, free, mass, inertia, sphere_ids, dof):
    """(kinetic energy of the free spheres at the end of the step minus that of their free
    motion, the latter) [J].

    The step solves M (v⁺ − v_free) = R for the reactions R (Eq. 4-6), so the first number
    is R · (v⁺ + v_free) / 2, the work of the reactions.  For frictional contacts
    (Signorini at the velocity level with the gap term g/h >= 0, Coulomb's maximal
    dissipation) and rigid links without prestrain it is <= 0 whatever the tolerance:
    R · (v⁺ + v_free)/2 = R · U⁺ − ½ Rᵀ W R with R · U⁺ <= 0 and W (Delassus) positive
    semi-definite.  A positive value then means the solve failed.  Elastic or prestrained
    links (stored energy) and drives (moving walls or beads) may add energy legitimately
    (:func:`energy_sources`)."""
    gain = 0.0
    base = 0.0
    for b in sphere_ids:
        if dof[b] != FREE:
            continue
        m = mass[b]
        ii = inertia[b]
        kp = m * (vel6[b, 0] ** 2 + vel6[b, 1] ** 2 + vel6[b, 2] ** 2) \
            + ii * (vel6[b, 3] ** 2 + vel6[b, 4] ** 2 + vel6[b, 5] ** 2)
        kf = m * (free[b, 0] ** 2 + free[b, 1] ** 2 + free[b, 2] ** 2) \
            + ii * (free[b, 3] ** 2 + free[b, 4] ** 2 + free[b, 5] ** 2)
        gain += 0.5 * (kp - kf)
        base += 0.5 * kf
    return gain, base


def energy_sources(model, state) -> str | None:
    """Why the reactions of ``model`` may add kinetic energy from ``state`` on (drives,
    elastic links, rigid links stretched past their reference length by a prestrain,
    compliant contacts, whose springs give back what they stored), in words, or None: then
    :func:`reaction_gain` must be <= 0."""
    why = []
    if model.drives:
        why.append("driven bodies")
    if model.options.contact_compliance > 0.0:
        why.append("compliant contacts")
    if model.n_links:
        k = model.link_stiffness
        if (np.isfinite(k) & (k > 0)).any():
            why.append("elastic links")
        d = state.position[model.link_i] - state.position[model.link_j]
        g = np.sqrt((d * d).sum(axis=1))
        rigid = ~np.isfinite(model.link_stiffness)
        if (g[rigid] > model.link_ref_length[rigid] * (1 + 1e-6)).any():
            why.append("stretched rigid links")
    return ", ".join(why) or None


#: The ``where`` codes of :func:`through_walls` in words.
THROUGH = {0: "went through plane {w} (its centre is behind the plane by more than its "
              "radius)",
           1: "is outside cylinder {w} (between its ends, farther from the axis than the "
              "cylinder's radius plus its own; the cylinder holds spheres inside only)",
           2: "went through the bottom cap of cylinder {w}",
           3: "went through the top cap of cylinder {w}"}


__all__ = ["overlap_advice", "TRAVEL_WARN", "max_overlap", "through_walls", "THROUGH", "reaction_gain",
           "energy_sources", "ENERGY_WARN", "OVERLAP_WARN", "PhysicsWarning"]
