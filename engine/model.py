"""The static part of a simulation: counts, read-only per-body arrays and solver options.

A :class:`Model` is produced by :meth:`engine.Scene.compile` and never changes during a run
(MuJoCo's ``MjModel``).  Arrays are C-contiguous, read-only and named
``entity_attribute``; every unit is given in brackets.  Kernels receive these arrays, never
the dataclass itself.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional
import numpy as np
from pydantic import ConfigDict, Field, model_validator

from .checks import Checked

#: ``body_kind`` codes.
SPHERE, PLANE, CYLINDER = 0, 1, 2
KIND_NAMES = {SPHERE: "sphere", PLANE: "plane", CYLINDER: "cylinder"}

#: ``body_dof`` codes: how a body's translation is determined.
FREE = 0  #: integrated from forces and impulses (Eq. 3-4)
IMPOSED = 1  #: velocity imposed (fixed bodies: imposed zero); no rotation
LINE = 2  #: free along one direction ``body_line`` only (force- or pressure-driven walls)

#: The largest ``Options.max_iter`` (NLGS sweeps per step): a billion sweeps is hours a step
#: even on a small scene, and well inside the kernels' 64-bit counters.
MAX_ITER_LIMIT = 10**9

#: ``body_caps`` bits for cylinders.
CAP_BOTTOM, CAP_TOP = 1, 2

#: Columns of :attr:`Model.body_dyn`, the packed per-body row the NLGS kernel reads.
DYN_INV_MASS, DYN_INV_INERTIA, DYN_RADIUS, DYN_LINE, DYN_LX, DYN_LY, DYN_LZ = range(7)


def pack_body_dyn(kind, mass, inertia, radius, dof, line) -> np.ndarray:
    """The (nb, 8) row per body the NLGS kernel reads (:attr:`Model.body_dyn`), from the
    model's own arrays: 1/mass [1/kg] and 1/inertia [1/(kg·m²)] (0 for IMPOSED bodies, and
    the inertia's for walls), the radius [m] (0 for walls), the LINE flag and the line's
    direction (columns DYN_*; the eighth is padding).  The one place it is packed."""
    kind, dof = np.asarray(kind), np.asarray(dof)
    dyn = np.zeros((kind.shape[0], 8))
    movable = dof != IMPOSED
    dyn[:, DYN_INV_MASS] = np.where(movable, 1.0 / np.asarray(mass), 0.0)
    dyn[:, DYN_INV_INERTIA] = np.where(movable & (kind == SPHERE), 1.0 / np.asarray(inertia),
                                       0.0)
    dyn[:, DYN_RADIUS] = np.where(kind == SPHERE, radius, 0.0)
    dyn[:, DYN_LINE] = (dof == LINE).astype(float)
    dyn[:, DYN_LX:DYN_LZ + 1] = line
    return dyn


#: Overlap [fraction of the smaller radius of a contact's two bodies] past which a run
#: stops (:attr:`Options.max_overlap`): the smaller body half inside the other, ten times
#: the overlap a run's summary warns about (``engine.sanity.OVERLAP_WARN``, 5 %).  The
#: contact's normal, point and force no longer mean anything there; a run that must go on
#: past it raises the bound (up to 1000).
MAX_OVERLAP = 0.5

#: The position correction of the triaxial tests (box and cylinder) by default: the
#: measured choice of ``bench/bench_overlap.py``.  Without it the wire's light beads sink
#: into the grains step after step (47-65 % of a bead's radius in the paper-size TexSol
#: cylinders, 14.8 % in the demo's); with it 2.5-19 % and 0.9 %, for 40 % more NLGS
#: sweeps a step in the demo (docs/notes/2026-12-08-hostile-pass-two.md).
TRIAXIAL_OVERLAP_TOL = 0.005

#: The position correction's default (:attr:`Options.overlap_tol`): off.  Asked for
#: (0.005 is the measured choice, bench/bench_overlap.py), overlaps beyond this fraction of
#: the smaller radius are pushed out after every step.  Not on by default yet: a pull-out's
#: consolidation under a pressure-driven plate no longer comes to rest with it (kinetic
#: energy 1.2 % of its peak after 4 000 steps, against the 0.1 % it reaches without), and a
#: pile of grains 1 000 times heavier than the beads under them needs 12 times the sweeps
#: (docs/notes/2026-12-07-evening-drift-is-the-coupling-defect.md).
OVERLAP_TOL = None


class Options(Checked):
    """Time-stepping and solver options, validated (a bad value raises ``ValueError``
    naming the field and its allowed range).

    Attributes
    ----------
    dt : float
        Time step h [s], > 0.
    theta : float
        θ of the θ-method (Eq. 4), in [0.5, 1].
    tol : float
        NLGS tolerance on the "Quad" norm [-], > 0 (LMGC90's usual value: 1e-4).
    max_iter : int
        Maximum NLGS sweeps per step, in [1, 10⁹] (:data:`MAX_ITER_LIMIT`: the kernels'
        64-bit counters honour it; 2⁶³ was accepted, and a run reported every step
        converged with the spheres through the floor: issue 33).
    relax : float
        Relaxation ω of the NLGS update, in (0, 2).  ω < 1 under-relaxes:
        p ← p_old + ω (p_new − p_old).  ω > 1 over-relaxes (projected SOR): each contact's
        local problem is solved for its free velocity plus (ω − 1) times its current local
        velocity, so the local solver keeps the impulse on its cone (p_n >= 0,
        ‖p_T‖ <= μ p_n; unilateral links λ >= 0).  Over-relaxation is for the unmixed sweep
        on one thread: refused with ``anderson > 0`` or ``threads > 1``.  The stopping test
        divides the sweep's change by ω, so it measures the Gauss–Seidel update whatever ω.
        On the peers deposit with ``hot_sweeps=2``, ω = 1.4 took a quarter fewer sweeps per
        step and came to rest 1.2x sooner (docs/speed.md); ω = 1.6 and 1.7 did not
        converge on some of its steps.
    alert : float
        Alert distance [m], >= 0: a pair is a contact when its gap at the θ-predicted
        configuration is below it (or is predicted to close within the step).
    skin : float
        Verlet skin [m], > 0: the candidate-pair list holds pairs closer than alert + skin
        and is rebuilt when a body has moved more than skin/2 since the last build.
    gravity : tuple of 3 floats
        Gravity [m/s²] applied to free spheres.
    anderson : int
        Depth m of the Anderson acceleration of the NLGS sweeps, in [0, 16] (0: plain
        Gauss–Seidel).  The convergence test is the same (:mod:`engine.solver.anderson`).
        With ``threads > 1`` the parallel sweeps are mixed the same way, the mixing passes
        on the same threads.
    hot_sweeps : int
        After each full sweep, re-sweep this many times the contacts whose impulse changed
        most in it (local-velocity change above ``HOT_FACTOR`` = 2 times the mean), in
        [0, 8] (0, the default: plain sweeps).  The stopping test stays on full sweeps
        (:func:`engine.solver.nlgs.iterate_hot`; with ``threads > 1`` the re-sweeps run in
        the parallel sweep's race-free group order, :func:`engine.solver.parallel.iterate_groups`).
        Unmixed only: refused with ``anderson > 0``.
    threads : int
        NLGS threads, in [1, 64].  1 (the default): the serial Gauss–Seidel sweep.  T > 1:
        the domain-decomposed Gauss–Seidel of :mod:`engine.solver.parallel` (T domains swept
        at once; the same physics within ``tol``, results reproducible for a given T); it
        pays on large dense scenes only (docs/speed.md).
    chain_solve : bool
        Solve each wire as one chain in every NLGS sweep (:mod:`engine.solver.chains`:
        the links' impulses exactly, given the contacts', a tridiagonal system per wire
        with the wires' λ >= 0 as a complementarity) instead of one Gauss–Seidel pass over
        its links: tension crosses the whole chain in one sweep.  The same converged
        answer and residual.  Goes with every variant of the sweep: serial or on
        ``threads`` (the chains then solved on one thread after the contacts' phases),
        plain, with the hot re-sweeps, or mixed (``anderson``).  Default False.
    max_overlap : float
        Largest overlap of a contact at the end of a step's detection, as a fraction of the
        smaller radius of its two bodies, past which :func:`engine.run` stops with a
        :class:`~engine.step.SimulationError` (default :data:`MAX_OVERLAP` = 0.5: the
        smaller body half inside the other; above :data:`engine.sanity.OVERLAP_WARN` = 5 %
        the run's summary warns).  The stop names the step, the two bodies and what to
        change; a run that must go on raises it (up to 1000).
    contact_compliance : float
        ε, the contacts' normal compliance as a fraction of their Delassus diagonal, in
        [0, 1] (0, the default: rigid contacts, the paper's Signorini law).  With ε > 0
        each contact (sphere–sphere and sphere–wall; not the wire's links, whose laws are
        their own) is the unilateral spring of Eq. (14) with g_ref = 0: stiffness
        k = 1/(ε h² W_nn), natural period 2π h √ε, a static overlap F/k = ε h² W_nn F
        under a force F, and the gap term g/h of either sign, so that an overlap is the
        spring's and does not grow step after step.  The tangential law is Coulomb's
        as without it (a tangential compliance would let every sticking contact creep).
        It vanishes as h²: the rigid law is the limit h → 0.  It gives the frictional
        problem's hyperstatic directions a stiffness, which the sweeps need on dense
        packings settling as a whole: on the mould deposit's stagnating step,
        ε = 0.01 converges to round-off where the rigid law's sweeps wander
        (docs/speed.md).  Over-relaxation (``relax`` > 1) is refused with it.
    overlap_tol : float or None
        The position correction (:mod:`engine.solver.projection`): after each step, the
        contacts overlapping by more than this fraction of their smaller radius are pushed
        out to zero overlap by a projection on positions that leaves the velocities as
        the step solved them (no kinetic energy added).  In (0, 1], or None (the default,
        :data:`OVERLAP_TOL`): no correction.
    overlap_sweeps : int
        Most Gauss–Seidel sweeps of that projection per step, in [1, 10⁴] (default 50);
        what a step leaves is corrected at the next one.
    natural_residual : bool
        Also compute each step's natural-map residual, Siconos's stopping measure
        (:mod:`engine.solver.residual`), into ``StepStats.natural_residual`` and the
        histories (one more pass over the contacts per step).  It does not change the
        stopping test (the Quad norm).  Default False (None reported, NaN in histories).
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    dt: float = Field(gt=0.0, allow_inf_nan=False)
    theta: float = Field(0.5, ge=0.5, le=1.0)
    tol: float = Field(1e-4, gt=0.0, allow_inf_nan=False)
    max_iter: int = Field(1000, ge=1, le=MAX_ITER_LIMIT)
    relax: float = Field(1.0, gt=0.0, lt=2.0)
    alert: float = Field(ge=0.0, allow_inf_nan=False)
    skin: float = Field(gt=0.0, allow_inf_nan=False)
    gravity: tuple[float, float, float] = (0.0, 0.0, -9.81)
    threads: int = Field(1, ge=1, le=64)
    anderson: int = Field(0, ge=0, le=16)
    hot_sweeps: int = Field(0, ge=0, le=8)
    chain_solve: bool = False
    max_overlap: float = Field(MAX_OVERLAP, gt=0.0, le=1e3, allow_inf_nan=False)
    natural_residual: bool = False
    contact_compliance: float = Field(0.0, ge=0.0, le=1.0, allow_inf_nan=False)
    overlap_tol: Optional[float] = Field(OVERLAP_TOL, gt=0.0, le=1.0, allow_inf_nan=False)
    overlap_sweeps: int = Field(50, ge=1, le=10_000)

    _hot_alone = model_validator(mode="after")(lambda self: no_solver_conflict(self))


def no_solver_conflict(m):
    """``m`` (a record with ``hot_sweeps``, ``anderson``, ``relax`` and ``threads``) when
    its NLGS options go together, else ValueError (:func:`solver_conflict`): the validator
    of :class:`Options` and of the tests' parameter models."""
    problem = solver_conflict(m.hot_sweeps, m.anderson, m.relax, m.threads,
                              bool(getattr(m, "chain_solve", False)),
                              float(getattr(m, "contact_compliance", 0.0)))
    if problem:
        raise ValueError(problem)
    return m


def solver_conflict(hot_sweeps, anderson, relax, threads, chain_solve=False,
                    contact_compliance=0.0) -> str | None:
    """Why these NLGS options do not go together (None: they do): the hot re-sweeps and
    over-relaxation work on the unmixed sweep, over-relaxation on one thread only; the
    chain solve goes with all of them (``chain_solve`` is kept for the callers).  Shared by
    :class:`Options` and the ``nscd run`` files, which check before anything runs."""
    if hot_sweeps and anderson > 0:
        return (f"hot_sweeps = {hot_sweeps} works with the unmixed sweep only: set anderson=0 "
                f"(got {anderson}), or hot_sweeps=0")
    if relax > 1.0 and (anderson > 0 or threads > 1):
        return (f"relax = {relax:g} > 1 (over-relaxation) works with the unmixed sweep on one "
                f"thread only: set anderson=0 (got {anderson}) and threads=1 (got {threads}), "
                f"or relax <= 1")
    if relax > 1.0 and contact_compliance > 0.0:
        return (f"relax = {relax:g} > 1 (over-relaxation) works with rigid contacts only: set "
                f"contact_compliance=0 (got {contact_compliance:g}), or relax <= 1")
    return None


@dataclass(frozen=True)
class Drive:
    """An imposed velocity, force or pressure on one body (see :meth:`Scene.drive`).

    ``kind`` is ``"velocity"``, ``"force"`` or ``"pressure"``; ``value`` is a (3,) array
    [m/s] or [N], a float [Pa], a schedule (pressure only, :mod:`engine.schedules`: data,
    its current value in ``state.drive_pressure``), or a callable of time ``t`` [s]
    returning that; ``area`` [m²] (pressure only) is a float, a schedule
    (``state.drive_area``) or a callable ``(model, state) -> float``.
    """

    body: int
    kind: str
    value: object
    area: object = None

    def at(self, t: float):
        """The drive value at time ``t`` [s] (a schedule as it is: its current value is in
        the State, :func:`engine.schedules.drive_values`)."""
        return self.value(t) if callable(self.value) else self.value


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.ascontiguousarray(a)
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class Model:
    """Static description of a scene.

    Attributes (nb bodies, ng groups, nlaw laws)
    ---------------------------------------------
    body_kind : (nb,) int8
        SPHERE, PLANE or CYLINDER.
    body_group : (nb,) int16
        Index into ``group_names``.
    body_radius : (nb,) float64 [m]
        Sphere or cylinder radius; 0 for planes.
    body_mass, body_inertia : (nb,) float64 [kg], [kg·m²]
        Sphere mass and moment of inertia (2/5 m r²); a driven wall's own mass; ``inf``
        for bodies that never move under forces.
    body_axis : (nb, 3) float64 [-]
        Unit normal of a plane (pointing to the side where spheres live) or axis of a
        cylinder; zero for spheres.
    body_height : (nb,) float64 [m]
        Cylinder height along its axis; 0 otherwise.
    body_caps : (nb,) int8
        Cylinder end caps present (bits CAP_BOTTOM, CAP_TOP).
    body_dof : (nb,) int8
        FREE, IMPOSED or LINE.
    body_line : (nb, 3) float64 [-]
        Direction of motion of a LINE body; zero otherwise.
    body_dyn : (nb, 8) float64
        Packed row read by the NLGS kernel: inverse mass [1/kg], inverse inertia
        [1/(kg·m²)] (0 for IMPOSED bodies and walls), radius [m], LINE flag, line direction.
    sphere_ids, wall_ids : int32 arrays
        Body ids of spheres and of walls (planes and cylinders).
    group_names : tuple of str
    pair_law : (ng, ng) int16
        The see table: law index for each pair of groups, -1 = no interaction.
    law_code : (nlaw,) int16 ; law_param : (nlaw, 4) float64
        Law codes (:mod:`engine.laws`) and their parameter rows.
    laws : tuple of Law
        The law objects, index-aligned with ``law_code``.
    drives : tuple of Drive
    link_i, link_j : (nl,) int32
        Wire links (Eq. 7-15) from bead i to bead j = the next bead of its wire.
    link_law : (nl,) int16
        Law code of each link (:mod:`engine.laws`).
    link_ref_length : (nl,) float64 [m]
        g_ref = g(0)/(1+ε₀) (Eq. 7), g(0) the initial centre distance.
    link_stiffness : (nl,) float64 [N]
        k (force per unit strain); ``inf`` for the rigid laws.
    link_max_tension : (nl,) float64 [N]
        Tension that breaks the link for good; ``inf`` if unbreakable.
    link_unilateral : (nl,) int8
        1 for wires (tension only), 0 for rods (any sign).
    link_order : (nl,) int32
        Order in which the NLGS visits the links: along each wire, even positions first,
        then odd ones.
    body_next : (nb,) int32
        The bead linked after each bead that gets no contact with it (-1 if none: not
        linked, or linked with ``add_wire(neighbour_contact=True)``).
    options : Options
    """

    body_kind: np.ndarray
    body_group: np.ndarray
    body_radius: np.ndarray
    body_mass: np.ndarray
    body_inertia: np.ndarray
    body_axis: np.ndarray
    body_height: np.ndarray
    body_caps: np.ndarray
    body_dof: np.ndarray
    body_line: np.ndarray
    body_dyn: np.ndarray
    sphere_ids: np.ndarray
    wall_ids: np.ndarray
    group_names: tuple
    pair_law: np.ndarray
    law_code: np.ndarray
    law_param: np.ndarray
    laws: tuple
    drives: tuple
    link_i: np.ndarray
    link_j: np.ndarray
    link_law: np.ndarray
    link_ref_length: np.ndarray
    link_stiffness: np.ndarray
    link_max_tension: np.ndarray
    link_unilateral: np.ndarray
    link_order: np.ndarray
    body_next: np.ndarray
    options: Options

    def __post_init__(self):
        for name, value in self.__dict__.items():
            if isinstance(value, np.ndarray):
                object.__setattr__(self, name, _frozen(value))

    @property
    def n_bodies(self) -> int:
        return int(self.body_kind.shape[0])

    @property
    def n_spheres(self) -> int:
        return int(self.sphere_ids.shape[0])

    @property
    def n_walls(self) -> int:
        return int(self.wall_ids.shape[0])

    @property
    def n_links(self) -> int:
        return int(self.link_i.shape[0])

    def group_id(self, name: str) -> int:
        """Index of group ``name``; ``ValueError`` if unknown."""
        try:
            return self.group_names.index(name)
        except ValueError:
            raise ValueError(f"unknown group {name!r}; groups are {list(self.group_names)}") from None

    def bodies_in(self, group: str) -> np.ndarray:
        """Body ids of a group."""
        return np.flatnonzero(self.body_group == self.group_id(group)).astype(np.int32)

    def with_drive(self, body: int, *, velocity) -> "Model":
        """A copy in which wall ``body`` is velocity-driven from now on: ``velocity`` (3,)
        [m/s] or a callable of time.  Replaces a pressure or force drive (or a fixity);
        the State stays valid.  Used to switch a test from a stress-controlled stage to a
        strain-controlled one (e.g. a triaxial test's top wall)."""
        from dataclasses import replace

        b = int(body)
        if not 0 <= b < self.n_bodies or self.body_kind[b] == SPHERE:
            raise ValueError(f"body must be a wall id, got {body!r}")
        if not callable(velocity):
            v = np.asarray(velocity, dtype=float)
            if v.shape != (3,) or not np.all(np.isfinite(v)):
                raise ValueError(f"velocity must be 3 finite numbers [m/s], got {velocity!r}")
            velocity = v
        dof = self.body_dof.copy()
        dof[b] = IMPOSED
        line = self.body_line.copy()
        line[b] = 0.0
        dyn = pack_body_dyn(self.body_kind, self.body_mass, self.body_inertia,
                            self.body_radius, dof, line)
        drives = tuple(d for d in self.drives if d.body != b) + (Drive(body=b, kind="velocity",
                                                                        value=velocity),)
        drives = tuple(sorted(drives, key=lambda d: d.body))
        return replace(self, body_dof=_frozen(dof), body_line=_frozen(line),
                       body_dyn=_frozen(dyn), drives=drives)

    def with_friction(self, mu: float, pairs=None) -> "Model":
        """A copy in which the contacts between the groups of ``pairs`` (a list of
        ``(group_a, group_b)``; every pair with a contact law by default) follow Coulomb's law
        with friction coefficient ``mu`` [-] from the next step on.  The other pairs keep
        their laws (a law shared with them is not changed: the listed pairs get a law row of
        their own).  The State stays valid: the friction of a contact is read from the see
        table at every step, and a warm-start impulse outside the new cone is replaced by the
        local solution, inside it, at the contact's first Gauss–Seidel update (with the
        default ``relax`` = 1; a smaller relaxation gets there over the sweeps).  Used
        for a stage with other friction, e.g. a low-friction compaction before a triaxial
        test (``compaction_mu`` of :mod:`engine.experiments.triaxial`).
        """
        from dataclasses import replace

        from . import laws as _laws

        try:
            m = float(mu)
        except (TypeError, ValueError):
            m = float("nan")
        if not (np.isfinite(m) and m >= 0.0):
            raise ValueError(f"mu must be a finite friction coefficient >= 0, got {mu!r}")
        pair_law = self.pair_law.copy()
        if pairs is None:
            ng = len(self.group_names)
            idx = [(a, b) for a in range(ng) for b in range(a, ng) if pair_law[a, b] >= 0]
        else:
            idx = []
            for p in pairs:
                if not (isinstance(p, (tuple, list)) and len(p) == 2):
                    raise ValueError(f"pairs must be (group_a, group_b) tuples, got {p!r}")
                a, b = self.group_id(p[0]), self.group_id(p[1])
                if pair_law[a, b] < 0:
                    raise ValueError(f"groups {p[0]!r} and {p[1]!r} do not interact: no "
                                     "contact law to change")
                idx.append((a, b))
        law = _laws.Coulomb(mu=m)
        laws = list(self.laws)
        if law in laws:
            row = laws.index(law)
        else:
            laws.append(law)
            row = len(laws) - 1
        for a, b in idx:
            pair_law[a, b] = pair_law[b, a] = row
        code = np.asarray([l.code for l in laws], np.int16)
        param = np.asarray([l.params() for l in laws], float).reshape(len(laws), -1)
        return replace(self, pair_law=_frozen(pair_law), law_code=_frozen(code),
                       law_param=_frozen(param), laws=tuple(laws))

    def with_group_removed(self, group: str) -> "Model":
        """A copy in which the bodies of ``group`` are out of the mechanics from the next
        step on: every pair of groups with ``group`` loses its contact law, their links
        become :class:`engine.laws.LooseWire` (no force) and the bodies are IMPOSED (fixed
        where they are).  They stay in the model, so a history keeps one body count.  The
        State needs their velocities and their links' impulses set to zero and its
        candidate pairs rebuilt (:func:`engine.experiments.start.remove_group` does both)."""
        from dataclasses import replace

        from . import laws as _laws

        g = self.group_id(group)
        ids = np.flatnonzero(self.body_group == g)
        pair_law = self.pair_law.copy()
        pair_law[g, :] = -1
        pair_law[:, g] = -1
        dof = self.body_dof.copy()
        dof[ids] = IMPOSED
        dyn = pack_body_dyn(self.body_kind, self.body_mass, self.body_inertia,
                            self.body_radius, dof, self.body_line)
        gone = self.links_of(ids)
        law, stiff, uni = (self.link_law.copy(), self.link_stiffness.copy(),
                           self.link_unilateral.copy())
        law[gone], stiff[gone], uni[gone] = _laws.LOOSE_WIRE, 0.0, 1
        return replace(self, pair_law=_frozen(pair_law), body_dof=_frozen(dof),
                       body_dyn=_frozen(dyn), link_law=_frozen(law),
                       link_stiffness=_frozen(stiff), link_unilateral=_frozen(uni))

    def links_of(self, ids) -> np.ndarray:
        """(n_links,) bool: the links with an end among the bodies ``ids``."""
        return np.isin(self.link_i, ids) | np.isin(self.link_j, ids)

    def with_options(self, **changes) -> "Model":
        """A copy with some options changed (validated), e.g. ``model.with_options(dt=1e-5)``."""
        from dataclasses import replace

        opts = Options(**{**self.options.model_dump(), **changes})
        return replace(self, options=opts)

