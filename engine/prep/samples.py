"""The paper's numerical TexSol samples, built in one call at a ``scale`` factor.

``scale`` multiplies the number of particles and the volume (lengths by scale^(1/3)); grain
and bead sizes and the wire density stay the paper's.  scale = 1 is the paper's size:

=================  =====================  ===================  =================================
sample             container              sand                 wire
=================  =====================  ===================  =================================
``cylinder``       Ø9 mm × 20 mm (§3.3)   6 200, Ø0.3–0.8 mm   250 km·m⁻³, r_w = 0.135 mm (≈1 100 beads)
``box``            16 mm cube (§3.2)      6 500, Ø0.46–1.25 mm 200 km·m⁻³, r_w = r_min (≈1 600 beads)
``slope``          Ø12 mm × 14 mm (§3.1)  26 000, Ø0.2–0.6 mm  400 km·m⁻³, r_w = 0.1 mm (≈2 900 beads),
                                                               none in an outer layer 2 d_max thick
=================  =====================  ===================  =================================

Choices the paper leaves open, made here: the gap between beads is g_w = 0.2 r_w; the box's
sand size (not given in the paper) is the one that fills the box with its 6 500 grains; the
cylinder's bead radius is 0.9 r_min, the largest that gives its ~1 100 beads at 250 km·m⁻³;
the slope's wire density is counted over the whole sample although the wire stays inside the
outer layer.  The wire is built first by the isotropic walk (Eq. 16), the orthotropic walk
(Eq. 17) or, for the cylinder only, as a helix (``wire_mode="helix"``, not in the paper: a
sand column encased by the wire, :func:`engine.prep.wire.helix`), then the sand by the
geometric deposit around it; or, ``build="layered"``, the sand in layers, each layer's wire
walked by Eq. (17) on its free surface and covered by the next layer.  Every sample is "only
geometrically admissible": relax it
(:func:`engine.prep.relax`) before a test.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from .. import laws as _laws
from ..analysis.wire import wire_length
from . import granulometry
from .containers import Box, Cylinder
from .deposit import DepositError, geometric
from .wire import KM_PER_M3, helix, random_walk

__all__ = ["Sample", "paper_sample", "cylinder_sample", "box_sample", "slope_sample", "PAPER",
           "PULLOUT", "pullout_sample", "pullout_box", "pullout_min_scale",
           "WIRE_MODES", "BUILDS", "default_layers"]

PAPER = {
    "cylinder": dict(diameter=9e-3, height=20e-3, n_sand=6200, d_min=0.3e-3, d_max=0.8e-3,
                     wire_density=250 * KM_PER_M3, bead_radius=0.135e-3),
    "box": dict(side=16e-3, n_sand=6500, d_min=0.46e-3, d_max=1.25e-3,
                wire_density=200 * KM_PER_M3, bead_radius=0.23e-3),
    "slope": dict(diameter=12e-3, height=14e-3, n_sand=26000, d_min=0.2e-3, d_max=0.6e-3,
                  wire_density=400 * KM_PER_M3, bead_radius=0.1e-3),
}
"""The paper's sample parameters (SI)."""


