"""Kinetic energy of a state."""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _kinetic_energy(vel6, mass, inertia, ids):
    e = 0.0
    for b in ids:
        v = vel6[b]
        e += 0.5 * (mass[b] * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
                    + inertia[b] * (v[3] * v[3] + v[4] * v[4] + v[5] * v[5]))
    return e


def kinetic_energy(model, state, bodies=None) -> float:
    """Σ ½ m v² + ½ I ω² [J] over ``bodies`` (ids; default every sphere, walls excluded)."""
    ids = model.sphere_ids if bodies is None else np.ascontiguousarray(bodies, dtype=np.int64)
    return float(_kinetic_energy(state.vel6, model.body_mass, model.body_inertia, ids))
