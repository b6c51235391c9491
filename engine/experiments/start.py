"""What a test starts from (issue 30 §1-2): the sample it builds itself, a prepared
geometric sample, or the end state of another run (a deposit in the mould, a user's own
scene), prepared one of :data:`PREPARATIONS` ways.

:func:`start_of` turns each of these into one :class:`Start`, which adds the particles to
the test's :class:`~engine.scene.Scene` (:meth:`Start.add_to`) and, for an end state,
carries over what a new scene cannot hold (:meth:`Start.carry_over`): the particles'
velocities and spins, the wire links' reference lengths, laws and broken links.  The
contacts' impulses are not carried: a history frame holds forces, not the warm start, so a
test started from a state in memory and one started from its history file run the same
steps bit for bit.

Preparations (``preparation=`` of the triaxial tests):

``"geometric"``
    the sample as :mod:`engine.prep` builds it ("only geometrically admissible", §2.4),
    loaded directly (the tests' behaviour before issue 30);
``"paper"``
    §2.4's whole preparation: the geometric sample, then "a deposit under gravity to relax
    the sample and to obtain the force network" in its mould
    (:func:`engine.experiments.gravity_deposit`, its history beside the test's as
    ``<history>.deposit.h5``), then the mould removed and the test's own confinement
    (§3.3's pressurization) from that end state;
``"layered"``
    the paper preparation of a sample built as the TexSol machine lays it (§1.1): the sand
    in layers, the wire walked on each layer's free surface and covered by the next
    (:func:`engine.prep.cylinder_sample` with ``build="layered"``), then the same deposit
    under gravity; with no wire, the sand laid in the same layers.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, replace

import numpy as np

from .. import laws as _laws
from ..model import CYLINDER, PLANE, SPHERE, Model
from ..prep import Box, Cylinder
from ..prep.samples import Sample
from ..state import State

__all__ = ["PREPARATIONS", "REMOVE_BEADS", "Start", "start_of", "state_of", "remove_group",
           "without_wire"]

#: When a control takes the beads out of a TexSol sample (``remove_beads=`` of the triaxial
#: tests): never, after the geometric deposit (:func:`without_wire`: the sand laid around
#: the beads, then prepared and tested without them), or at the start of the loading
#: (:func:`remove_group`: the very packing the TexSol test loads, without its beads).
REMOVE_BEADS = ("never", "after_deposit", "at_loading")

#: The preparations of the triaxial tests (module docstring).
PREPARATIONS = ("geometric", "paper", "layered")

#: Relative spread of the particles' densities within a group that still counts as one
#: density (m / (4/3 π r³) recomputed from a stored mass differs in the last bits).
DENSITY_RTOL = 1e-9


@dataclass
class Start:
    """The particles a test starts from.

    Attributes
    ----------
    source : str                       what they came from, for messages and ``params``.
    container : Box | Cylinder | None  the mould [m] (None: not known).
    floor : float [m]                  z of the floor the sample stands on.
    sand_radii : (n,) [m];  sand_density : float [kg/m³]
    n_beads : int;  wire_density : float [m·m⁻³] (0 without a wire, nan: not known)
    sample : engine.prep.Sample | None        a geometric sample, added as it is.
    model, state : the end state, or None     a state's particles, re-added in order.
    """

    source: str
    container: object
    floor: float
    sand_radii: np.ndarray
    sand_density: float
    n_beads: int
    wire_density: float
    sample: Sample | None = None
    model: Model | None = None
    state: State | None = None
    _wires: list = field(default_factory=list)     # (bead ids, closed, touch, link ids)
    _sand: np.ndarray = None
    _new_ids: np.ndarray = None                    # the new id of each source body (-1: none)

    @property
    def has_wire(self) -> bool:
        return self.n_beads > 0

    @property
    def sand_mass(self) -> float:
        """[kg]"""
        return float(self.sand_density * 4 / 3 * np.pi * (self.sand_radii ** 3).sum())

    @property
    def height(self) -> float:
        """Top of the highest particle above the floor [m]."""
        if self.sample is not None:
            return self.sample.height
        ids = self.particles()
        x, r = self.state.position[ids], self.model.body_radius[ids]
        return float((x[:, 2] + r).max() - self.floor)

    @property
    def bead_radius(self) -> float:
        """[m] (nan without a wire)"""
        if self.sample is not None:
            return float(self.sample.bead_radius) if self.sample.wire else math.nan
        if not self._wires:
            return math.nan
        return float(self.model.body_radius[self._wires[0][0][0]])

    def wire_law(self, default):
        """The wire's law: ``default`` (the test's) for a geometric sample, the first link's
        for an end state (every link keeps its own, :meth:`carry_over`)."""
        if self.sample is not None or not self._wires:
            return default
        return _law_of(self.model, self._wires[0][3][0])

    def axis(self) -> tuple:
        """(x, y) [m] of the sample's vertical axis: the mould's, else the middle of the
        particles' extent."""
        c = self.container
        if c is not None:
            lo, hi = c.bounds()
            return (float(c.center[0]), float(c.center[1])) if isinstance(c, Cylinder) else \
                (0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]))
        lo, hi = self.extent()
        return (0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]))

    def extent(self):
        """(lo, hi) (3,) [m]: the particles' bounding box."""
        if self.sample is not None:
            x, r = self.sample.sand_centers, self.sample.sand_radii
            if self.sample.wire:
                b = np.vstack(self.sample.wire)
                x = np.vstack([x, b])
                r = np.r_[r, np.full(len(b), self.sample.bead_radius)]
        else:
            ids = self.particles()
            x, r = self.state.position[ids], self.model.body_radius[ids]
        return (x - r[:, None]).min(0), (x + r[:, None]).max(0)

    def box(self) -> Box:
        """The mould if it is a box, else the particles' bounding box from the floor."""
        if isinstance(self.container, Box):
            return self.container
        lo, hi = self.extent()
        return Box((lo[0], lo[1], self.floor), (hi[0], hi[1], hi[2]))

    def particles(self) -> np.ndarray:
        """Source ids of the particles (sand, then beads) of a state start."""
        return np.concatenate([self._sand] + [w[0] for w in self._wires])

    def outer_radius(self, center=(0.0, 0.0)) -> float:
        """The mould's radius, or the particles' largest distance from the axis + radius."""
        if isinstance(self.container, Cylinder):
            return float(self.container.radius)
        if self.sample is not None:
            x, r = self.sample.sand_centers, self.sample.sand_radii
        else:
            ids = self.particles()
            x, r = self.state.position[ids], self.model.body_radius[ids]
        return float((np.hypot(x[:, 0] - center[0], x[:, 1] - center[1]) + r).max())

    def volume(self) -> float:
        """[m³] the mould's, else the particles' cylinder about :meth:`axis` from the floor."""
        if self.container is not None:
            return float(self.container.volume)
        return float(np.pi * self.outer_radius(self.axis()) ** 2 * self.height)

    def add_to(self, scene, *, wire_law=None, neighbour_contact=False, shift=None):
        """Add the particles to ``scene`` (groups "sand" and "wire"), moved by ``shift``
        (3,) [m] if given; returns (sand ids, list of bead-id arrays).  A geometric sample
        gets ``wire_law`` and ``neighbour_contact``; an end state's wires keep theirs
        (:meth:`carry_over`)."""
        if self.sample is not None:
            smp = self.sample
            if shift is not None:
                smp = replace(smp, sand_centers=smp.sand_centers + shift,
                              wire=[c + shift for c in smp.wire])
            if smp.wire:
                return smp.add_to(scene, wire_law=wire_law, neighbour_contact=neighbour_contact)
            return smp.add_to(scene)[0], []
        m, s = self.model, self.state
        x = s.position if shift is None else s.position + shift
        new = -np.ones(m.n_bodies, np.int64)
        sand = scene.add_spheres(x[self._sand], m.body_radius[self._sand],
                                 density=self.sand_density, group="sand")
        new[self._sand] = sand
        beads = []
        for ids, closed, touch, links in self._wires:
            b = scene.add_wire(x[ids], radius=float(m.body_radius[ids[0]]),
                               density=_density(m, ids, "wire"), law=_law_of(m, links[0]),
                               closed=closed, neighbour_contact=touch,
                               reference_lengths=m.link_ref_length[links])
            new[ids] = b
            beads.append(b)
        self._new_ids = new
        return sand, beads

    def carry_over(self, model: Model, state: State) -> Model:
        """After ``scene.compile``: an end state's velocities, spins, link laws (per link:
        a wire may mix them) and broken links into the new ``model``/``state`` (the
        reference lengths came with :meth:`add_to`); returns the model (the same one for a
        geometric sample)."""
        if self.sample is not None:
            return model
        m, s, new = self.model, self.state, self._new_ids
        src = np.flatnonzero(new >= 0)
        state.vel6[new[src]] = s.vel6[src]
        if not m.n_links:
            return model
        # the source link of each new link, by its two beads (new ids)
        key = {(int(new[i]), int(new[j])): k for k, (i, j) in enumerate(zip(m.link_i, m.link_j))}
        order = np.array([key[(int(i), int(j))] for i, j in zip(model.link_i, model.link_j)],
                         np.int64)
        state.link_broken[:] = s.link_broken[order]
        state.link_excluded_next[:] = model.body_next
        state.link_excluded_next[model.link_i[state.link_broken]] = -1
        return replace(model, **{name: getattr(m, name)[order] for name in (
            "link_law", "link_stiffness", "link_max_tension", "link_unilateral")})


