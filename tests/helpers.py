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
