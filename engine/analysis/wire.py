"""Wire geometry statistics (paper §2.4 and §3.1): voluminal length density, element
directions (orientation tensor; histograms in the (x,y), (x,z), (y,z) planes, Fig. 8-9) and
tortuosity ξ = (1/l) ∫ ρ⁻¹(s) ds (Fig. 7).

Every function takes ``chains``: a list of (k, 3) arrays of bead centres [m] in wire order
(what :func:`engine.prep.random_walk` returns), or ``(model, state)`` through
:func:`wire_chains`.  Elements are the segments between consecutive beads.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["wire_chains", "wire_length", "length_density", "orientation_tensor",
           "direction_histogram", "tortuosity", "WireStats", "wire_stats", "Encasement",
           "encasement"]

_PLANES = {"xy": (0, 1), "xz": (0, 2), "yz": (1, 2)}


def wire_chains(model, state) -> list[np.ndarray]:
    """The bead centres [m] of each wire of a model, in link order; a closed wire repeats its
    first bead at the end."""
    li, lj = np.asarray(model.link_i), np.asarray(model.link_j)
    chains, cur = [], []
    for k in range(li.shape[0]):
        if cur and li[k] != cur[-1]:
            chains.append(cur)
            cur = []
        if not cur:
            cur = [int(li[k])]
        cur.append(int(lj[k]))
    if cur:
        chains.append(cur)
    pos = np.asarray(state.position)
    return [pos[np.asarray(c)] for c in chains]


def _as_chains(chains) -> list[np.ndarray]:
    if isinstance(chains, np.ndarray) and chains.ndim == 2:
        chains = [chains]
    out = []
    for c in chains:
        c = np.asarray(c, dtype=float)
        if c.ndim != 2 or c.shape[1] != 3:
            raise ValueError(f"each chain must be a (k, 3) array of bead centres, got shape {c.shape}")
        out.append(c)
    return out


def _elements(chains) -> np.ndarray:
    segs = [np.diff(c, axis=0) for c in _as_chains(chains) if len(c) >= 2]
    return np.concatenate(segs) if segs else np.zeros((0, 3))


def wire_length(chains) -> float:
    """l = Σ |X_{i+1} − X_i| over all wires [m]."""
    return float(np.linalg.norm(_elements(chains), axis=1).sum())


def length_density(chains, volume: float) -> float:
    """Voluminal length density l / V [m·m⁻³] (the paper quotes km·m⁻³ = 1e3 m·m⁻³)."""
    v = float(volume)
    if not v > 0:
        raise ValueError(f"volume must be > 0 [m³], got {volume!r}")
    return wire_length(chains) / v


def orientation_tensor(chains) -> np.ndarray:
    """A = Σ l_e n_e ⊗ n_e / Σ l_e over the elements (n_e unit direction, l_e length): a
    (3, 3) symmetric tensor of trace 1; its eigenvalues are 1/3 each for an isotropic
    network, and the vertical one is 0 for a network of horizontal layers."""
    e = _elements(chains)
    ln = np.linalg.norm(e, axis=1)
    if ln.sum() == 0:
        raise ValueError("the chains have no element of non-zero length")
    n = e / np.where(ln > 0, ln, 1.0)[:, None]
    return np.einsum("k,ki,kj->ij", ln, n, n) / ln.sum()


def direction_histogram(chains, plane: str = "xy", bins: int = 18):
    """Histogram of the element directions projected on a coordinate plane (Fig. 8-9).

    Directions are undirected: the angle of the projection, from the plane's first axis, is
    folded into [0, π).  Each element weighs its projected length, so near-normal elements
    count little.

    Returns
    -------
    edges : (bins+1,) [rad];  weights : (bins,) [m] summing to the projected length.
    """
    if plane not in _PLANES:
        raise ValueError(f"plane must be one of {sorted(_PLANES)}, got {plane!r}")
    if int(bins) != bins or bins < 1:
        raise ValueError(f"bins must be an integer >= 1, got {bins!r}")
    a, b = _PLANES[plane]
    e = _elements(chains)
    ang = np.mod(np.arctan2(e[:, b], e[:, a]), np.pi)
    w = np.hypot(e[:, a], e[:, b])
    hist, edges = np.histogram(ang, bins=int(bins), range=(0.0, np.pi), weights=w)
    return edges, hist


def tortuosity(chains, *, closed: bool = False) -> float:
    """ξ = (1/l) ∫ ρ⁻¹(s) ds [m⁻¹] (paper §2.4, Fig. 7).

    The curvature at an inner bead is the Menger curvature of the bead and its two
    neighbours, κ = 2 sin(turning angle) / |X_{i+1} − X_{i−1}| (the inverse radius of the
    circle through them, exact for beads on a circle), and the integral gives each inner
    bead half of its two elements.  l is the total wire length.  A straight chain gives 0;
    ``closed=True`` treats each chain as a loop (last bead linked to the first).
    """
    num, den = 0.0, 0.0
    for c in _as_chains(chains):
        if closed:
            c = np.vstack([c[-1:], c, c[:1]])
        if len(c) < 2:
            continue
        e = np.diff(c, axis=0)
        ln = np.linalg.norm(e, axis=1)
        den += ln[1:].sum() if closed else ln.sum()       # padding element not counted
        if len(c) < 3:
            continue
        e1, e2 = e[:-1], e[1:]
        cross = np.linalg.norm(np.cross(e1, e2), axis=1)
        chord = np.linalg.norm(c[2:] - c[:-2], axis=1)
        # 2 sin(φ)/chord with sin φ = |e1 × e2| / (|e1| |e2|)
        kappa = 2.0 * cross / np.where(ln[:-1] * ln[1:] * chord > 0, ln[:-1] * ln[1:] * chord, 1.0)
        num += float(np.sum(kappa * 0.5 * (ln[:-1] + ln[1:])))
    if den == 0:
        raise ValueError("the chains have no element of non-zero length")
    return num / den


@dataclass(frozen=True)
class WireStats:
    """Summary of a wire network: ``length`` [m], ``density`` [m·m⁻³] (if a volume was given,
    else nan), ``orientation`` (3, 3), its ``eigenvalues`` (ascending), ``tortuosity`` [m⁻¹],
    ``n_wires``, ``n_beads``."""

    length: float
    density: float
    orientation: np.ndarray
    eigenvalues: np.ndarray
    tortuosity: float
    n_wires: int
    n_beads: int


def wire_stats(chains, volume: float | None = None) -> WireStats:
    """All of the above in one call."""
    chains = _as_chains(chains)
    A = orientation_tensor(chains)
    ln = wire_length(chains)
    return WireStats(length=ln, density=ln / volume if volume else float("nan"),
                     orientation=A, eigenvalues=np.linalg.eigvalsh(A),
                     tortuosity=tortuosity(chains), n_wires=len(chains),
                     n_beads=int(sum(len(c) for c in chains)))


@dataclass(frozen=True)
class Encasement:
    """A helical wire's confinement of the column it encases (:func:`encasement`).

    tension : float [N]        the mean link tension T.
    radius : float [m]         the mean distance R of the beads from the axis.
    confinement : float [Pa]   Δσ₃ = T / (R s): the radial stress a ring of hoop tension T
                               adds over its share s of the height (thin-walled ring).
    """

    tension: float
    radius: float
    confinement: float

    def deviator_gain(self, k_p: float) -> float:
        """Δq ≈ K_p Δσ₃ [Pa]: the deviator the encasement adds to a column of passive
        coefficient K_p = (1 + sin φ)/(1 − sin φ) = σ₁/σ₃ (the total lateral stress held at
        the confining pressure, the sand's raised by Δσ₃)."""
        return float(k_p) * self.confinement


def encasement(tension, positions, *, pitch: float, axis=(0.0, 0.0)) -> Encasement:
    """The confinement a helix of ``pitch`` s [m] adds to the sand it encases: Δσ₃ = T/(R s),
    T the mean of the link tensions ``tension`` (l,) [N], R the beads' mean distance from
    the vertical ``axis`` (x, y) [m], ``positions`` (k, 3) [m] the beads' centres."""
    p = np.asarray(positions, float).reshape(-1, 3)
    s = float(pitch)
    if not (np.isfinite(s) and s > 0):
        raise ValueError(f"pitch must be a length > 0 [m], got {pitch!r}")
    T = float(np.mean(tension))
    R = float(np.mean(np.hypot(p[:, 0] - axis[0], p[:, 1] - axis[1])))
    return Encasement(tension=T, radius=R, confinement=T / (R * s))