def _law_of(model, k):
    """A wire law object of link ``k``'s code, stiffness and breaking tension (its reference
    length is carried over separately)."""
    code, stiff, tmax = int(model.link_law[k]), float(model.link_stiffness[k]), \
        float(model.link_max_tension[k])
    if code == _laws.RIGID_ROD:
        return _laws.RigidRod()
    if code == _laws.ELASTIC_ROD:
        return _laws.ElasticRod(stiffness=stiff)
    if code == _laws.RIGID_WIRE:
        return _laws.RigidWire()
    if code == _laws.LOOSE_WIRE:
        return _laws.LooseWire()
    if math.isfinite(tmax):
        return _laws.BrittleElasticWire(stiffness=stiff, max_tension=tmax)
    return _laws.ElasticWire(stiffness=stiff)


def _density(model, ids, group) -> float:
    """The one density [kg/m³] of bodies ``ids``, to 12 significant digits: m / (4/3 π r³)
    of a stored mass differs from the density it was made with in the last bits, and the
    masses :meth:`Scene.add_spheres` recomputes from the rounded value are those of the
    original scene (a 2650 kg/m³ sand gives back its masses exactly)."""
    rho = model.body_mass[ids] / (4 / 3 * np.pi * model.body_radius[ids] ** 3)
    if rho.size and np.ptp(rho) > DENSITY_RTOL * rho.max():
        raise ValueError(f"sample: the start state's {group} has several densities "
                         f"({rho.min():.6g}-{rho.max():.6g} kg/m³); a test takes one per group")
    return float(f"{np.median(rho):.12g}")