@dataclass
class Sample:
    """A geometric TexSol sample.

    Attributes
    ----------
    name : str
    container : Box | Cylinder      the mould [m].
    sand_centers : (n, 3) [m];  sand_radii : (n,) [m]
    wire : list of (k, 3) [m]       bead centres of each wire.
    bead_radius : float [m];  gap : float [m]
    wire_density : float [m·m⁻³]    built wire length / container volume.
    info : dict                      counts, heights, timings [s].
    """

    name: str
    container: object
    sand_centers: np.ndarray
    sand_radii: np.ndarray
    wire: list
    bead_radius: float
    gap: float
    wire_density: float
    info: dict = field(default_factory=dict)

    @property
    def n_beads(self) -> int:
        return int(sum(len(c) for c in self.wire))

    @property
    def height(self) -> float:
        """Top of the highest particle above the container's floor [m]."""
        z0 = self.container.bounds()[0][2]
        tops = [self.sand_centers[:, 2] + self.sand_radii]
        tops += [c[:, 2] + self.bead_radius for c in self.wire]
        return float(np.concatenate(tops).max() - z0) if self.sand_radii.size or self.wire else 0.0

    def add_to(self, scene, *, sand_group: str = "sand", wire_group: str = "wire",
               sand_density: float = 2650.0, bead_density: float = 1400.0, wire_law=None,
               neighbour_contact: bool = False):
        """Add the sand and the wires to an :class:`engine.Scene`.

        Returns (sand ids (n,), list of bead-id arrays, one per wire).  ``wire_law`` defaults
        to ``ElasticWire(stiffness=1.0)`` (the paper's k = 1 N, §3.3); ``neighbour_contact``
        as in :meth:`engine.Scene.add_wire`.
        """
        law = _laws.ElasticWire(stiffness=1.0) if wire_law is None else wire_law
        sand = scene.add_spheres(self.sand_centers, self.sand_radii, density=sand_density,
                                 group=sand_group)
        beads = [scene.add_wire(c, radius=self.bead_radius, density=bead_density,
                                group=wire_group, law=law, neighbour_contact=neighbour_contact)
                 for c in self.wire]
        return sand, beads

    def __str__(self):
        i = self.info
        return (f"{self.name} sample: {self.sand_radii.size} grains + {self.n_beads} beads in "
                f"{len(self.wire)} wire(s) at {self.wire_density / KM_PER_M3:.1f} km·m⁻³, "
                f"height {self.height * 1e3:.2f} mm (wire {i.get('wire_time', 0):.2f} s, "
                f"deposit {i.get('deposit_time', 0):.2f} s)")


def _mould(container, height):
    """``container`` from its floor, ``height`` [m] tall (a Cylinder or a Box)."""
    if isinstance(container, Cylinder):
        return Cylinder(container.radius, height, container.center)
    lo, hi = np.array(container.lo), np.array(container.hi)
    hi[2] = lo[2] + height
    return Box(lo, hi)


def _deposit(container, radii, obstacles, seed, heights):
    """(centres, radii) of the geometric deposit of ``radii`` around ``obstacles``
    (:func:`geometric`) in ``container`` made ``heights[0]`` tall, or, when not every grain
    fits below its top, the next of ``heights`` [m]."""
    for attempt, height in enumerate(heights):
        try:
            return geometric(radii, _mould(container, height), obstacles=obstacles, seed=seed)
        except DepositError:
            if attempt == len(heights) - 1:
                raise


def _taller(container, deposit_height_factor=1.5):
    """The heights :func:`_deposit` tries for a whole sample: the mould made
    ``deposit_height_factor`` times taller, then by half again, three times (the sand's
    height is what it is, reported in info; a small sample can leave its last grains no
    pocket below the mould's top: seen, box_sample(0.05, seed=2), 324 of 325 grains
    placed)."""
    if isinstance(container, Cylinder):
        height = container.height
    else:
        lo, hi = container.bounds()
        height = hi[2] - lo[2]
    return [height * (deposit_height_factor * 1.5 ** k) for k in range(4)]


def _slab(region, z0, z1):
    """``region`` cut to the heights [z0, z1] (a Cylinder or a Box)."""
    if isinstance(region, Cylinder):
        cx, cy, _ = region.center
        return Cylinder(region.radius, z1 - z0, (cx, cy, z0))
    lo, hi = np.array(region.lo, float), np.array(region.hi, float)
    lo[2], hi[2] = z0, z1
    return Box(lo, hi)


