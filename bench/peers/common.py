"""Helpers shared by every side of the peer comparison (our venv, Debian's /usr/bin/python3
for Siconos, Yade's own interpreter): plain numpy + json, no engine import.

A *state file* is JSON: ``radius`` (n,), ``position`` (n, 3), ``vel6`` (n, 6: velocity
then angular velocity, global frame), ``box_lo``/``box_hi`` (open box: floor at
box_lo[2], four side walls), ``params`` (material and solver parameters).
"""
import json
import math

import numpy as np

#: The comparison set-up (peers.md): 1 000 spheres, radii uniform 0.1-0.3 mm.
PARAMS = dict(r_min=1e-4, r_max=3e-4, density=2650.0, mu=0.3, restitution=0.0, dt=5e-5,
              theta=0.5, tol=1e-4, max_iter=1000, gravity=9.81, lattice=[10, 10, 10],
              spacing_factor=1.05, seed=12345)


def load_state(path):
    with open(path) as f:
        d = json.load(f)
    d["radius"] = np.asarray(d["radius"], float)
    d["position"] = np.asarray(d["position"], float).reshape(-1, 3)
    d["vel6"] = np.asarray(d.get("vel6", np.zeros((len(d["radius"]), 6))), float).reshape(-1, 6)
    return d


def save_state(path, radius, position, vel6, box_lo, box_hi, params, **extra):
    d = dict(radius=np.asarray(radius, float).tolist(),
             position=np.asarray(position, float).tolist(),
             vel6=np.asarray(vel6, float).tolist(),
             box_lo=[float(x) for x in box_lo], box_hi=[float(x) for x in box_hi],
             params=params)
    d.update(extra)
    with open(path, "w") as f:
        json.dump(d, f)


def masses(radius, density):
    m = density * 4.0 / 3.0 * math.pi * radius ** 3
    return m, 0.4 * m * radius ** 2


def kinetic_energy(radius, vel6, density):
    m, inertia = masses(radius, density)
    return float(0.5 * np.sum(m * np.sum(vel6[:, :3] ** 2, axis=1))
                 + 0.5 * np.sum(inertia * np.sum(vel6[:, 3:] ** 2, axis=1)))


def geometric_contacts(position, radius, box_lo, box_hi, gap_max):
    """Pairs (sphere-sphere, sphere-wall) whose gap is <= gap_max [m], counted from the
    positions alone: the same yardstick for every engine.  Returns a dict."""
    n = len(radius)
    rmax = float(radius.max())
    cell = 2.0 * rmax + gap_max
    keys = np.floor((position - position.min(axis=0)) / cell).astype(np.int64)
    buckets = {}
    for idx, k in enumerate(map(tuple, keys)):
        buckets.setdefault(k, []).append(idx)
    pairs = 0
    overlap_max = 0.0
    for (a, b, c), members in buckets.items():
        cand = []
        for da in (-1, 0, 1):
            for db in (-1, 0, 1):
                for dc in (-1, 0, 1):
                    cand.extend(buckets.get((a + da, b + db, c + dc), ()))
        cand = np.asarray(cand)
        for i in members:
            js = cand[cand > i]
            if js.size == 0:
                continue
            d = np.linalg.norm(position[js] - position[i], axis=1) - radius[js] - radius[i]
            pairs += int(np.sum(d <= gap_max))
            if d.size:
                overlap_max = max(overlap_max, float(-d.min()))
    lo, hi = np.asarray(box_lo), np.asarray(box_hi)
    gaps = [position[:, 2] - radius - lo[2]]
    for ax in (0, 1):
        gaps.append(position[:, ax] - radius - lo[ax])
        gaps.append(hi[ax] - position[:, ax] - radius)
    gaps = np.stack(gaps)
    walls = int(np.sum(gaps <= gap_max))
    overlap_max = max(overlap_max, float(-gaps.min()))
    return dict(gap_max_m=gap_max, sphere_sphere=pairs, sphere_wall=walls, total=pairs + walls,
                max_overlap_m=overlap_max, n=n)


def summary(position, radius, vel6, box_lo, box_hi, density):
    """Final-state figures compared across engines."""
    z = position[:, 2] - box_lo[2]
    out = dict(mean_height_m=float(z.mean()), max_top_m=float((z + radius).max()),
               kinetic_energy_J=kinetic_energy(radius, vel6, density),
               speed_max_m_s=float(np.linalg.norm(vel6[:, :3], axis=1).max()),
               finite=bool(np.isfinite(position).all() and np.isfinite(vel6).all()))
    rmin = float(radius.min())
    out["contacts_geometric"] = {
        "gap<=0": geometric_contacts(position, radius, box_lo, box_hi, 0.0),
        "gap<=1%rmin": geometric_contacts(position, radius, box_lo, box_hi, 0.01 * rmin),
        "gap<=10%rmin": geometric_contacts(position, radius, box_lo, box_hi, 0.1 * rmin)}
    return out
