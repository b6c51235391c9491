"""Scene builders shared by tests."""
import numpy as np

G = 9.81


def lattice_pile(n, r, rng, box, gap=1.05):
    """n spheres of radius r(1 ± 10 %) on a loose cubic lattice inside box = (lo, hi)."""
    lo, hi = np.asarray(box[0], float), np.asarray(box[1], float)
    d = 2 * r * 1.1 * gap
    nx = int((hi[0] - lo[0]) // d)
    ny = int((hi[1] - lo[1]) // d)
    pts = []
    k = 0
    while len(pts) < n:
        z = lo[2] + d / 2 + (k // (nx * ny)) * d
        i = k % (nx * ny)
        pts.append((lo[0] + d / 2 + (i % nx) * d, lo[1] + d / 2 + (i // nx) * d, z))
        k += 1
    radii = r * rng.uniform(0.9, 1.1, n)
    return np.asarray(pts), radii


def settle(model, state, steps, ids=None):
    """Static equilibrium by kinetic damping (dynamic relaxation): run ``steps`` steps and
    zero the velocities of bodies ``ids`` whenever their kinetic energy has just decreased
    (a peak was passed).  Returns the kinetic energy history."""
    from engine import step

    ids = model.sphere_ids if ids is None else np.asarray(ids)
    m = model.body_mass[ids]
    prev = 0.0
    history = []
    for _ in range(steps):
        step(model, state)
        ke = 0.5 * float(m @ (state.velocity[ids] ** 2).sum(axis=1))
        if ke < prev:
            state.vel6[ids] = 0.0
            ke = 0.0
        prev = ke
        history.append(ke)
    return np.asarray(history)


def box_pile(n, width, *, seed=7, theta=0.5, dt=2e-4, tol=1e-8, max_iter=5000, mu=0.4,
             wall_mu=0.0):
    """``n`` grains (r = 1 mm ± 10 %) on a loose lattice in a square box of side ``width`` [m]
    whose floor and side walls (group "side") have friction ``wall_mu`` (0: no Janssen
    effect, the floor carries the whole weight).  Returns (model, state, box ids, radii)."""
    from engine import Scene, laws

    rng = np.random.default_rng(seed)
    lo, hi = (0, 0, 0), (width, width, 0.1)
    pts, radii = lattice_pile(n, 1e-3, rng, (lo, hi), gap=1.02)
    s = Scene(gravity=(0, 0, -G))
    s.add_spheres(pts, radii, density=2650.0)
    box = s.add_box(lo, hi, group="side")
    s.interact("sand", "sand", laws.Coulomb(mu=mu))
    s.interact("sand", "side", laws.Coulomb(mu=wall_mu))
    model, state = s.compile(dt=dt, theta=theta, tol=tol, max_iter=max_iter)
    return model, state, box, radii