def _wires_of(model, state, bead_group) -> list:
    """The wires of a model: (bead ids in order, closed, neighbour contact, link ids) each,
    from its links in :meth:`Scene.add_wire`'s order (links i -> i+1 along each wire)."""
    li, lj = np.asarray(model.link_i), np.asarray(model.link_j)
    if not li.size:
        return []
    breaks = np.flatnonzero(lj[:-1] != li[1:]) + 1
    wires = []
    for a, b in zip(np.r_[0, breaks], np.r_[breaks, li.size]):
        closed = bool(lj[b - 1] == li[a])
        ids = li[a:b] if closed else np.r_[li[a:b], lj[b - 1]]
        if np.unique(ids).size != ids.size or not np.all(model.body_group[ids] == bead_group):
            raise ValueError("sample: the start state's links do not form wires of the "
                             "\"wire\" group in add_wire's order (links i -> i+1)")
        touch = bool(model.body_next[li[a]] == -1)
        wires.append((ids.astype(np.int64), closed, touch, np.arange(a, b)))
    return wires


def _mould_of(model, state):
    """(container, floor z) of a state's walls: the cylinder wall, or the box of the side
    planes (±x, ±y), and the floor plane (normal +z); None and None where absent."""
    floor, container = None, None
    planes = [b for b in model.wall_ids if model.body_kind[b] == PLANE]
    for b in planes:
        if np.allclose(model.body_axis[b], (0, 0, 1)):
            z = float(state.position[b, 2])
            floor = z if floor is None else min(floor, z)
    cyl = [b for b in model.wall_ids if model.body_kind[b] == CYLINDER]
    z0 = 0.0 if floor is None else floor
    if cyl:
        b = cyl[0]
        c = state.position[b]
        container = Cylinder(float(model.body_radius[b]), float(model.body_height[b]),
                             (float(c[0]), float(c[1]), float(c[2])))
    else:
        lo, hi = [None] * 2, [None] * 2
        for b in planes:
            n, x = model.body_axis[b], state.position[b]
            for ax in (0, 1):
                e = np.zeros(3)
                e[ax] = 1.0
                if np.allclose(n, e):
                    lo[ax] = float(x[ax])
                elif np.allclose(n, -e):
                    hi[ax] = float(x[ax])
        if None not in lo and None not in hi:
            top = float(state.position[model.sphere_ids, 2].max()
                        + model.body_radius[model.sphere_ids].max())
            container = Box((lo[0], lo[1], z0), (hi[0], hi[1], max(top, z0)))
    return container, floor


