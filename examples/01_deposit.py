"""01 — gravity deposit of sand and a wire (a small TexSol sample) in a cylindrical container.

The project's demo (``make demo``)::

    .venv/bin/python examples/01_deposit.py --out out/demo

Sand spheres (diameters uniform in 0.3–0.8 mm, 2650 kg/m³) start on a loose, jittered
lattice inside a vertical cylinder (closed bottom, open top), around a wire laid as a
helix (beads of the smallest sand diameter, 1400 kg/m³, elastic wire law of Eq. 14 with
k = 1 N), and everything settles under gravity (NSCD: θ-method + NLGS with
Signorini/Coulomb contacts, μ = 0.5, and the wire links in the same sweep).  The wire's
random-walk generator and the geometric deposit of the paper (§2.4) come with the sample
preparation issue; this demo uses a helix and a lattice.  Writes

* ``<out>/series/deposit.pvd`` + VTU frames (open the .pvd in ParaView; part 2 is the
  wire with its tension),
* ``<out>/deposit.png`` — kinetic energy, NLGS sweeps, contacts and residual vs time,

and prints the run summary and a static check: at rest, the vertical force of the floor
(bottom cap) plus that of the side wall (friction) must carry the total weight.

The script is split into ``build_scene`` / ``History`` / ``report`` so that another
sample (e.g. sand + wire) can reuse the run-and-report part.
"""
from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from engine import Scene, laws, run
from engine.step import CallbackWriter, NonConvergenceWarning
from workbench.figures import deposit_figure
from workbench.series import SeriesWriter

# material and container
D_MIN, D_MAX = 0.3e-3, 0.8e-3          # sphere diameters [m]
DENSITY = 2650.0                        # [kg/m³]
MU = 0.5                                # sand–sand and sand–wall friction [-]
SPACING = 1.1 * D_MAX                   # lattice spacing [m] (> largest diameter)
WIRE_R, WIRE_RHO, WIRE_K = 0.5 * D_MIN, 1400.0, 1.0   # bead radius [m], [kg/m³], k [N]
DT, THETA, TOL, MAX_ITER = 5e-5, 0.5, 1e-4, 1000


