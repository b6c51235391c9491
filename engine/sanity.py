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
* spheres that went through a plane they interact with (centre behind it by more than the
  radius, :func:`through_planes`): a :class:`~engine.step.SimulationError` naming them.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .model import FREE

#: Overlap [fraction of the smaller radius] above which a run's summary warns.
OVERLAP_WARN = 0.05


class PhysicsWarning(RuntimeWarning):
    """A run left the range where its results can be trusted (overlaps above
    :data:`OVERLAP_WARN`)."""


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
def through_planes(pos, radius, group, sphere_ids, planes, pair_law, axis, dof):
    """(sphere, plane) of the first free sphere (``dof``: a driven or fixed one goes where
    it is told) whose centre is behind a plane it interacts with by more than its radius,
    or (-1, -1)."""
    for p in planes:
        nx, ny, nz = axis[p, 0], axis[p, 1], axis[p, 2]
        px, py, pz = pos[p, 0], pos[p, 1], pos[p, 2]
        gp = group[p]
        for b in sphere_ids:
            if pair_law[group[b], gp] < 0 or dof[b] != FREE:
                continue
            d = (pos[b, 0] - px) * nx + (pos[b, 1] - py) * ny + (pos[b, 2] - pz) * nz
            if d < -radius[b]:
                return b, p
    return -1, -1


__all__ = ["max_overlap", "through_planes", "OVERLAP_WARN", "PhysicsWarning"]