def state_of(sample):
    """(model, state, where) of an end state given as ``(model, state)``, a result with a
    ``history`` (:class:`~engine.experiments.DepositResult`, ...) or the path of a history
    or checkpoint file (its last state)."""
    from .. import io

    if isinstance(sample, tuple) and len(sample) == 2 and isinstance(sample[0], Model) \
            and isinstance(sample[1], State):
        return sample[0], sample[1], "a (model, state) pair"
    path = getattr(sample, "history", sample)
    if isinstance(path, (str, os.PathLike)):
        model, state = io.load(path, frame=-1)
        return model, state, f"the end state of {os.fspath(path)}"
    raise ValueError(f"sample must be an engine.prep.Sample, a (model, state) pair, a result "
                     f"with a history (e.g. gravity_deposit's) or a history path, got "
                     f"{type(sample).__name__}")


def from_state(model, state, where) -> Start:
    """A :class:`Start` of an end state: its "sand" spheres and its "wire" beads and links;
    its walls are left behind (the mould removed)."""
    names = tuple(model.group_names)
    if "sand" not in names:
        raise ValueError(f"sample: {where} has no \"sand\" group (its groups: "
                         f"{', '.join(names)}); a test needs its grains in \"sand\"")
    kinds = np.asarray(model.body_kind)
    groups = np.asarray(model.body_group)
    sand_g = names.index("sand")
    wire_g = names.index("wire") if "wire" in names else -1
    other = np.flatnonzero((kinds == SPHERE) & (groups != sand_g) & (groups != wire_g))
    if other.size:
        bad = sorted({names[g] for g in groups[other]})
        raise ValueError(f"sample: {where} has spheres in group(s) {', '.join(bad)}; a test "
                         f"takes \"sand\" and \"wire\" only")
    sand = np.flatnonzero((kinds == SPHERE) & (groups == sand_g))
    if sand.size == 0:
        raise ValueError(f"sample: {where} has no sand grain")
    wires = _wires_of(model, state, wire_g)
    linked = np.concatenate([w[0] for w in wires]) if wires else np.zeros(0, np.int64)
    loose = np.setdiff1d(np.flatnonzero((kinds == SPHERE) & (groups == wire_g)), linked)
    if loose.size:
        raise ValueError(f"sample: {where} has {loose.size} \"wire\" beads in no link")
    container, floor = _mould_of(model, state)
    if floor is None:
        floor = float((state.position[sand, 2] - model.body_radius[sand]).min())
    n_beads = int(linked.size)
    wd = math.nan
    if not n_beads:
        wd = 0.0
    elif container is not None:
        g = np.linalg.norm(state.position[model.link_i] - state.position[model.link_j], axis=1)
        wd = float(g.sum() / container.volume)
    st = Start(source=where, container=container, floor=floor,
               sand_radii=np.asarray(model.body_radius[sand]).copy(),
               sand_density=_density(model, sand, "sand"), n_beads=n_beads, wire_density=wd,
               model=model, state=state)
    st._sand, st._wires = sand, wires
    return st


