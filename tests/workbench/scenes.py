"""Small TexSol scenes shared by the workbench tests (a few hundred beads, a few steps)."""
from __future__ import annotations

import numpy as np

from engine import Scene, laws, run
from engine.prep.containers import Cylinder

R_CYL = 2.5e-3     # container radius [m]
R_SAND = 0.25e-3   # mean sand radius [m] (± 10 %)
R_BEAD = 0.15e-3   # wire bead radius [m]


def _lattice(n: int, radius: float, spacing: float, z0: float) -> np.ndarray:
    """``n`` sites of a square lattice (spacing [m]) in a disc of ``radius`` [m], layer by
    layer from height ``z0``."""
    m = int(radius // spacing)
    g = np.arange(-m, m + 1) * spacing
    x, y = np.meshgrid(g, g, indexing="ij")
    inside = np.hypot(x, y) <= radius
    layer = np.column_stack([x[inside], y[inside]])
    nz = -(-n // len(layer))
    return np.array([(px, py, z0 + k * spacing) for k in range(nz) for px, py in layer])[:n]


def texsol_cylinder(n_sand: int = 300, wire_beads: int = 48, steps: int = 150, *,
                    dt: float = 1e-4, seed: int = 0, container_radius: float = R_CYL,
                    max_iter: int = 300):
    """Sand spheres on a loose lattice (gaps of 2 % of a diameter) in a vertical cylinder
    (closed bottom) of ``container_radius`` [m] around a horizontal wire ring (a closed
    elastic wire, 1 N; at most ``wire_beads`` beads, fewer if the ring is shorter), run for
    ``steps`` steps under gravity.

    Returns ``(model, state, cylinder)`` with ``cylinder`` an
    :class:`engine.prep.containers.Cylinder` of the container (for toroidal maps).
    """
    rng = np.random.default_rng(seed)
    d_max = 2.2 * R_SAND
    spacing = 1.02 * d_max
    usable = container_radius - 0.5 * d_max - 0.02 * d_max
    ring_r = 0.55 * container_radius
    dphi = 2.1 * R_BEAD / ring_r
    n_ring = min(wire_beads, int(2 * np.pi / dphi))
    phi = 2 * np.pi * np.arange(n_ring) / n_ring
    z_ring = 2.5 * spacing
    ring = np.column_stack([ring_r * np.cos(phi), ring_r * np.sin(phi), np.full(n_ring, z_ring)])
    sites = _lattice(n_sand + 4 * n_ring, usable, spacing, 0.5 * spacing)
    gap = np.linalg.norm(sites[:, None] - ring[None], axis=2).min(axis=1)
    sites = sites[gap > 0.5 * d_max + R_BEAD + 1e-6][:n_sand]
    radii = R_SAND * rng.uniform(0.9, 1.1, len(sites))
    height = float(sites[:, 2].max() + 2 * d_max)
    s = Scene(gravity=(0.0, 0.0, -9.81))
    s.add_spheres(sites, radii, density=2650.0, group="sand")
    s.add_cylinder(center=(0, 0, 0), axis=(0, 0, 1), radius=container_radius, height=height,
                   group="wall", bottom=True, top=False)
    s.add_wire(ring, radius=R_BEAD, density=1400.0, group="wire",
               law=laws.ElasticWire(stiffness=1.0), closed=True)
    for a, b in (("sand", "sand"), ("sand", "wall"), ("wire", "sand"), ("wire", "wall"),
                 ("wire", "wire")):
        s.interact(a, b, laws.Coulomb(mu=0.5))
    model, state = s.compile(dt=dt, theta=0.5, tol=1e-4, max_iter=max_iter)
    if steps:
        run(model, state, steps, progress=False)
    return model, state, Cylinder(radius=container_radius, height=height)