def _layered(container, wire_region, radii, *, wire, length, bead_radius, gap, seed, layers,
             deposit_height_factor=1.5):
    """The sand and the wire of a layered build (``build="layered"``): the grains in
    ``layers`` equal shares, each laid by the geometric deposit on what is there already
    (grains and beads: obstacles it rests on); on the free surface of each share but the
    last, a wire of ``length / (layers - 1)`` walked by Eq. (17) (horizontal, one layer),
    its beads' centres r_w above the 90th percentile of that share's grain tops (a bead
    that would overlap a grain standing higher is refused and the walk goes round it),
    inside ``wire_region``; the next share covers it.  Returns (centres, radii, chains,
    the wire layers' surface heights [m])."""
    z_floor = float(container.bounds()[0][2])
    H = float(container.bounds()[1][2]) - z_floor
    a = 2.0 * bead_radius + gap
    shares = np.array_split(np.arange(radii.size), layers)
    n_wires = layers - 1
    centers, rads, chains, surfaces = np.zeros((0, 3)), np.zeros(0), [], []
    top = z_floor
    for k, share in enumerate(shares):
        beads = np.vstack(chains) if chains else np.zeros((0, 3))
        obstacles = (np.vstack([centers, beads]),
                     np.r_[rads, np.full(beads.shape[0], bead_radius)])
        mould_top = top + deposit_height_factor * H / layers
        c, r = _deposit(container, radii[share], obstacles if obstacles[1].size else None,
                        seed + 1 + 7919 * k,
                        [mould_top + (1.5 ** attempt - 1) * H / layers - z_floor
                         for attempt in range(4)])
        centers, rads = np.vstack([centers, c]), np.r_[rads, r]
        top = float((c[:, 2] + r).max())
        if not wire or k == layers - 1:
            continue
        surface = float(np.percentile(c[:, 2] + r, 90))
        surfaces.append(surface)
        z_w = surface + bead_radius
        slab = _slab(wire_region, z_w - bead_radius - a, z_w + bead_radius + a)
        beads = np.vstack(chains) if chains else np.zeros((0, 3))
        try:
            chains += random_walk(slab, bead_radius, gap, length=length / n_wires,
                                  seed=seed + 31 * k, search_angle=math.pi / 4,
                                  mode="orthotropic", layers=[z_w],
                                  obstacles=(np.vstack([centers, beads]),
                                             np.r_[rads, np.full(beads.shape[0], bead_radius)]))
        except ValueError as e:
            raise ValueError(f"layers = {layers}: the wire of layer {k + 1} "
                             f"({length / n_wires:.4g} m) does not fit on its free surface "
                             f"({e}); use more layers") from None
        top = max(top, z_w + bead_radius)
    return centers, rads, chains, surfaces


def _build(name, container, wire_region, radii, *, wire, wire_density, bead_radius, seed,
           wire_mode="isotropic", helix_pitch=None, helix_inset=0.0, deposit_height_factor=1.5,
           build="wire_first", layers=None):
    bead_radius = float(bead_radius)
    gap = 0.2 * bead_radius
    t0 = time.perf_counter()
    chains = []
    if build == "layered":
        centers, r, chains, surfaces = _layered(
            container, wire_region, radii, wire=wire, length=wire_density * container.volume,
            bead_radius=bead_radius, gap=gap, seed=seed, layers=layers,
            deposit_height_factor=deposit_height_factor)
        t1, t2 = t0, time.perf_counter()           # walks and deposits interleaved
    elif wire and wire_mode == "helix":
        # the helix rises through the whole deposit mould (its beads take room, so the sand
        # rises above the container's top) and is cut at the sand's top once it is laid
        tall = Cylinder(wire_region.radius, wire_region.height * deposit_height_factor * 1.5,
                        wire_region.center)
        chains = helix(tall, bead_radius, gap, helix_pitch, inset=helix_inset)
    elif wire:
        chains = random_walk(wire_region, bead_radius, gap,
                             length=wire_density * container.volume, seed=seed,
                             search_angle=math.pi / 4, mode=wire_mode)
    if build != "layered":
        t1 = time.perf_counter()
        obstacles = None
        if chains:
            b = np.vstack(chains)
            obstacles = (b, np.full(b.shape[0], bead_radius))
        centers, r = _deposit(container, radii, obstacles, seed + 1,
                              _taller(container, deposit_height_factor))
        t2 = time.perf_counter()
    if chains and wire_mode == "helix":
        top = float((centers[:, 2] + r).max())
        chains = [c[c[:, 2] + bead_radius <= top] for c in chains]
    s = Sample(name=name, container=container, sand_centers=centers, sand_radii=r, wire=chains,
               bead_radius=bead_radius, gap=gap,
               wire_density=wire_length(chains) / container.volume if chains else 0.0)
    s.info.update(wire_time=t1 - t0, deposit_time=t2 - t1, n_sand=int(r.size),
                  n_beads=s.n_beads, n_wires=len(chains),
                  sand_top=float((centers[:, 2] + r).max() - container.bounds()[0][2]),
                  build=build)
    if build == "layered":
        s.info.update(layers=int(layers), wire_layers=[float(z) for z in surfaces])
    return s


#: Fewest sand grains of a paper sample: below, the builders failed on the wire ("cannot
#: fit") or the deposit ("placed 2 of 6 grains") instead of saying the scale is too small
#: (issue 33); at 10 grains every sample builds, with and without a wire (seeds 0-3).
MIN_GRAINS = 10