def from_sample(sample: Sample) -> Start:
    """A :class:`Start` of a geometric sample (:mod:`engine.prep`)."""
    return Start(source=f"a {sample.name} sample (engine.prep)", container=sample.container,
                 floor=float(sample.container.bounds()[0][2]),
                 sand_radii=np.asarray(sample.sand_radii), sand_density=2650.0,
                 n_beads=sample.n_beads, wire_density=sample.wire_density, sample=sample)


def check_preparation(value) -> str:
    if value not in PREPARATIONS:
        raise ValueError(f"preparation = {value!r}: must be one of "
                         f"{', '.join(map(repr, PREPARATIONS))}")
    return value


def start_of(test: str, shape: type, sample, build, *, wire: bool, wire_law=None) -> Start:
    """The :class:`Start` of test ``test``, whose sample must sit in a ``shape`` container
    (Cylinder or Box): ``sample`` (None: ``build()``, the test's own geometric sample; an
    :class:`engine.prep.Sample`; or an end state, :func:`state_of`).  Refused by name: a
    sample of the other shape, ``wire=False`` with a sample that has a wire, a
    ``wire_law`` with an end state (its links keep their own laws)."""
    if sample is None:
        st = from_sample(build())
    elif isinstance(sample, Sample):
        st = from_sample(sample)
    else:
        st = from_state(*state_of(sample))
        if wire_law is not None and st.has_wire:
            raise ValueError(f"{test}: wire_law = {wire_law!r} with a start state: its links "
                             f"keep their own law and reference lengths (pass wire_law=None)")
    want = shape.__name__.lower()
    if st.container is not None and not isinstance(st.container, shape):
        raise ValueError(f"{test}: sample is {st.source} in a "
                         f"{type(st.container).__name__.lower()} mould; the test needs a "
                         f"{want} sample (engine.prep.{want}_sample)")
    if sample is not None and not wire and st.has_wire:
        raise ValueError(f"{test}: wire = False but the sample ({st.source}) has a wire of "
                         f"{st.n_beads} beads; give a sample built with wire=False")
    return st


def without_wire(st: Start) -> Start:
    """The :class:`Start` of a geometric sample's sand without its wire: the grains where
    the geometric deposit laid them around the beads, the beads taken out (the control
    ``remove_beads="after_deposit"``)."""
    if st.sample is None or not st.has_wire:
        raise ValueError(f"remove_beads = 'after_deposit' takes the beads out of a geometric "
                         f"sample with a wire; the sample is {st.source}"
                         + ("" if st.sample is None else " without a wire"))
    smp = replace(st.sample, wire=[], wire_density=0.0,
                  info=dict(st.sample.info, beads_removed=st.sample.n_beads))
    out = from_sample(smp)
    out.source = f"{st.source}, its {st.n_beads} beads removed after the geometric deposit"
    return out


def remove_group(model: Model, state: State, group: str) -> Model:
    """Take the bodies of ``group`` out of the mechanics from the next step on: they touch
    nothing (every pair of groups with ``group`` loses its law), their links carry no force
    (:class:`engine.laws.LooseWire`) and they stay where they are, fixed (zero velocity and
    spin).  They stay in the model and the files (so a history keeps one body count), out
    of every contact, link force and stress.  The candidate pairs are rebuilt at the next
    step.  Returns the new model; ``state`` is changed in place (the control
    ``remove_beads="at_loading"``)."""
    new = model.with_group_removed(group)
    ids = np.flatnonzero(model.body_group == model.group_id(group))
    state.vel6[ids] = 0.0
    state.link_impulse[model.links_of(ids)] = 0.0
    state.pairs_ref = None
    return new
