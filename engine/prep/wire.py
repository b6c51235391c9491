"""The wire of a numerical TexSol sample, built bead by bead by a random walk (paper §2.4,
Eq. 16-17, Fig. 6).

Bead i+1 is put at X_{i+1} = X_i + (2 r_w + g_w) η_{i+1}, η_{i+1} drawn at random in a cone
of axis η_ref and apex angle α_search:

* isotropic walk, Eq. (16): η_ref = η_ini for the first bead, then the last direction
  (X_i − X_{i−1})/|X_i − X_{i−1}|;
* orthotropic walk, Eq. (17): the heading is drawn in the horizontal plane around the last
  horizontal direction, and the vertical component is ± sin(α_rise), its sign bringing the
  bead back towards the height of its layer ("the vertical component of X_i is computed
  around a constant value").

A draw is refused if the bead would leave the container or overlap a bead already placed
(or an obstacle).  After ``draws`` refused draws the walk tries ``draws`` more with
α_search = 4π/3 (the paper's "bypassing" / "rebound"); if those fail too the wire is cut and
a new wire starts at a random free point.  The walk stops when the target length is reached.

:func:`helix` is the one deterministic wire: a helix about a cylinder's axis, a positive
control (not in the paper).

Lengths in [m]; the voluminal length density is in m·m⁻³ (SI): the paper's 250 km·m⁻³ is
``density=2.5e5``.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["random_walk", "helix", "KM_PER_M3"]

KM_PER_M3 = 1.0e3
"""One km·m⁻³ (the paper's unit of wire density) in m·m⁻³."""

BYPASS_ANGLE = 4.0 * math.pi / 3.0
_MAX_FAILED_STARTS = 200


def _inside_fn(container):
    """A scalar test ``inside(x, y, z)`` for a (shrunk) container."""
    from .containers import Box, Cylinder, Sphere
    if isinstance(container, Box):
        (x0, y0, z0), (x1, y1, z1) = container.lo, container.hi
        return lambda x, y, z: x0 <= x <= x1 and y0 <= y <= y1 and z0 <= z <= z1
    if isinstance(container, Cylinder):
        cx, cy, cz = container.center
        r2, h = container.radius ** 2, container.height
        return lambda x, y, z: ((x - cx) ** 2 + (y - cy) ** 2 <= r2) and cz <= z <= cz + h
    if isinstance(container, Sphere):
        cx, cy, cz = container.center
        r2 = container.radius ** 2
        return lambda x, y, z: (x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2 <= r2
    raise ValueError(f"container must be engine.prep.Box, Cylinder or Sphere, got {container!r}")


class _Grid:
    """Spatial hash of sphere centres for overlap queries (cell size >= the largest contact
    distance, so 27 cells hold every candidate)."""

    def __init__(self, cell):
        self.cell = cell
        self.cells = {}

    def key(self, x, y, z):
        c = self.cell
        return (math.floor(x / c), math.floor(y / c), math.floor(z / c))

    def add(self, x, y, z, r):
        self.cells.setdefault(self.key(x, y, z), []).append((x, y, z, r))

    def remove(self, x, y, z, r):
        self.cells[self.key(x, y, z)].remove((x, y, z, r))

    def free(self, x, y, z, r):
        i, j, k = self.key(x, y, z)
        for a in (i - 1, i, i + 1):
            for b in (j - 1, j, j + 1):
                for c in (k - 1, k, k + 1):
                    for (px, py, pz, pr) in self.cells.get((a, b, c), ()):
                        d = r + pr
                        if (x - px) ** 2 + (y - py) ** 2 + (z - pz) ** 2 < d * d * (1 - 1e-12):
                            return False
        return True


def _cone(rng, axis, apex):
    """A unit vector drawn uniformly in the cone of ``axis`` (unit) and apex angle ``apex``."""
    half = min(0.5 * apex, math.pi)
    ct = 1.0 - rng.random() * (1.0 - math.cos(half))
    st = math.sqrt(max(0.0, 1.0 - ct * ct))
    ph = 2.0 * math.pi * rng.random()
    ax, ay, az = axis
    # orthonormal basis (u, v, axis)
    if abs(az) < 0.9:
        ux, uy, uz = -ay, ax, 0.0
    else:
        ux, uy, uz = 0.0, -az, ay
    n = math.sqrt(ux * ux + uy * uy + uz * uz)
    ux, uy, uz = ux / n, uy / n, uz / n
    vx, vy, vz = ay * uz - az * uy, az * ux - ax * uz, ax * uy - ay * ux
    c, s = st * math.cos(ph), st * math.sin(ph)
    return (c * ux + s * vx + ct * ax, c * uy + s * vy + ct * ay, c * uz + s * vz + ct * az)


def _unit(rng):
    z = 2.0 * rng.random() - 1.0
    ph = 2.0 * math.pi * rng.random()
    s = math.sqrt(1.0 - z * z)
    return (s * math.cos(ph), s * math.sin(ph), z)


def random_walk(container, bead_radius: float, gap: float, *, length: float | None = None,
                density: float | None = None, mode: str = "isotropic",
                search_angle: float = math.pi / 4, rise_angle: float = math.radians(5.0),
                layers=None, eta_ini=None, draws: int = 30, obstacles=None,
                seed: int = 0) -> list[np.ndarray]:
    """Build the wire of a TexSol sample by the random walk of Eq. (16) or (17).

    Parameters
    ----------
    container : engine.prep.Box | Cylinder | Sphere
        Every bead lies entirely inside it.
    bead_radius : float [m], > 0
        r_w.
    gap : float [m], >= 0
        g_w: consecutive bead centres are 2 r_w + g_w apart.
    length : float [m], optional
        Total wire length to build (sum over wires of (beads − 1)(2 r_w + g_w)); or
    density : float [m·m⁻³], optional
        Voluminal length density: length / container volume (250 km·m⁻³ = 2.5e5).
    mode : {"isotropic", "orthotropic"}
        Eq. (16) or Eq. (17).
    search_angle : float [rad], in (0, 2π]
        α_search, the apex angle of the search cone (isotropic), or the width of the heading
        window in the horizontal plane (orthotropic).  The bypass angle is 4π/3.
    rise_angle : float [rad], in [0, π/2)
        α_rise (orthotropic only).
    layers : sequence of float [m], optional
        Orthotropic only: the layer heights (absolute z).  Default: layers 4 (2 r_w + g_w)
        apart filling the container height.  The length is shared equally between layers.
    eta_ini : (3,) optional
        η_ini, the first direction of the first wire (random if not given).
    draws : int >= 1
        n, the number of refused draws before the bypass angle is tried, and then before the
        wire is cut.
    obstacles : ((m, 3) centres [m], (m,) radii [m]), optional
        Spheres the beads must not overlap.
    seed : int

    Returns
    -------
    list of (k, 3) float64 arrays: the bead centres of each wire (k >= 2), in order.

    Raises
    ------
    ValueError
        A parameter out of range (naming it), or a length that cannot fit in the container.
    """
    r = float(bead_radius)
    if not (math.isfinite(r) and r > 0):
        raise ValueError(f"bead_radius must be finite and > 0 [m], got {bead_radius!r}")
    g = float(gap)
    if not (math.isfinite(g) and g >= 0):
        raise ValueError(f"gap must be finite and >= 0 [m], got {gap!r}")
    if mode not in ("isotropic", "orthotropic"):
        raise ValueError(f"mode must be 'isotropic' or 'orthotropic', got {mode!r}")
    alpha = float(search_angle)
    if not (0 < alpha <= 2 * math.pi):
        raise ValueError(f"search_angle must be in (0, 2π] [rad], got {search_angle!r}")
    rise = float(rise_angle)
    if not (0 <= rise < math.pi / 2):
        raise ValueError(f"rise_angle must be in [0, π/2) [rad], got {rise_angle!r}")
    if int(draws) != draws or draws < 1:
        raise ValueError(f"draws must be an integer >= 1, got {draws!r}")
    if (length is None) == (density is None):
        raise ValueError("give exactly one of length [m] and density [m·m⁻³]")
    if length is not None:
        target = float(length)
        if not (math.isfinite(target) and target > 0):
            raise ValueError(f"length must be finite and > 0 [m], got {length!r}")
    else:
        dens = float(density)
        if not (math.isfinite(dens) and dens > 0):
            raise ValueError(f"density must be finite and > 0 [m·m⁻³], got {density!r}")
        target = dens * container.volume
    a = 2.0 * r + g
    try:
        inner = container.shrunk(r)
    except ValueError:
        raise ValueError(f"bead_radius {r!r} m does not fit in the container {container!r}")
    inside = _inside_fn(inner)
    n_beads = target / a + 1
    fill = n_beads * 4.0 / 3.0 * math.pi * r ** 3 / inner.volume
    if fill > 0.3:
        raise ValueError(f"length/density cannot fit: {target:.4g} m of wire is about "
                         f"{n_beads:.0f} beads filling {fill:.0%} of the container (at most 30 %)")
    lo, hi = inner.bounds()
    if mode == "orthotropic":
        if layers is None:
            m = max(1, int(round((hi[2] - lo[2]) / (4 * a))))
            layers = [lo[2] + (k + 0.5) * (hi[2] - lo[2]) / m for k in range(m)]
        layers = [float(z) for z in np.atleast_1d(np.asarray(layers, dtype=float))]
        for z in layers:
            if not lo[2] <= z <= hi[2]:
                raise ValueError(f"layers: height {z!r} m is outside the container's bead "
                                 f"range [{lo[2]:.6g}, {hi[2]:.6g}] m")
    if eta_ini is not None:
        e = np.asarray(eta_ini, dtype=float)
        if e.shape != (3,) or not np.all(np.isfinite(e)) or np.linalg.norm(e) == 0:
            raise ValueError(f"eta_ini must be a non-zero 3-vector, got {eta_ini!r}")
        eta_ini = tuple(e / np.linalg.norm(e))

    rng = np.random.default_rng(seed)
    cell = max(a, 2 * r)
    grid = _Grid(cell)
    if obstacles is not None:
        oc = np.asarray(obstacles[0], dtype=float).reshape(-1, 3)
        orad = np.broadcast_to(np.asarray(obstacles[1], dtype=float), (oc.shape[0],))
        if orad.size and 2 * orad.max() > cell:
            grid = _Grid(max(cell, r + orad.max()))
        for (x, y, z), ro in zip(oc, orad):
            grid.add(float(x), float(y), float(z), float(ro))

    def start(z_layer):
        for _ in range(10000):
            x, y, z = lo + rng.random(3) * (hi - lo)
            if z_layer is not None:
                z = z_layer
            if inside(x, y, z) and grid.free(x, y, z, r):
                return (x, y, z)
        return None

    def next_dir(eta_ref, apex, z, z_layer):
        if z_layer is None:
            return _cone(rng, eta_ref, apex)
        psi = math.atan2(eta_ref[1], eta_ref[0]) + (rng.random() - 0.5) * min(apex, 2 * math.pi)
        dz = z_layer - z
        s = 1.0 if dz > 0 else -1.0 if dz < 0 else (1.0 if rng.random() < 0.5 else -1.0)
        return (math.cos(rise) * math.cos(psi), math.cos(rise) * math.sin(psi), s * math.sin(rise))

    chains, total = [], 0.0
    goals = ([(None, target)] if mode == "isotropic"
             else [(z, target / len(layers)) for z in layers])
    for z_layer, goal in goals:
        built, failed_starts = 0.0, 0
        while built < goal * (1 - 1e-12):
            p = start(z_layer)
            if p is None:
                failed_starts = _MAX_FAILED_STARTS
            else:
                chain = [p]
                grid.add(*p, r)
                if eta_ini is not None and not chains:
                    eta = eta_ini
                elif z_layer is None:
                    eta = _unit(rng)
                else:
                    ph = 2 * math.pi * rng.random()
                    eta = (math.cos(ph), math.sin(ph), 0.0)
                while built < goal * (1 - 1e-12):
                    x, y, z = chain[-1]
                    q = None
                    for apex in (alpha, BYPASS_ANGLE):
                        for _ in range(draws):
                            d = next_dir(eta, apex, z, z_layer)
                            cx, cy, cz = x + a * d[0], y + a * d[1], z + a * d[2]
                            if inside(cx, cy, cz) and grid.free(cx, cy, cz, r):
                                q = (cx, cy, cz)
                                break
                        if q is not None:
                            break
                    if q is None:
                        break                           # cut the wire here
                    chain.append(q)
                    grid.add(*q, r)
                    built += a
                    if z_layer is None:
                        eta = d                          # Eq. (16): η_ref = (X_i − X_{i−1})/|.|
                    else:
                        eta = (d[0], d[1], 0.0)          # Eq. (17): the horizontal heading
                if len(chain) >= 2:
                    chains.append(np.array(chain))
                    failed_starts = 0
                else:
                    grid.remove(*chain[0], r)
                    failed_starts += 1
            if failed_starts >= _MAX_FAILED_STARTS:
                raise ValueError(
                    f"length/density cannot fit: built {total + built:.4g} m of the "
                    f"{target:.4g} m asked ({(total + built) / container.volume:.4g} m·m⁻³); "
                    f"no free room is left for a new wire (bead_radius={r}, gap={g})")
        total += built
    return chains


def helix(container, bead_radius: float, gap: float, pitch: float, *,
          inset: float) -> list[np.ndarray]:
    """A helical wire about a cylinder's axis: a sand column encased by the wire.

    Not in the paper (its wires are random walks, Eq. 16-17): a deterministic positive
    control of the wire–sand coupling.  The bead centres lie on the helix of radius
    R_h = R − inset − r_w about the axis (the beads' outer edge ``inset`` inside the mould's
    side), from z = floor + r_w up to at most top − r_w, rising ``pitch`` per turn and
    starting on the +x side of the axis.  Consecutive centres are 2 r_w + g_w apart along the
    chord: the angle step Δθ solves (2 R_h sin(Δθ/2))² + (pitch Δθ/2π)² = (2 r_w + g_w)².

    Parameters
    ----------
    container : engine.prep.Cylinder
        The mould [m].
    bead_radius : float [m], > 0
        r_w.
    gap : float [m], >= 0
        g_w: consecutive bead centres are s_w = 2 r_w + g_w apart.
    pitch : float [m], > s_w / sqrt(1 − (s_w / 4 R_h)²)
        The rise per turn.  The bound, at most 3.3 % above s_w (as R_h > s_w), keeps the
        centres of adjacent turns at least s_w apart (sin x >= 2x/π bounds their distance).
    inset : float [m], >= 0
        The beads' outer edge is this far inside the mould's side.

    Returns
    -------
    list of one (k, 3) float64 array: the bead centres in order (k >= 2).

    Raises
    ------
    ValueError
        A parameter out of range (naming it), or a mould too narrow or too low for the helix.
    """
    from .containers import Cylinder
    if not isinstance(container, Cylinder):
        raise ValueError(f"container must be an engine.prep.Cylinder (a helix needs an axis), "
                         f"got {container!r}")
    r, g, p, m = (float(v) for v in (bead_radius, gap, pitch, inset))
    for name, v, least in (("bead_radius", r, "> 0"), ("gap", g, ">= 0"), ("pitch", p, "> 0"),
                           ("inset", m, ">= 0")):
        if not (math.isfinite(v) and (v > 0 or (v == 0 and least == ">= 0"))):
            raise ValueError(f"{name} must be finite and {least} [m], got {v!r}")
    s = 2.0 * r + g
    rh = container.radius - m - r
    if not rh > s:
        raise ValueError(f"inset = {m:.6g} m: the helix radius R_h = radius - inset - "
                         f"bead_radius = {rh:.6g} m must be > 2 bead_radius + gap = {s:.6g} m")
    p_min = s / math.sqrt(1.0 - (s / (4.0 * rh)) ** 2)
    if not p > p_min:
        raise ValueError(f"pitch must be > {p_min:.6g} m (2 bead_radius + gap = {s:.6g} m on a "
                         f"helix of radius {rh:.6g} m: adjacent turns must not touch), got {p!r}")
    c = p / (2.0 * math.pi)                   # rise per radian [m]
    lo, hi = 0.0, math.pi / 3.0               # the chord at π/3 is >= R_h > s
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if (2.0 * rh * math.sin(0.5 * mid)) ** 2 + (c * mid) ** 2 < s * s:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 4e-16 * hi:
            break
    dth = 0.5 * (lo + hi)
    span = container.height - 2.0 * r
    k = int(math.floor(span / (c * dth))) + 1 if span > 0 else 0
    if k < 2:
        raise ValueError(f"container.height = {container.height:.6g} m: must be >= 2 bead_radius "
                         f"+ the rise per bead = {2 * r + c * dth:.6g} m for two beads")
    th = dth * np.arange(k)
    cx, cy, cz = container.center
    return [np.column_stack([cx + rh * np.cos(th), cy + rh * np.sin(th), cz + r + c * th])]