#: The wires of the samples: the walks of Eq. (16) and Eq. (17)
#: (:func:`engine.prep.random_walk`) and the helix of the cylinder (:func:`engine.prep.helix`).
WIRE_MODES = ("isotropic", "orthotropic", "helix")


#: How a sample is built: the wire walked through the whole mould first and the sand laid
#: around it (``"wire_first"``, the paper's §2.4), or the sand in layers, each covering the
#: wire walked on the layer below's free surface (``"layered"``, as the TexSol machine lays
#: them, §1.1).
BUILDS = ("wire_first", "layered")


def default_layers(height: float, bead_radius: float) -> int:
    """The layered build's number of sand layers in a mould ``height`` [m] tall: wire layers
    4 (2 r_w + g_w) apart, Eq. (17)'s layer spacing of :func:`engine.prep.random_walk`
    (1.19 mm for the cylinder's beads: 18 sand layers at scale 1, 9 at scale 0.1), one sand
    layer more than wire layers, at least 2."""
    a = 4.0 * (2.2 * float(bead_radius))
    return max(1, int(round(float(height) / a))) + 1


def _paper(name, container, wire_region, scale, *, wire, wire_density, bead_radius, seed,
           wire_mode="isotropic", helix_pitch=None, helix_inset=None, build="wire_first",
           layers=None):
    """The paper's grains for ``name`` at ``scale`` in ``container``, and the wire (walked by
    Eq. 16, ``wire_mode="isotropic"``, or Eq. 17, ``"orthotropic"``: horizontal layers with a
    rise angle of 5°, :func:`engine.prep.random_walk`; or the cylinder's ``"helix"``, one
    d_min inside the mould's side, of pitch ``helix_pitch`` or d_max)."""
    p = PAPER[name]
    if wire_mode not in WIRE_MODES:
        raise ValueError(f"wire_mode = {wire_mode!r}: must be one of "
                         f"{', '.join(map(repr, WIRE_MODES))}")
    if wire_mode == "helix" and name != "cylinder":
        raise ValueError(f"wire_mode = 'helix' needs the cylinder sample (a helix about its "
                         f"axis), not the {name}: use 'isotropic' or 'orthotropic'")
    if wire_mode == "helix" and wire_density is not None:
        raise ValueError(f"wire_density must be None with wire_mode = 'helix' (the helix's "
                         f"length is set by its helix_pitch), got {wire_density!r}")
    for key, v in (("helix_pitch", helix_pitch), ("helix_inset", helix_inset)):
        if v is not None and wire_mode != "helix":
            raise ValueError(f"{key} must be None with wire_mode = {wire_mode!r} (it is the "
                             f"helix's {key[6:]} [m]), got {v!r}")
    if helix_inset is not None and (isinstance(helix_inset, bool) or not isinstance(
            helix_inset, (int, float, np.number)) or not (math.isfinite(helix_inset)
                                                         and helix_inset >= 0)):
        raise ValueError(f"helix_inset must be a number >= 0 [m], got {helix_inset!r}")
    if build not in BUILDS:
        raise ValueError(f"build = {build!r}: must be one of {', '.join(map(repr, BUILDS))}")
    if build == "layered" and wire_mode != "isotropic":
        raise ValueError(f"wire_mode = {wire_mode!r} with build = 'layered': the layered build "
                         f"walks each layer's wire by Eq. 17 on the free surface; leave "
                         f"wire_mode at its default")
    if layers is not None and build != "layered":
        raise ValueError(f"layers must be None with build = {build!r} (it is the layered "
                         f"build's number of sand layers), got {layers!r}")
    if layers is not None and (isinstance(layers, bool) or not isinstance(
            layers, (int, np.integer)) or not 2 <= layers <= 1000):
        raise ValueError(f"layers must be an integer in [2, 1000] (sand layers; the wire lies "
                         f"between them), got {layers!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    for key, v in (("wire_density", wire_density), ("bead_radius", bead_radius),
                   ("helix_pitch", helix_pitch)):
        if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float, np.number))
                              or not (math.isfinite(v) and v > 0)):
            unit = "[m/m³]; None: the paper's" if key == "wire_density" else "[m]"
            hint = "" if key == "helix_pitch" else " (wire=False for sand only)"
            raise ValueError(f"{key} must be a number > 0 {unit}{hint}, got {v!r}")
    n = int(round(p["n_sand"] * scale))
    if n < MIN_GRAINS:
        least = math.ceil(MIN_GRAINS / p["n_sand"] * 1e4) / 1e4
        raise ValueError(f"scale {scale:g} gives a {name} sample of {n} grains (the paper's "
                         f"{p['n_sand']} x scale), fewer than {MIN_GRAINS}: use scale >= "
                         f"{least:g}")
    radii = granulometry.uniform(p["d_min"], p["d_max"], n=n, seed=seed + 2)
    return _build(name, container, wire_region, radii, wire=wire,
                  wire_density=p["wire_density"] if wire_density is None else wire_density,
                  bead_radius=p["bead_radius"] if bead_radius is None else bead_radius, seed=seed,
                  wire_mode=wire_mode,
                  helix_inset=p["d_min"] if helix_inset is None else float(helix_inset),
                  helix_pitch=p["d_max"] if helix_pitch is None else helix_pitch, build=build,
                  layers=(default_layers(container.bounds()[1][2] - container.bounds()[0][2],
                                         p["bead_radius"] if bead_radius is None
                                         else bead_radius)
                          if layers is None else int(layers)) if build == "layered" else None)


