"""Drivers: imposed velocity, imposed force and imposed pressure on bodies.

* velocity: the body's translational velocity is imposed (a constant (3,) [m/s] or a
  callable of time); it does not rotate and no force moves it.
* force: a constant or time-dependent force [N] added to the body's external force.  On a
  wall, the wall then moves along the force's line of action only, with its own mass.
* pressure: on a plane, the force p · A · n [N] along the plane normal n (towards the
  spheres), A [m²] the current wall area (a constant, or a callable ``(model, state)``
  re-evaluated every step); the plane moves along n with its own mass.

Walls feel no gravity; a driven wall's mass only sets its inertia.
"""
from __future__ import annotations

import numpy as np


def _vector(value, what: str) -> np.ndarray:
    v = np.asarray(value, dtype=float)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{what} must be 3 finite numbers, got {value!r}")
    return v


def drive_forces(model, state) -> None:
    """Fill ``state.force`` [N] with the force and pressure drives at the current time."""
    f = state.force
    f[:] = 0.0
    t = state.time
    for d in model.drives:
        if d.kind == "force":
            f[d.body] += _vector(d.at(t), f"force drive on body {d.body} at t={t:g} s")
        elif d.kind == "pressure":
            p = float(d.at(t))
            area = float(d.area(model, state)) if callable(d.area) else float(d.area)
            if not np.isfinite(area) or area < 0.0:
                raise ValueError(f"pressure drive on body {d.body}: area must be finite and "
                                 f">= 0 m², got {area!r} at t={t:g} s")
            f[d.body] += p * area * model.body_axis[d.body]


def drive_velocities(model, state, t: float) -> None:
    """Set the imposed velocities at time ``t`` [s]."""
    for d in model.drives:
        if d.kind == "velocity":
            state.vel6[d.body, :3] = _vector(d.at(t), f"velocity drive on body {d.body} at t={t:g} s")
