"""3D geometric deposit (paper §2.4; Taboada's 2D method extended to 3D).

Each new sphere is put, among every *pocket* of the free surface, at the one that minimises
its potential energy (the lowest centre): a pocket is a position touching three supports —
three spheres, two spheres and a wall, or one sphere and two walls (the floor is a wall) —
where it overlaps nothing already placed (wire beads included), lies inside the container,
and rests stably (gravity is balanced by non-negative normal forces of the three supports).
The tangency position is the closed-form intersection of two planes and a sphere (the
differences of the three sphere equations are planes); a cylinder side is followed by a
fixed point on its tangent plane.

Pockets live in priority queues keyed by a lower bound of the height they give a grain,
one per pair of classes of the smallest and the largest grain they may still take, so each
placement only looks at the lowest pockets of the queues that may take it; a pocket is
dropped once no sample radius fits it (docs/prep.md).  Because the sample is only geometrically admissible, it is meant to be
relaxed under gravity afterwards (:func:`engine.prep.relax`).
"""
from __future__ import annotations

import numpy as np

from ..errors import DepositError
from ._deposit_kernel import deposit_kernel
from .containers import Box, Cylinder

__all__ = ["geometric", "DepositError"]


def _setup(container, r_grain_max, r_all_max):
    if isinstance(container, Box):
        lo, hi = np.array(container.lo), np.array(container.hi)
        wall_n = np.array([[0, 0, 1], [1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0]], float)
        wall_d = np.array([lo[2], lo[0], -hi[0], lo[1], -hi[1]])
        cyl = np.zeros(3)
        box = np.array([lo[0], hi[0], lo[1], hi[1], lo[2]])
        top = hi[2]
    elif isinstance(container, Cylinder):
        c = np.array(container.center)
        R = container.radius
        wall_n = np.array([[0, 0, 1], [0, 0, 0]], float)
        wall_d = np.array([c[2], 0.0])
        cyl = np.array([c[0], c[1], R])
        box = np.array([c[0] - R, c[0] + R, c[1] - R, c[1] + R, c[2]])
        lo, hi = c - (R, R, 0), c + (R, R, container.height)
        top = hi[2]
    else:
        raise ValueError(f"container must be engine.prep.Box or Cylinder for a geometric "
                         f"deposit, got {container!r}")
    h = r_grain_max + r_all_max
    gn = np.maximum(np.ceil((hi - lo) / h).astype(np.int64), 1)
    if np.prod(gn) > 5e7:
        raise ValueError(f"container {container!r} is too large for grains of radius "
                         f"{r_grain_max:.3g} m ({np.prod(gn):.3g} grid cells)")
    return wall_n, wall_d, cyl, box, float(top), lo, 1.0 / h, gn


def geometric(radii, container, *, obstacles=None, seed: int = 0, reach: float | None = None,
              support: bool = True, max_pockets: int = 1 << 27, info: dict | None = None):
    """Place spheres of the given radii in a container by the 3D geometric deposit.

    Parameters
    ----------
    radii : (n,) [m], > 0
        Grain radii; they are placed in a random order drawn from ``seed``.
    container : engine.prep.Box | engine.prep.Cylinder
        The floor is its bottom; nothing goes above its top.
    obstacles : ((m, 3) centres [m], (m,) radii [m]), optional
        Spheres already there (the wire beads): grains never overlap them and may rest on them.
    support : bool
        Whether grains may rest on obstacles (True) or only avoid them (False).
    seed : int
        The placement order (and the first grain's spot on an empty floor).
    reach : float [m], optional
        Pockets are formed by supports at most 2·reach apart (gap between surfaces).  Default:
        the largest grain radius; smaller is faster and a little looser.
    max_pockets : int
        Memory cap on the number of pockets kept.
    info : dict, optional
        Filled with ``placed`` and ``dropped``: grains that found no pocket and were dropped
        vertically where they land lowest (resting on one support until relaxed).

    Returns
    -------
    centers : (n, 3) [m];  radii : (n,) [m] in placement order.

    Raises
    ------
    DepositError
        Not every grain fits below the container's top; says how many were placed, and the
        exception carries them.
    ValueError
        Bad input (naming the field).
    """
    r = np.asarray(radii, dtype=float).ravel()
    if r.size == 0 or not np.all(np.isfinite(r)) or np.any(r <= 0):
        raise ValueError("radii must be a non-empty array of finite values > 0 [m]")
    if obstacles is not None:
        oc = np.asarray(obstacles[0], dtype=float).reshape(-1, 3)
        orad = np.broadcast_to(np.asarray(obstacles[1], dtype=float), (oc.shape[0],)).copy()
        if not (np.all(np.isfinite(oc)) and np.all(np.isfinite(orad)) and np.all(orad > 0)):
            raise ValueError("obstacles must be finite centres (m, 3) [m] and radii > 0 [m]")
    else:
        oc, orad = np.zeros((0, 3)), np.zeros(0)
    rng = np.random.default_rng(seed)
    order = rng.permutation(r.size)
    r = r[order]
    reach = float(r.max() if reach is None else reach)
    if not (np.isfinite(reach) and reach > 0):
        raise ValueError(f"reach must be finite and > 0 [m], got {reach!r}")
    r_all = max(r.max(), orad.max() if orad.size else 0.0)
    wall_n, wall_d, cyl, box, top, glo, inv_h, gn = _setup(container, r.max(), r_all)
    if 2 * r.max() > top - box[4]:
        raise ValueError(f"the largest grain (radius {r.max():.4g} m) is taller than the container")
    m = oc.shape[0]
    X = np.concatenate([oc[:, 0], np.zeros(r.size)])
    Y = np.concatenate([oc[:, 1], np.zeros(r.size)])
    Z = np.concatenate([oc[:, 2], np.zeros(r.size)])
    R = np.concatenate([orad, r])
    # floor points in a random order: where a grain goes when no pocket takes it
    step = r.min()
    gx = np.arange(box[0] + step, box[1], step)
    gy = np.arange(box[2] + step, box[3], step)
    pts = np.stack(np.meshgrid(gx, gy, indexing="ij"), -1).reshape(-1, 2)
    pts = pts[rng.permutation(pts.shape[0])]
    placed, status, dropped = deposit_kernel(r, m, X, Y, Z, R, wall_n, wall_d, wall_n.shape[0], cyl, box,
                                    top, glo, inv_h, gn, reach, pts, max_pockets,
                                    bool(support))
    if info is not None:
        info.update(placed=int(placed), dropped=int(dropped))
    centers = np.stack([X[m:m + placed], Y[m:m + placed], Z[m:m + placed]], 1)
    if status != 0:
        why = ("no pocket or floor spot is left below the container's top"
               if status == 1 else f"the pocket memory cap (max_pockets={max_pockets}) was hit")
        raise DepositError(f"geometric deposit placed {placed} of {r.size} grains: {why}",
                           placed, centers, r[:placed])
    return centers, r