def _scale(scale):
    s = float(scale)
    if not (math.isfinite(s) and s > 0):
        raise ValueError(f"scale must be finite and > 0, got {scale!r}")
    return s


def cylinder_sample(scale: float = 1.0, *, wire: bool = True, wire_density: float | None = None,
                    bead_radius: float | None = None, seed: int = 0, wire_mode: str = "isotropic",
                    helix_pitch: float | None = None, helix_inset: float | None = None,
                    build: str = "wire_first", layers: int | None = None) -> Sample:
    """The cylinder triaxial sample (§3.3): Ø9 mm × 20 mm, 6 200 grains Ø0.3–0.8 mm and a wire
    at 250 km·m⁻³ (about 1 100 beads) at scale 1.  ``wire=False``: sand only.

    ``wire_mode="helix"`` (not in the paper): the wire is a helix about the axis, the beads'
    outer edge ``helix_inset`` [m] inside the mould's side (None: one small-grain diameter
    d_min = 0.3 mm, a layer the geometric deposit leaves nearly empty, so the beads are the
    sample's surface; d_max = 0.8 mm lays a layer of sand outside the helix), rising
    ``helix_pitch`` [m] per turn: a sand column encased by the wire, a positive control of
    the wire–sand coupling.  The default pitch s is d_max = 0.8 mm: the clear gap between
    turns is then s − 2 r_w = 0.8 − 0.27 = 0.53 mm, so the largest grains cannot pass between
    them (grains under 0.53 mm can).  The helix's length, hence the wire density, follows
    from the pitch and the sand's height (at the defaults 511 km·m⁻³ of the mould at scale
    1, 1 361 at scale 0.1), so
    ``wire_density`` must be None.  The sand is the same as with the other modes for one
    ``seed``.

    ``build="layered"`` (any of the three samples; not the paper's §2.4, which walks the
    wire first): the sand laid in ``layers`` layers (None: :func:`default_layers`, wire
    layers 1.19 mm apart), the wire walked by Eq. (17) on each layer's free surface and
    covered by the next, as the TexSol machine lays them (§1.1); the same wire length.
    With ``wire=False`` the sand is laid in the same layers."""
    p = PAPER["cylinder"]
    s = _scale(scale)
    L = s ** (1.0 / 3.0)
    c = Cylinder(0.5 * p["diameter"] * L, p["height"] * L)
    return _paper("cylinder", c, c, s, wire=wire, wire_density=wire_density,
                  bead_radius=bead_radius, seed=seed, wire_mode=wire_mode,
                  helix_pitch=helix_pitch, helix_inset=helix_inset, build=build,
                  layers=layers)


