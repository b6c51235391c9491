"""Validation cases with closed-form answers, shared by the tests and the benchmarks.

Each function builds a small scene, runs it and returns what it measured next to the
closed form, so that an accuracy test and a speed/accuracy benchmark use the same case.
"""
from __future__ import annotations

import numpy as np

from . import laws
from .scene import Scene
from .step import step


def beaded_string(n_free: int = 15, stiffness: float = 1.0, prestrain: float = 0.01,
                  bead_radius: float = 1e-3, density: float = 2000.0, dt: float = 5e-4,
                  theta: float = 0.5, amplitude: float = 1e-3, periods: float = 2.0,
                  tol: float = 1e-12) -> dict:
    """First transverse mode of a taut beaded string (elastic wire, both ends fixed).

    ``n_free`` beads of mass m between two fixed beads, spacing a = 2.2 r, tension
    T = k ε₀ (the prestrain of Eq. 7), no gravity; the first mode is excited by transverse
    velocities amplitude·sin(nπ/(N+1)) [m/s].  The closed form is
    ω₁ = 2 √(T/(m a)) sin(π/(2(N+1))).  The frequency is measured from the upward zero
    crossings of the middle bead's transverse displacement.

    Returns
    -------
    dict with ``omega`` (measured) and ``omega_exact`` [rad/s], ``rel_error`` [-],
    ``steps``, ``iterations`` (mean NLGS sweeps per step).
    """
    a = 2.2 * bead_radius
    x = np.arange(n_free + 2) * a
    s = Scene(gravity=(0.0, 0.0, 0.0))
    b = s.add_wire(np.column_stack([x, np.zeros_like(x), np.zeros_like(x)]), radius=bead_radius,
                   density=density, group="wire",
                   law=laws.ElasticWire(stiffness=stiffness, prestrain=prestrain))
    s.interact("wire", "wire", None)
    s.fix(b[[0, -1]])
    model, state = s.compile(dt=dt, theta=theta, tol=tol, max_iter=10000)
    n = np.arange(1, n_free + 1)
    state.vel6[b[1:-1], 2] = amplitude * np.sin(n * np.pi / (n_free + 1))
    m = model.body_mass[b[1]]
    w_exact = 2 * np.sqrt(stiffness * prestrain / (m * a)) * np.sin(np.pi / (2 * (n_free + 1)))
    mid = b[(n_free + 1) // 2]
    steps = int(periods * 2 * np.pi / w_exact / dt) + 10
    z = np.empty(steps)
    t = np.empty(steps)
    its = 0
    for k in range(steps):
        its += step(model, state).iterations
        z[k] = state.position[mid, 2]
        t[k] = state.time
    up = np.flatnonzero((z[:-1] < 0) & (z[1:] >= 0))
    if up.size < 2:
        return dict(omega=np.nan, omega_exact=w_exact, rel_error=np.inf, steps=steps,
                    iterations=its / steps)
    tc = t[up] - z[up] * (t[up + 1] - t[up]) / (z[up + 1] - z[up])
    w = 2 * np.pi / np.diff(tc).mean()
    return dict(omega=w, omega_exact=w_exact, rel_error=abs(w / w_exact - 1), steps=steps,
                iterations=its / steps)


__all__ = ["beaded_string"]