def lattice_in_cylinder(n: int, radius: float, spacing: float, jitter: float,
                        rng: np.random.Generator) -> np.ndarray:
    """``n`` points of a square lattice (spacing [m]) filling a disc of ``radius`` [m]
    layer after layer from z = spacing/2, each moved by a uniform jitter in
    [-jitter, jitter]³ [m].  Two points are at least ``spacing - 2 jitter`` apart."""
    m = int(np.floor(radius / spacing))
    g = np.arange(-m, m + 1) * spacing
    x, y = np.meshgrid(g, g, indexing="ij")
    inside = x ** 2 + y ** 2 <= radius ** 2
    layer = np.column_stack([x[inside], y[inside]])
    if layer.shape[0] == 0:
        raise ValueError("the container is too narrow for one lattice site")
    nz = -(-n // layer.shape[0])
    pts = np.array([(px, py, (k + 0.5) * spacing) for k in range(nz) for px, py in layer])[:n]
    return pts + rng.uniform(-jitter, jitter, size=pts.shape)


def helix(n_beads: int, radius: float, pitch: float, z0: float, bead_radius: float) -> np.ndarray:
    """``n_beads`` centres on a helix of ``radius`` [m] and ``pitch`` [m] per turn from
    height ``z0``, 2.2 × ``bead_radius`` of arc apart (the chords are a little shorter)."""
    dphi = 2.2 * bead_radius / np.hypot(radius, pitch / (2 * np.pi))  # arc length per radian
    phi = np.arange(n_beads) * dphi
    return np.column_stack([radius * np.cos(phi), radius * np.sin(phi),
                            z0 + pitch * phi / (2 * np.pi)])


def build_scene(n: int, seed: int, container_radius: float, wire_beads: int = 150):
    """Scene of ``n`` sand spheres on a loose lattice in a cylinder (closed bottom) around a
    helical wire of ``wire_beads`` beads (none if 0).

    Returns ``(scene, sand_ids, cylinder_id, height)``, ``height`` [m] of the container.
    """
    rng = np.random.default_rng(seed)
    jitter = 0.5 * (SPACING - D_MAX) * 0.99
    # lattice sites at least (rmax + jitter + margin) away from the side wall
    usable = container_radius - 0.5 * D_MAX - jitter - 0.05 * D_MAX
    wire = (helix(wire_beads, 0.5 * container_radius, 2.5 * D_MAX, 0.5 * D_MAX + WIRE_R, WIRE_R)
            if wire_beads else np.zeros((0, 3)))
    # lattice sites far enough from every wire bead, then the first n of them
    extra = n + 4 * wire_beads
    sites = lattice_in_cylinder(extra, usable, SPACING, jitter, rng)
    sites[:, 2] += 0.5 * D_MAX  # lowest layer clear of the floor
    if len(wire):
        d = np.linalg.norm(sites[:, None, :] - wire[None, :, :], axis=2).min(axis=1)
        sites = sites[d > 0.5 * D_MAX + WIRE_R + 1e-6]
    centers = sites[:n]
    radii = 0.5 * rng.uniform(D_MIN, D_MAX, size=len(centers))
    height = float(max(centers[:, 2].max(), wire[:, 2].max() if len(wire) else 0) + 2 * D_MAX)
    s = Scene(gravity=(0.0, 0.0, -9.81))
    sand = s.add_spheres(centers, radii, density=DENSITY, group="sand")
    tube = s.add_cylinder(center=(0, 0, 0), axis=(0, 0, 1), radius=container_radius,
                          height=height, group="wall", bottom=True, top=False)
    s.interact("sand", "sand", laws.Coulomb(mu=MU))
    s.interact("sand", "wall", laws.Coulomb(mu=MU))
    if len(wire):
        s.add_wire(wire, radius=WIRE_R, density=WIRE_RHO, group="wire",
                   law=laws.ElasticWire(stiffness=WIRE_K))
        for other in ("sand", "wall", "wire"):
            s.interact("wire", other, laws.Coulomb(mu=MU))
    return s, sand, tube, height


def kinetic_energy(model, state) -> float:
    """Translational + rotational kinetic energy of the spheres [J]."""
    ids = model.sphere_ids
    v2 = np.einsum("ij,ij->i", state.velocity[ids], state.velocity[ids])
    w2 = np.einsum("ij,ij->i", state.spin[ids], state.spin[ids])
    return 0.5 * float(model.body_mass[ids] @ v2 + model.body_inertia[ids] @ w2)


class History:
    """Per-step history (time [s], kinetic energy [J], NLGS sweeps, residual, contacts),
    recorded by the engine writer :attr:`writer`."""

    KEYS = ("time", "kinetic_energy", "iterations", "residual", "contacts")

    def __init__(self):
        self.data = {k: [] for k in self.KEYS}
        self.writer = CallbackWriter(self._record, trigger=1)

    def _record(self, model, state) -> None:
        d = self.data
        d["time"].append(state.time)
        d["kinetic_energy"].append(kinetic_energy(model, state))
        d["iterations"].append(state.stats.iterations)
        d["residual"].append(state.stats.residual)
        d["contacts"].append(state.stats.n_contacts)


def wall_reactions(model, state, wall: int) -> tuple[float, float]:
    """Vertical force [N] on the spheres from the bottom cap (``sub == 1``) and from the
    side (``sub == 0``) of cylinder ``wall``, over the last step."""
    c = state.contacts
    if len(c) == 0:
        return 0.0, 0.0
    fz = c.force[:, 2]
    on_wall = c.j == wall
    return float(fz[on_wall & (c.sub == 1)].sum()), float(fz[on_wall & (c.sub == 0)].sum())


def report(model, state, summary, wall: int, history: dict | None = None) -> None:
    """Print the run summary and the static check floor + side wall = weight."""
    ids = model.sphere_ids
    weight = float(model.body_mass[ids].sum()) * -model.options.gravity[2]
    floor, side = wall_reactions(model, state, wall)
    vmax = float(np.linalg.norm(state.velocity[ids], axis=1).max())
    top = float((state.position[ids, 2] + model.body_radius[ids]).max())
    print(f"non-converged steps: {len(summary.non_converged)} of {summary.steps} hit "
          f"max_iter = {model.options.max_iter} (max final residual {summary.max_residual:.2e}, "
          f"tol {model.options.tol:g})")
    ke = kinetic_energy(model, state)
    if history and history["kinetic_energy"]:
        print(f"kinetic energy: peak {max(history['kinetic_energy']):.3e} J, "
              f"final/peak {ke / max(history['kinetic_energy']):.1e}")
    print(f"final: kinetic energy {ke:.3e} J, "
          f"max speed {vmax:.3e} m/s, {len(state.contacts)} contacts, deposit top {top * 1e3:.2f} mm")
    print(f"total weight                   {weight:.6e} N")
    print(f"floor reaction (bottom cap, z) {floor:.6e} N  = {floor / weight:.4f} x weight")
    print(f"side-wall friction (z)         {side:.6e} N  = {side / weight:.4f} x weight")
    print(f"floor + side wall              {floor + side:.6e} N  = {(floor + side) / weight:.4f} x weight")
    links = state.links
    if len(links):
        taut = links.tension > 0
        print(f"wire: {len(links)} links, {int(taut.sum())} in tension, max tension "
              f"{links.tension.max():.3e} N, mean over taut links "
              f"{(links.tension[taut].mean() if taut.any() else 0.0):.3e} N")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", type=Path, default=Path("out/demo"), help="output directory")
    p.add_argument("--n", type=int, default=1500, help="number of sand spheres")
    p.add_argument("--steps", type=int, default=4000, help=f"time steps of {DT:g} s")
    p.add_argument("--seed", type=int, default=0, help="seed of the radii and lattice jitter")
    p.add_argument("--radius", type=float, default=5e-3, help="container radius [m]")
    p.add_argument("--every", type=int, default=100, help="write a ParaView frame every N steps")
    p.add_argument("--wire-beads", type=int, default=150, help="beads of the helical wire (0: sand only)")
    a = p.parse_args(argv)
    if a.n < 1 or a.steps < 0 or a.every < 1 or a.wire_beads < 0 or a.wire_beads == 1:
        p.error("--n and --every must be >= 1, --steps >= 0, --wire-beads 0 or >= 2")

    t0 = time.perf_counter()
    scene, sand, tube, height = build_scene(a.n, a.seed, a.radius, a.wire_beads)
    model, state = scene.compile(dt=DT, theta=THETA, tol=TOL, max_iter=MAX_ITER)
    print(f"{len(sand)} sand spheres (d = {D_MIN * 1e3:g}-{D_MAX * 1e3:g} mm) and a wire of "
          f"{model.n_spheres - len(sand)} beads (d = {2 * WIRE_R * 1e3:g} mm, k = {WIRE_K:g} N) in a cylinder "
          f"R = {a.radius * 1e3:g} mm, H = {height * 1e3:.1f} mm; dt = {DT:g} s, theta = {THETA}, "
          f"tol = {TOL:g}; {a.steps} steps (t = {a.steps * DT:g} s)")

    series = SeriesWriter(a.out / "series", every=a.every, name="deposit")
    series.write(model, state)  # initial frame
    history = History()
    # run() prints its summary (progress=True), or warns with it when steps did not converge
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", NonConvergenceWarning)
        summary = run(model, state, a.steps, writers=[series, history.writer], progress=True)
    for w in caught:
        print(f"{w.category.__name__}: {w.message}")
    if state.step % a.every:  # make sure the final state is in the series
        series.write(model, state)
    series.close()
    png = deposit_figure(history.data, a.out / "deposit.png", tol=TOL,
                         title=f"Gravity deposit, {len(sand)} sand grains + "
                               f"{model.n_spheres - len(sand)} wire beads")

    report(model, state, summary, tube, history.data)
    print(f"figure:          {png}")
    print(f"ParaView series: {series.pvd_path} ({series.frames} frames)")
    print(f"total wall time: {time.perf_counter() - t0:.1f} s (numba compilation included)")
    return 130 if summary.interrupted else 0


if __name__ == "__main__":
    sys.exit(main())