def box_sample(scale: float = 1.0, *, wire: bool = True, wire_density: float | None = None,
               bead_radius: float | None = None, seed: int = 0, wire_mode: str = "isotropic",
               helix_pitch: float | None = None, helix_inset: float | None = None,
               build: str = "wire_first", layers: int | None = None) -> Sample:
    """The box triaxial sample (§3.2): a 16 mm cube, 6 500 grains and a wire at 200 km·m⁻³
    (8 000 particles in all at scale 1).  ``bead_radius`` r_w (Fig. 12: r_min, r_min/3,
    r_min/4; default r_min).  ``wire_mode="helix"`` and ``helix_pitch`` are the cylinder's:
    refused."""
    s = _scale(scale)
    a = PAPER["box"]["side"] * s ** (1.0 / 3.0)
    c = Box((0.0, 0.0, 0.0), (a, a, a))
    return _paper("box", c, c, s, wire=wire, wire_density=wire_density,
                  bead_radius=bead_radius, seed=seed, wire_mode=wire_mode,
                  helix_pitch=helix_pitch, helix_inset=helix_inset, build=build,
                  layers=layers)


def slope_sample(scale: float = 1.0, *, wire: bool = True, wire_density: float | None = None,
                 bead_radius: float | None = None, seed: int = 0, wire_mode: str = "isotropic",
                 helix_pitch: float | None = None, helix_inset: float | None = None,
                 build: str = "wire_first", layers: int | None = None) -> Sample:
    """The slope-deposit sample (§3.1): Ø12 mm × 14 mm, 26 000 grains Ø0.2–0.6 mm and a wire
    at 400 km·m⁻³ (about 2 900 beads Ø0.2 mm), with no wire in an outer layer 2 d_max thick
    (at most a quarter of the radius).  ``wire_density=800e3`` gives the paper's TexSol(2).
    ``wire_mode="helix"`` and ``helix_pitch`` are the cylinder's: refused."""
    p = PAPER["slope"]
    s = _scale(scale)
    L = s ** (1.0 / 3.0)
    c = Cylinder(0.5 * p["diameter"] * L, p["height"] * L)
    layer = min(2 * p["d_max"], 0.25 * c.radius)
    inner = Cylinder(c.radius - layer, c.height)
    return _paper("slope", c, inner, s, wire=wire, wire_density=wire_density,
                  bead_radius=bead_radius, seed=seed, wire_mode=wire_mode,
                  helix_pitch=helix_pitch, helix_inset=helix_inset, build=build,
                  layers=layers)


#: The pull-out sample (:func:`pullout_sample`, not one of the paper's) at scale 1: a box
#: ``length`` along the wire (x) × ``width`` (y) × ``height`` (z) [m], filled with the
#: cylinder's sand (Ø0.3–0.8 mm, ``PAPER["cylinder"]``) at ``solid_fraction`` of its volume
#: less the beads'; no side narrower than ``min_diameters`` mean grain diameters.
PULLOUT = dict(length=10e-3, width=6e-3, height=6e-3, solid_fraction=0.6, min_diameters=5.0)


def pullout_min_scale() -> float:
    """The smallest scale of the pull-out box: its narrowest side (width and height, 6 mm
    × scale^(1/3)) is :data:`PULLOUT` ``min_diameters`` mean grain diameters (about 0.096)."""
    p, q = PULLOUT, PAPER["cylinder"]
    d_mean = 0.5 * (q["d_min"] + q["d_max"])
    return (p["min_diameters"] * d_mean / min(p["width"], p["height"])) ** 3


def pullout_box(scale: float = 1.0) -> Box:
    """The pull-out box at ``scale`` [m]: lo at the origin, sides :data:`PULLOUT` ×
    scale^(1/3); a scale below :func:`pullout_min_scale` is refused on one line."""
    p, q = PULLOUT, PAPER["cylinder"]
    s = _scale(scale)
    L = s ** (1.0 / 3.0)
    side = min(p["width"], p["height"]) * L
    d_mean = 0.5 * (q["d_min"] + q["d_max"])
    if side < p["min_diameters"] * d_mean * (1 - 1e-12):
        least = math.ceil(pullout_min_scale() * 1e4) / 1e4
        raise ValueError(f"scale = {scale!r}: the pull-out box would be {side * 1e3:.2f} mm "
                         f"wide and high, {side / d_mean:.1f} mean grain diameters (at least "
                         f"{p['min_diameters']:g}): use scale >= {least:g}")
    return Box((0.0, 0.0, 0.0), (p["length"] * L, p["width"] * L, p["height"] * L))


def pullout_sample(scale: float = 1.0, *, bead_radius: float | None = None,
                   seed: int = 0) -> Sample:
    """The pull-out test's sample (not in the paper): a straight wire along x at
    mid-height through a box of sand, leaving it through the box's +x face.

    The box is :func:`pullout_box` (10 mm × 6 mm × 6 mm at ``scale`` 1, lengths by
    scale^(1/3)).  The wire's beads (radius ``bead_radius`` r_w [m]; None: the cylinder's
    0.135 mm) are 2 r_w + g_w apart (g_w = 0.2 r_w, as in the paper samples), on the line
    y = W/2, z = H/2: the last one is just outside the +x face (centre at x = L_x + 1.1 r_w;
    the gap between it and its neighbour lies on the face), the first one leaves one
    largest-grain diameter (d_max = 0.8 mm) between its back and the −x face.  The sand
    (the cylinder's: diameters uniform in 0.3–0.8 mm) fills a solid fraction 0.6 of the box
    less the inner beads, laid by the geometric deposit around those beads in a mould 1.5
    times taller.  ``info`` has ``embedded_length`` (from the first bead's back to the +x
    face [m]), ``exit_x`` (the face's x [m]) and ``sand_top`` [m].
    """
    q = PAPER["cylinder"]
    box = pullout_box(scale)
    lo, hi = box.bounds()
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    rw = q["bead_radius"] if bead_radius is None else bead_radius
    if isinstance(rw, bool) or not isinstance(rw, (int, float, np.number)) \
            or not (math.isfinite(rw) and rw > 0):
        raise ValueError(f"bead_radius must be a number > 0 [m], got {bead_radius!r}")
    rw = float(rw)
    side = float(min(hi[1] - lo[1], hi[2] - lo[2]))
    if 2 * rw > side / PULLOUT["min_diameters"]:
        raise ValueError(f"bead_radius = {rw!r}: the wire must be at most a fifth of the box's "
                         f"width ({side:.4g} m): use bead_radius <= {side / 10:.3g} m")
    gap = 0.2 * rw
    pitch = 2 * rw + gap
    first = lo[0] + q["d_max"] + rw                     # the first bead's centre, at least
    n_in = int(math.floor((hi[0] - 0.5 * pitch - first) / pitch)) + 1
    if n_in < 2:
        raise ValueError(f"bead_radius = {rw!r}: fewer than 2 beads fit in the box's "
                         f"{(hi[0] - lo[0]) * 1e3:.2f} mm length")
    x = hi[0] + 0.5 * pitch - pitch * np.arange(n_in, -1, -1)     # the last one outside
    chain = np.column_stack([x, np.full(x.size, 0.5 * (lo[1] + hi[1])),
                             np.full(x.size, 0.5 * (lo[2] + hi[2]))])
    inner = chain[:-1]
    solid = PULLOUT["solid_fraction"] * (box.volume - inner.shape[0] * 4 / 3 * math.pi * rw ** 3)
    radii = granulometry.uniform(q["d_min"], q["d_max"], volume=solid, seed=seed + 2)
    t0 = time.perf_counter()
    centers, r = _deposit(box, radii, (inner, np.full(inner.shape[0], rw)), seed + 1,
                          _taller(box))
    s = Sample(name="pullout", container=box, sand_centers=centers, sand_radii=r,
               wire=[chain], bead_radius=rw, gap=gap,
               wire_density=wire_length([inner]) / box.volume)
    s.info.update(deposit_time=time.perf_counter() - t0, n_sand=int(r.size),
                  n_beads=s.n_beads, n_wires=1, exit_x=float(hi[0]),
                  embedded_length=float(hi[0] - (inner[0, 0] - rw)),
                  sand_top=float((centers[:, 2] + r).max() - lo[2]))
    return s


_BUILDERS = {"cylinder": cylinder_sample, "box": box_sample, "slope": slope_sample}


def paper_sample(name: str, scale: float = 1.0, **kw) -> Sample:
    """``paper_sample("cylinder" | "box" | "slope", scale, wire=..., seed=...)``; the
    keywords go to the builder (``wire_mode="helix"`` and ``helix_pitch``: the cylinder's)."""
    if name not in _BUILDERS:
        raise ValueError(f"name must be one of {sorted(_BUILDERS)}, got {name!r}")
    return _BUILDERS[name](scale, **kw)
