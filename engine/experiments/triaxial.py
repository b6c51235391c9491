"""Triaxial tests of the paper: the box (§3.2, Fig. 11-12) and the cylinder (§3.3,
Fig. 13-16, Table 2).

Both run two stages on a geometric sample (:mod:`engine.prep.samples`), under gravity:

1. **isotropic**: the pressure p, raised linearly over ``ramp_steps``, is applied to the
   sides (pressure-driven side walls for the box; loads on the free-surface particles for
   the cylinder, :class:`engine.drivers.Confinement`) and to the top wall (pressure-driven),
   until the Weber mean stress (Eq. 18) and the top wall's stress are within ``iso_tol`` of p
   for ``iso_hold`` consecutive checks;
2. **triaxial**: the top wall moves down at a constant velocity v = ε̇ H₀, the lateral
   pressure held.  ε̇ comes from an inertial number I = ε̇ d √(ρ/p) (default I = 5e-4, a
   quasi-static test; the value used is in ``result.params``).

The default NLGS tolerance is 3e-4, not the engine's 1e-4: on these confined samples the
residual stagnates between 1e-4 and 2.5e-4 (measured on the cylinder at scale 0.05: 1 041 of
1 500 isotropic steps hit 1 000 sweeps at tol = 1e-4, relaxation 0.7 did not help; 186 of 800
at 3e-4, nearly all during the pressure ramp).  ``hot_sweeps`` (default None: 2, or 0 when
``anderson`` > 0; :data:`engine.experiments.common.HOT_SWEEPS`) re-sweeps the contacts that
changed most after each sweep (:attr:`engine.model.Options.hot_sweeps`, docs/speed.md).
``anderson`` (default 0) is the depth of the other NLGS acceleration
(:mod:`engine.solver.anderson`), the default before 2026-11-25.  ``threads`` (default 1) is
the NLGS thread count (:attr:`engine.model.Options.threads`); 2 pays only on samples of tens
of thousands of contacts (docs/speed.md).

Between the stages the top wall's drive is switched (:meth:`engine.model.Model.with_drive`).
A velocity-driven (kinematic) top wall in stage 1 was tried first: on a jammed packing of
rigid grains it made the NLGS fail to converge in 529 of 600 steps and overshot the target
stress by 100 %; a pressure-driven wall has no such infeasibility.
"""
from __future__ import annotations

import math
import os
import warnings

import numpy as np

from .. import laws
from ..analysis import (best_fit_strain, equivalent_stress, macro_stiffness, principal,
                        toroidal_map, wall_forces, weber_stress)
from ..drivers import Confinement
from ..prep import Box, Cylinder, box_sample, cylinder_sample
from ..scene import Scene
from .params import check_args
from .start import check_preparation, start_of
from .common import (ConfinementError, Recorder, Stages, TestResult, check_scale,
                     choose_rate, finish, history_writer, run_meta, solver_choice,
                     wire_law_or_default)

__all__ = ["cylinder_triaxial", "box_triaxial"]

G = 9.81


class _Pressure:
    """The stage-1 pressure [Pa], a callable of time for the drives; ``value`` is set by the
    test as it ramps."""

    def __init__(self):
        self.value = 0.0

    def __call__(self, t):
        return self.value


def _laws_for(scene, mu, mu_wall, mu_wire, wire):
    scene.interact("sand", "sand", laws.Coulomb(mu=mu))
    scene.interact("sand", "wall", laws.Coulomb(mu=mu_wall))
    if wire:
        scene.interact("wire", "sand", laws.Coulomb(mu=mu_wire))
        scene.interact("wire", "wire", laws.Coulomb(mu=mu_wire))
        scene.interact("wire", "wall", laws.Coulomb(mu=mu_wire))


def _compaction_mu(value, least=0.0, why=""):
    """Check ``compaction_mu`` (None, or a friction coefficient >= ``least``; ``why``: the
    reason for ``least``, for the message)."""
    if value is None:
        return None
    try:
        m = float(value)
    except (TypeError, ValueError):
        m = float("nan")
    if not (math.isfinite(m) and m >= least):
        raise ValueError(f"compaction_mu must be None or a friction coefficient >= {least:g}"
                         f"{why}, got {value!r}")
    return m


def _compaction(model, compaction_mu):
    """The model of the isotropic stage: ``model`` itself, or, with ``compaction_mu`` set,
    a copy in which every contact (sand, wire and walls) has that friction coefficient
    (:meth:`engine.model.Model.with_friction`).  The triaxial stage always runs with the test's
    own ``mu``, ``mu_wall`` and ``mu_wire``.

    A low-friction compaction is the usual DEM way to reach a denser packing whatever the
    grains' friction (docs/paper.md, Fig. 14, has what it did to the cylinder samples).
    """
    return model if compaction_mu is None else model.with_friction(compaction_mu)


#: The cylinder test stops (:class:`ConfinementError`) when the confinement radius exceeds
#: this factor times its value at the start (:class:`engine.drivers.Confinement`'s
#: ``max_growth``).  A sample that stays together bulges by a few
#: per cent (Fig. 13a: 3.28 mm at mid-height against 3.03 at the ends at 10 % strain).  On
#: samples of scale 0.04 (about 250 grains) grains sometimes left the membrane (seed 1:
#: rigid wire and k = 1 N without compaction, and most runs with compaction_mu = 0.1).  The
#: escaped grain then counted as a surface grain, the force-weighted radius grew 150-200
#: times, the membrane's total force with it, and the run went on to a meaningless end.
RADIUS_RUNAWAY = 1.5


#: Smallest ``compaction_mu`` of the cylinder test: at 0 the free-surface confinement let
#: the frictionless grains out (scale 0.3, seed 0: the membrane radius blew up and the mean
#: stress stayed at 5 kPa of the 15 kPa target); 0.1 and 0.2 held at scale 0.3, not always
#: at 0.04 (docs/paper.md).
CYLINDER_COMPACTION_MU_MIN = 0.1


def cylinder_triaxial(scale: float = 0.05, *, sample=None, preparation: str = "geometric",
                      pressure: float = 15e3, wire: bool = True,
                      wire_law=None, neighbour_contact: bool = False,
                      wire_density: float | None = None, wire_mode: str = "isotropic",
                      bead_radius: float | None = None,
                      wire_prestrain: float = 0.0, confinement: str = "free_surface",
                      deposit_steps: int = 6000, axial_strain: float = 0.1, strain_rate: float | None = None,
                      target_I: float = 5e-4, allow_dynamic: bool = False, dt: float = 5e-5,
                      theta: float = 0.5, tol: float = 3e-4, max_iter: int = 1000,
                      relax: float = 1.0, anderson: int = 0, threads: int = 1, hot_sweeps: int | None = None, mu: float = 0.5,
                      mu_wall: float = 0.5,
                      mu_wire: float = 0.3, compaction_mu: float | None = None,
                      iso_tol: float = 0.02, iso_hold: int = 5, iso_max_steps: int = 4000,
                      confine_every: int = 10, record_every: int = 10, frames: int = 100,
                      torus_strains=(0.02, 0.05, 0.1), max_nonconverged: float = 0.25,
                      ramp_steps: int = 400, history: str = "out/cylinder_triaxial.h5", seed: int = 0,
                      progress: bool = True) -> TestResult:
    """The cylinder triaxial test of §3.3 (Fig. 13-16, Table 2).

    The sample is :func:`engine.prep.cylinder_sample` (Ø9 mm × 20 mm, 6 200 grains + a wire
    at 250 km·m⁻³ at ``scale`` = 1) between a fixed floor and a top wall, confined by
    ``pressure`` [Pa] on its free-surface particles, then loaded to ``axial_strain`` at a
    constant velocity.  The paper's confining pressure for this test is not given: 15 kPa,
    its box test's, is the default.  ``wire_law``: the paper's ElasticWire(k = 1 N) by
    default; RigidWire() or ElasticWire(k) with k from 0.1 to 100 N for Table 2.
    ``compaction_mu``: the friction coefficient of every contact during the isotropic stage
    (None: the test's own; at least :data:`CYLINDER_COMPACTION_MU_MIN`), see
    :func:`_compaction`.
    ``neighbour_contact``: linked wire beads also touch like two spheres
    (:meth:`engine.Scene.add_wire`; default False: a slack link lets its two beads overlap).

    What the test starts from (:mod:`engine.experiments.start`, docs/experiments.md):

    * ``sample``: None (the test builds :func:`~engine.prep.cylinder_sample` at ``scale``
      with ``seed``, ``wire_density`` [m/m³] (None: the paper's), ``wire_mode``
      ("isotropic", Eq. 16, or "orthotropic", Eq. 17) and ``bead_radius`` r_w [m] (None:
      the paper's 0.135 mm)); a geometric
      :class:`engine.prep.Sample` in a cylinder; or an end state: a ``(model, state)``
      pair, a result with a history (``gravity_deposit``'s) or a history or checkpoint
      path, whose "sand" and "wire" particles are taken with their velocities and the
      links' own laws and reference lengths (its walls are left behind).
    * ``preparation``: "geometric" (the sample as it is) or "paper" (§2.4: the geometric
      sample relaxed under gravity in its mould first, :func:`gravity_deposit` with the
      test's solver options, ``mu_wall`` for the mould and at most ``deposit_steps``
      steps, its history ``<history>.deposit.h5``; then the mould removed).
    * ``wire_prestrain`` ε₀: at the start of the loading every link's reference length
      becomes g/(1+ε₀), g its length then, so the preparation cannot relax it.
    * ``confinement``: "free_surface" (§3.3, :class:`engine.drivers.Confinement`) or
      "layer_crown" (LMGC90's 3D membrane example, :class:`engine.drivers.LayerCrown`).

    Returns a :class:`TestResult` (triaxial stage; the isotropic stage in
    ``extra["isotropic"]``); ``extra`` also holds the toroidal wire-stress maps at
    ``torus_strains`` (Fig. 13c), the macro-stiffness H of (ε_zz, σ_w^eq) (Table 2), the
    sample radius and height, the best-fit strains (Eq. 19) of the sand, the wire and all
    the particles over the loading (``best_fit_strain``, Fig. 12's measure) and
    ``extra["start"]``: what the test started from (the deposit's history, steps and
    settlement for the paper preparation) and, at the start of the loading, the sand's
    solid fraction in the confinement's volume and the wire's share of taut links and
    mean and largest tension [N].

    Raises ValueError for bad input (naming it), ConvergenceError when more than
    ``max_nonconverged`` of the steps hit ``max_iter``.
    """
    args = dict(locals())
    check_args("cylinder_triaxial", args)
    scale = check_scale(scale)
    anderson, hot_sweeps = solver_choice(anderson, hot_sweeps)
    p = float(pressure)
    eps_max = float(axial_strain)
    compaction_mu = _compaction_mu(compaction_mu, CYLINDER_COMPACTION_MU_MIN,
                                   " (at 0 the free-surface confinement let the "
                                   "frictionless grains out)")
    st, deposit, law = _prepared("cylinder_triaxial", Cylinder, cylinder_sample, dict(
        args, scale=scale, anderson=anderson, hot_sweeps=hot_sweeps))
    wire = st.has_wire
    axis = st.axis()
    across = 2 * st.outer_radius(axis) / (2 * float(st.sand_radii.mean()))
    if across < 5.5:
        raise ValueError(
            f"scale {scale} gives a sample {across:.1f} mean grain diameters across; the "
            f"free-surface confinement needs at least 5.5 (scale >= 0.04): on thinner samples "
            f"it threw grains out at tens of m/s (measured at scale 0.03)")
    sc = Scene(gravity=(0.0, 0.0, -G))
    sand, beads = st.add_to(sc, wire_law=law, neighbour_contact=neighbour_contact)
    floor = sc.add_plane(point=(axis[0], axis[1], st.floor), normal=(0, 0, 1), group="wall")
    top_z = st.floor + st.height
    d_mean = 2 * float(st.sand_radii.mean())
    rate, I = choose_rate(strain_rate, p, d_mean, 2650.0, target_I=target_I,
                          allow_dynamic=allow_dynamic)
    p_now = _Pressure()
    # the membrane loads go on sand grains only: a cell's share on a light wire bead
    # accelerates it by ~1e6 m/s² and blew the run up
    conf = _membrane(confinement, np.asarray(sand), axis)
    m_sample = st.sand_mass
    top = sc.add_plane(point=(axis[0], axis[1], top_z), normal=(0, 0, -1), group="wall")
    sc.drive(top, pressure=p_now, mass=0.2 * m_sample,
             area=lambda model, state: math.pi * conf.radius ** 2)
    sc.fix(floor)
    _laws_for(sc, mu, mu_wall, mu_wire, wire)
    model, state = sc.compile(dt=dt, theta=theta, tol=tol, max_iter=max_iter, relax=relax,
                              anderson=anderson, threads=threads, hot_sweeps=hot_sweeps)
    model = st.carry_over(model, state)
    conf.apply(model, state)

    def confine():
        """Update the membrane loads; stop if the sample has come apart."""
        try:
            conf.apply(model, state)
        except ConfinementError as e:
            raise ConfinementError(
                f"cylinder_triaxial: the sample came apart: {e}. Seen on samples of scale "
                f"0.04 (here scale {scale:g}, seed {seed}); use a larger scale. The history "
                f"{history} keeps the steps run so far.") from e

    model_iso = _compaction(model, compaction_mu)
    stage = {"value": 0}
    stage_of = []

    def stresses(model, state):
        V = math.pi * conf.radius ** 2 * (state.position[top, 2] - state.position[floor, 2])
        mem = conf.membrane_stress(model) / V
        # Eq. (18) over the whole sample with volume V (the membrane is its lateral boundary)
        sand_s = _weber(model, state, "sand", V) - mem
        wire_s = _weber(model, state, "wire", V) if model.n_links else np.zeros((3, 3))
        return sand_s + wire_s, sand_s, wire_s, V

    def sample_values(model, state):
        tot, sand_s, wire_s, V = stresses(model, state)
        H = state.position[top, 2] - state.position[floor, 2]
        stage_of.append(stage["value"])
        return dict(stress=tot, sand_stress=sand_s, wire_stress=wire_s, height=H, volume=V,
                    radius=conf.radius, stage=stage["value"], time=state.time, step=state.step)

    rec = _SplitRecorder(sample_values, record_every)
    units = dict(stress="Pa", sand_stress="Pa", wire_stress="Pa", height="m", volume="m^3",
                 radius="m", stage="-", time="s", step="-")
    H0 = top_z
    est_steps = iso_max_steps + int(eps_max / (rate * dt)) + 1
    hist = history_writer(history, rec, units, record_every, frames, meta=run_meta(
        "cylinder_triaxial", est_steps, scale=scale, seed=seed, sample=st.source,
        preparation=preparation, confinement=confinement, pressure=p, wire=wire,
        wire_law=law, neighbour_contact=neighbour_contact, axial_strain=eps_max,
        strain_rate=rate, dt=dt, theta=theta, tol=tol, max_iter=max_iter, mu=mu,
        mu_wall=mu_wall, mu_wire=mu_wire))
    stages = Stages(model_iso, state, [rec, hist], progress=progress, total=est_steps,
                    desc="cylinder triaxial")
    maps = {}
    R0 = conf.radius
    preload = None
    strains = {}
    try:
        # stage 1: isotropic
        def set_pressure(v):
            p_now.value = conf.pressure = v

        def measure():
            # the spheres push the top wall up: compression positive
            sigma_top = wall_forces(model, state, [top])[0, 2] / (math.pi * conf.radius ** 2)
            confine()
            return (-np.trace(stresses(model, state)[0]) / 3, sigma_top)

        stages.set_stage("isotropic")
        iso_reached = _isotropic(stages, confine_every, iso_max_steps, ramp_steps, p,
                                 set_pressure, measure, iso_tol, iso_hold)
        # stage 2: triaxial
        stage["value"] = 1
        stages.set_stage("loading")
        H0 = state.position[top, 2] - state.position[floor, 2]
        R0 = conf.radius
        ref = state.position.copy()
        preload = _loading_start(model, state, st, math.pi * R0 ** 2 * H0)
        if wire and wire_prestrain:
            model = _prestrained(model, state, wire_prestrain)
        model = stages.model = model.with_drive(top, velocity=(0.0, 0.0, -rate * H0))
        n_load = int(math.ceil(eps_max / (rate * dt)))
        targets = sorted(float(e) for e in torus_strains if e <= eps_max + 1e-12)
        done = 0
        while done < n_load and not stages.interrupted:
            n = min(confine_every, n_load - done)
            if not stages.run(n):
                break
            done += n
            confine()
            H = state.position[top, 2] - state.position[floor, 2]
            eps = 1 - H / H0
            last = done >= n_load
            # the last chunk ends within one step of the final strain (the first step lags
            # by θ h ε̇): a target equal to it is taken there
            while targets and wire and (eps >= targets[0] or (last and targets[0] >= eps_max - 1e-12)):
                e = targets.pop(0)
                maps[e] = toroidal_map(model, state, Cylinder(conf.radius, H, (
                    axis[0], axis[1], state.position[floor, 2])), part="wire")
        stages.record_last()
        strains = _best_fit(ref, state, sand, np.concatenate(beads) if beads else
                            np.zeros(0, np.int64))
    finally:
        stages.close()
        hist.close()
    tri, iso = _split(rec, stage_of)
    res = _result("cylinder_triaxial", tri, H0, history)
    res.params = dict(scale=scale, sample=st.source, preparation=preparation,
                      confinement=confinement, wire_density=st.wire_density,
                      wire_mode=wire_mode if sample is None else None,
                      bead_radius=st.bead_radius if wire else None,
                      wire_prestrain=wire_prestrain if wire else 0.0,
                      deposit_steps=deposit_steps if deposit is not None else None,
                      pressure=p, wire=wire, wire_law=repr(law), neighbour_contact=bool(wire and neighbour_contact), axial_strain=eps_max,
                      strain_rate=rate, inertial_number=I, loading_velocity=rate * H0, dt=dt,
                      theta=theta, tol=tol, max_iter=max_iter, anderson=anderson, threads=threads,
                      hot_sweeps=hot_sweeps, mu=mu,
                      mu_wall=mu_wall,
                      mu_wire=mu_wire, compaction_mu=compaction_mu, seed=seed,
                      n_sand=int(st.sand_radii.size),
                      n_beads=st.n_beads, d_mean=d_mean, iso_reached=iso_reached)
    res.extra["start"] = _start_extra(st, deposit, preload)
    if len(res.time):
        res.extra["radial_strain"] = tri["radius"] / R0 - 1          # extension positive
    res.extra["isotropic"] = dict(time=iso.get("time"), mean_stress=_mean(iso.get("stress")),
                                  axial_stress=_axial(iso.get("stress")), reached=iso_reached)
    res.extra["torus_maps"] = maps
    res.extra["best_fit_strain"] = strains
    res.extra["height"], res.extra["radius"] = tri.get("height"), tri.get("radius")
    if wire and len(res.time) >= 5:
        try:
            res.extra["H"] = macro_stiffness(res.axial_strain, res.wire_equivalent)
        except ValueError as e:
            res.extra["H"] = None
            res.extra["H_error"] = str(e)
    return finish(res, stages, max_nonconverged)


#: The test's arguments the paper preparation's deposit takes as they are.
_DEPOSIT_ARGS = ("dt", "theta", "tol", "max_iter", "relax", "anderson", "threads",
                 "hot_sweeps", "mu", "mu_wall", "mu_wire", "max_nonconverged", "seed")


def _prepared(test, shape, builder, a):
    """(the :class:`~engine.experiments.start.Start` of a triaxial test, the deposit's
    result or None, the wire's law): the test's ``sample`` or its own, built by
    ``builder`` (:func:`~engine.prep.cylinder_sample` or :func:`~engine.prep.box_sample`),
    prepared as its ``preparation`` says (:mod:`engine.experiments.start`; the paper
    preparation's :func:`~engine.experiments.gravity_deposit` takes the test's solver
    options, friction and seed, and ``deposit_steps``).  ``a``: the test's arguments (its
    ``locals()`` on entry, with the scale and the solver choice resolved).  The wire law
    and the prestrain are checked before any sample is built."""
    sample, wire, wire_density, wire_mode = (a["sample"], a["wire"], a["wire_density"],
                                             a["wire_mode"])
    law = wire_law_or_default(a["wire_law"]) if wire else None
    _check_prestrain(test, a["wire_prestrain"], a["neighbour_contact"])
    preparation = check_preparation(a["preparation"])
    given = [n for n, v in (("wire_density", wire_density), ("bead_radius", a["bead_radius"]))
             if v is not None] + (["wire_mode"] if wire_mode != "isotropic" else [])
    if sample is not None and given:
        raise ValueError(f"{test}: {', '.join(given)} build(s) the test's own sample; with "
                         f"sample= given, build the sample with them "
                         f"(engine.prep.{shape.__name__.lower()}_sample)")
    def build():
        return builder(a["scale"], wire=wire, wire_density=wire_density, wire_mode=wire_mode,
                       bead_radius=a["bead_radius"], seed=a["seed"])

    st = start_of(test, shape, sample, build, wire=wire, wire_law=a["wire_law"])
    if preparation == "geometric":
        return st, None, st.wire_law(law) if st.has_wire else None
    if st.sample is None:
        raise ValueError(f"{test}: preparation = 'paper' relaxes a geometric sample in its "
                         f"mould first; the sample given is {st.source}, an end state "
                         f"already (use preparation='geometric')")
    from .deposit import gravity_deposit

    dep = gravity_deposit(sample=st.sample, wire=st.has_wire, wire_law=law,
                          neighbour_contact=a["neighbour_contact"],
                          history=deposit_history(a["history"]), progress=a["progress"],
                          steps=a["deposit_steps"], **{k: a[k] for k in _DEPOSIT_ARGS})
    st = start_of(test, shape, dep.history, None, wire=wire)
    return st, dep, st.wire_law(law) if st.has_wire else None


def deposit_history(history) -> str:
    """Where the paper preparation's deposit writes its history: ``history`` with the
    suffix ``.deposit.h5``."""
    root, ext = os.path.splitext(os.fspath(history))
    return root + ".deposit.h5"


def _check_prestrain(test, eps, neighbour_contact):
    if eps and neighbour_contact:
        raise ValueError(f"{test}: wire_prestrain = {eps:g} with neighbour_contact = True: a "
                         f"prestrained link pulls its beads into their contact; use one or "
                         f"the other")


def _prestrained(model, state, eps):
    """``model`` with every link's reference length g/(1+ε₀), g its length in ``state`` (the
    prestrain ``wire_prestrain`` of the triaxial tests, set at the start of the loading so
    that the preparation cannot relax it)."""
    from dataclasses import replace

    g = np.linalg.norm(state.position[model.link_i] - state.position[model.link_j], axis=1)
    return replace(model, link_ref_length=g / (1.0 + float(eps)))


def _loading_start(model, state, st, volume):
    """What the sample is at the start of the loading: its sand's solid fraction in
    ``volume`` [m³] and its wire's preload (share of taut links, mean and largest tension
    [N])."""
    out = dict(volume=float(volume), solid_fraction=float(
        (4 / 3 * np.pi * (st.sand_radii ** 3).sum()) / volume))
    if model.n_links:
        t = state.links.tension
        out.update(taut_share=float(np.mean(t > 0)), mean_tension=float(t.mean()),
                   max_tension=float(t.max()))
    return out


def _best_fit(ref, state, sand, beads) -> dict:
    """Best-fit strains (Eq. 19) of the sand, the wire and all the particles from ``ref``
    (the positions at the start of the loading) to ``state`` (Fig. 12's measure)."""
    sand = np.asarray(sand)
    out = {}
    for name, sel in (("sand", sand), ("wire", beads), ("all", np.concatenate([sand, beads]))):
        if sel.size >= 4:
            out[name] = best_fit_strain(ref, state.position, sel)
    return out


def _start_extra(st, deposit, loading_start) -> dict:
    """``result.extra["start"]``: what the test started from and what it was at the start of
    the loading."""
    out = dict(source=st.source, deposit=None)
    if deposit is not None:
        out["deposit"] = dict(history=deposit.history, at_rest=deposit.at_rest,
                              steps=deposit.convergence.get("steps"),
                              settlement=deposit.settlement,
                              slack_share=deposit.slack_share)
    out.update(loading_start or {})
    return out


#: The lateral confinements of the cylinder test (its ``confinement``): the free-surface
#: membrane of §3.3 (:class:`engine.drivers.Confinement`) and the layer crowns of LMGC90's
#: 3D membrane example (:class:`engine.drivers.LayerCrown`).
CONFINEMENTS = ("free_surface", "layer_crown")


def _membrane(kind, sand, axis):
    from ..drivers import LayerCrown

    if kind == "free_surface":
        return Confinement(0.0, sand, center=axis, max_growth=RADIUS_RUNAWAY)
    if kind == "layer_crown":
        return LayerCrown(0.0, sand, center=axis, max_growth=RADIUS_RUNAWAY)
    raise ValueError(f"confinement = {kind!r}: must be one of {', '.join(map(repr, CONFINEMENTS))}")


def _isotropic(stages, every, max_steps, ramp_steps, p, set_pressure, measure, iso_tol,
               iso_hold) -> bool:
    """Stage 1: raise the pressure linearly over ``ramp_steps`` (a sudden p on a loose
    sample throws its outer grains in at metres per second), then run until every stress
    ``measure()`` returns is within ``iso_tol`` of p for ``iso_hold`` consecutive checks
    ``every`` steps apart.  Returns whether it got there within ``max_steps``; if not, a
    RuntimeWarning says so with the stresses reached (the loading then starts from there,
    and the result's ``params["iso_reached"]`` is False)."""
    ok_count, n = 0, 0
    values = ()
    while n < max_steps:
        if not stages.run(every):
            break
        n += every
        p_now = p * min(1.0, n / max(ramp_steps, 1))
        set_pressure(p_now)
        values = measure()
        ok = p_now == p and all(abs(v / p - 1) < iso_tol for v in values)
        ok_count = ok_count + 1 if ok else 0
        if ok_count >= iso_hold:
            break
    reached = ok_count >= iso_hold
    if not reached and not stages.interrupted:
        got = ", ".join(f"{v:.4g}" for v in values)
        warnings.warn(f"the isotropic stage did not reach {p:.4g} Pa (within {iso_tol:.0%} "
                      f"for {iso_hold} checks) in {n} steps (iso_max_steps = {max_steps}): the "
                      f"stresses were {got} Pa; the loading starts from there. Raise "
                      f"iso_max_steps", RuntimeWarning, stacklevel=3)
    return reached


def _weber(model, state, part, V):
    """Weber sum (Eq. 18) of the whole sample with volume V (tension positive)."""
    s = weber_stress(model, state, part=part)
    return s.tensor * s.volume / V


def _mean(stress):
    if stress is None or len(stress) == 0:
        return np.zeros(0)
    return -np.trace(np.asarray(stress), axis1=1, axis2=2) / 3


def _axial(stress):
    if stress is None or len(stress) == 0:
        return np.zeros(0)
    return -np.asarray(stress)[:, 2, 2]


class _SplitRecorder(Recorder):
    """A recorder of one function returning a dict of values."""

    def __init__(self, fn, every):
        super().__init__({}, every)
        self.fn = fn
        self.rows = {}
        self.fns = {k: None for k in ("stress", "sand_stress", "wire_stress", "height",
                                      "volume", "radius", "stage", "time", "step")}

    def values(self, model, state) -> dict:
        return self.fn(model, state)


def _split(rec, stage_of):
    """Rows of the triaxial stage, starting with the last isotropic record (the state the
    loading starts from: axial strain 0, deviator about 0), and rows of the isotropic one."""
    st = np.asarray(stage_of)
    first = np.flatnonzero(st == 1)
    if first.size and first[0] > 0:
        st = st.copy()
        st[first[0] - 1] = 2                      # both stages
    tri = {k: np.asarray(v)[st >= 1] for k, v in rec.rows.items()}
    iso = {k: np.asarray(v)[(st == 0) | (st == 2)] for k, v in rec.rows.items()}
    return tri, iso


def _result(name, tri, H0, history):
    stress = tri.get("stress", np.zeros((0, 3, 3)))
    n = len(stress)
    if n == 0:
        z = np.zeros(0)
        return TestResult(name, z, z.astype(int), z, z, z, z, np.zeros((0, 3, 3)),
                          np.zeros((0, 3, 3)), np.zeros((0, 3, 3)), z, os.path.abspath(history))
    V = tri["volume"]
    sig_a = -stress[:, 2, 2]
    sig_r = -(stress[:, 0, 0] + stress[:, 1, 1]) / 2
    wire_s = tri["wire_stress"]
    return TestResult(
        name=name, time=tri["time"], step=tri["step"].astype(int),
        axial_strain=1 - tri["height"] / H0, volumetric_strain=1 - V / V[0],
        deviator=sig_a - sig_r, mean_stress=-np.trace(stress, axis1=1, axis2=2) / 3,
        stress=stress, sand_stress=tri["sand_stress"], wire_stress=wire_s,
        wire_equivalent=np.array([equivalent_stress(s) for s in wire_s]),
        history=os.path.abspath(history))


def box_triaxial(scale: float = 0.05, *, sample=None, preparation: str = "geometric",
                 pressure: float = 15e3, wire: bool = True,
                 wire_law=None, neighbour_contact: bool = False, bead_radius: float | None = None,
                 wire_density: float | None = None, wire_mode: str = "isotropic",
                 wire_prestrain: float = 0.0, deposit_steps: int = 6000,
                 axial_strain: float = 0.05,
                 strain_rate: float | None = None, target_I: float = 5e-4,
                 allow_dynamic: bool = False, dt: float = 5e-5, theta: float = 0.5,
                 tol: float = 3e-4, max_iter: int = 1000, relax: float = 1.0,
                 anderson: int = 0, threads: int = 1, hot_sweeps: int | None = None, mu: float = 0.5, mu_wall: float = 0.0,
                 mu_wire: float = 0.3, compaction_mu: float | None = None,
                 wall_mass: float | None = None, iso_tol: float = 0.02,
                 iso_hold: int = 5, iso_max_steps: int = 4000, check_every: int = 10,
                 ramp_steps: int = 400,
                 record_every: int = 10, frames: int = 100, max_nonconverged: float = 0.25,
                 history: str = "out/box_triaxial.h5", seed: int = 0,
                 progress: bool = True) -> TestResult:
    """The box triaxial test of §3.2 (Fig. 11-12).

    The sample is :func:`engine.prep.box_sample` (a 16 mm cube, 6 500 grains + a wire at
    200 km·m⁻³ at ``scale`` = 1; ``bead_radius`` r_w for Fig. 12) on a fixed floor, with
    four side walls under ``pressure`` (paper: about 15 kPa; pressure drives whose area
    follows the sample) and a top wall servo-controlled to the same stress, then moved down
    at a constant velocity.  The side walls are frictionless by default (``mu_wall``).
    ``compaction_mu``: the friction of the isotropic stage, see :func:`_compaction`.
    ``neighbour_contact``: linked wire beads also touch like two spheres
    (:meth:`engine.Scene.add_wire`; default False: a slack link lets its two beads overlap).
    ``sample``, ``preparation``, ``wire_density``, ``wire_mode``, ``wire_prestrain`` and
    ``deposit_steps`` as in :func:`cylinder_triaxial` (a box sample; the paper
    preparation's mould is the box's floor and four sides, with ``mu_wall``; the walls of
    an end state's box are where its side planes were, else at its particles' extent).

    ``extra`` holds the wall stresses (compression positive: x−, x+, y−, y+, top) per
    record, the wire Weber stress of the upper and lower halves with principal values and
    directions (Fig. 11), and the best-fit strains (Eq. 19) of the sand, the wire and all
    the particles (Fig. 12).
    """
    args = dict(locals())
    check_args("box_triaxial", args)
    scale = check_scale(scale)
    anderson, hot_sweeps = solver_choice(anderson, hot_sweeps)
    p = float(pressure)
    eps_max = float(axial_strain)
    compaction_mu = _compaction_mu(compaction_mu)
    st, deposit, law = _prepared("box_triaxial", Box, box_sample, dict(
        args, scale=scale, anderson=anderson, hot_sweeps=hot_sweeps))
    wire = st.has_wire
    box = st.box()
    lo, hi = np.array(box.lo), np.array(box.hi)
    sc = Scene(gravity=(0.0, 0.0, -G))
    sand, beads = st.add_to(sc, wire_law=law, neighbour_contact=neighbour_contact)
    bead_ids = np.concatenate(beads) if beads else np.zeros(0, np.int64)
    top_z = st.height
    d_mean = 2 * float(st.sand_radii.mean())
    rate, I = choose_rate(strain_rate, p, d_mean, 2650.0, target_I=target_I,
                          allow_dynamic=allow_dynamic)
    m_sample = st.sand_mass
    wall_mass = 0.2 * m_sample if wall_mass is None else float(wall_mass)   # (checked: BoxParams)
    floor = sc.add_plane(point=(0, 0, lo[2]), normal=(0, 0, 1), group="wall")
    p_now = _Pressure()
    top = sc.add_plane(point=(0, 0, lo[2] + top_z), normal=(0, 0, -1), group="wall")
    sides = [sc.add_plane(point=pt, normal=n, group="wall") for pt, n in (
        ((lo[0], 0, 0), (1, 0, 0)), ((hi[0], 0, 0), (-1, 0, 0)),
        ((0, lo[1], 0), (0, 1, 0)), ((0, hi[1], 0), (0, -1, 0)))]

    def side_area(k):
        def area(model, state):
            H = state.position[top, 2] - state.position[floor, 2]
            other = (sides[2], sides[3]) if k < 2 else (sides[0], sides[1])
            ax = 1 if k < 2 else 0
            w = state.position[other[1], ax] - state.position[other[0], ax]
            return H * w
        return area

    for k, b in enumerate(sides):
        sc.drive(b, pressure=p_now, mass=wall_mass, area=side_area(k))

    def top_area(model, state):
        return ((state.position[sides[1], 0] - state.position[sides[0], 0])
                * (state.position[sides[3], 1] - state.position[sides[2], 1]))

    sc.drive(top, pressure=p_now, mass=wall_mass, area=top_area)
    sc.fix(floor)
    _laws_for(sc, mu, mu_wall, mu_wire, wire)
    model, state = sc.compile(dt=dt, theta=theta, tol=tol, max_iter=max_iter, relax=relax,
                              anderson=anderson, threads=threads, hot_sweeps=hot_sweeps)
    model = st.carry_over(model, state)
    stage = {"value": 0}
    stage_of = []
    walls = np.array([*sides, top])

    def dims(state):
        x = state.position
        return (x[sides[1], 0] - x[sides[0], 0], x[sides[3], 1] - x[sides[2], 1],
                x[top, 2] - x[floor, 2])

    def wall_sigma(model, state):
        Lx, Ly, H = dims(state)
        f = wall_forces(model, state, walls)
        areas = np.array([Ly * H, Ly * H, Lx * H, Lx * H, Lx * Ly])
        normals = np.array([model.body_axis[b] for b in walls])
        # the spheres push each wall against its normal: compression positive
        return -np.einsum("ka,ka->k", f, normals) / areas

    def sample_values(model, state):
        Lx, Ly, H = dims(state)
        V = Lx * Ly * H
        sand_s = _weber(model, state, "sand", V)
        wire_s = _weber(model, state, "wire", V) if model.n_links else np.zeros((3, 3))
        zmid = state.position[floor, 2] + 0.5 * H
        x0, y0 = state.position[sides[0], 0], state.position[sides[2], 1]
        halves = []
        for zl, zh in ((zmid, zmid + 0.5 * H), (zmid - 0.5 * H, zmid)):
            reg = Box((x0, y0, zl), (x0 + Lx, y0 + Ly, zh))
            try:
                halves.append(weber_stress(model, state, region=reg, part="wire").tensor
                              if model.n_links else np.zeros((3, 3)))
            except ValueError:
                halves.append(np.full((3, 3), np.nan))
        stage_of.append(stage["value"])
        return dict(stress=sand_s + wire_s, sand_stress=sand_s, wire_stress=wire_s,
                    wire_stress_upper=halves[0], wire_stress_lower=halves[1],
                    wall_stress=wall_sigma(model, state), height=H, volume=V,
                    radius=0.0, stage=stage["value"], time=state.time, step=state.step,
                    position=None)

    rec = _SplitRecorder(lambda m, s: {k: v for k, v in sample_values(m, s).items()
                                       if k != "position"}, record_every)
    rec.fns = {k: None for k in ("stress", "sand_stress", "wire_stress", "wire_stress_upper",
                                 "wire_stress_lower", "wall_stress", "height", "volume",
                                 "radius", "stage", "time", "step")}
    units = dict(stress="Pa", sand_stress="Pa", wire_stress="Pa", wire_stress_upper="Pa",
                 wire_stress_lower="Pa", wall_stress="Pa", height="m", volume="m^3",
                 radius="m", stage="-", time="s", step="-")
    est_steps = iso_max_steps + int(eps_max / (rate * dt)) + 1
    hist = history_writer(history, rec, units, record_every, frames, meta=run_meta(
        "box_triaxial", est_steps, scale=scale, seed=seed, sample=st.source,
        preparation=preparation, pressure=p, wire=wire,
        wire_law=law, neighbour_contact=neighbour_contact, axial_strain=eps_max,
        strain_rate=rate, dt=dt, theta=theta, tol=tol, max_iter=max_iter, mu=mu,
        mu_wall=mu_wall, mu_wire=mu_wire))
    stages = Stages(_compaction(model, compaction_mu), state, [rec, hist], progress=progress,
                    total=est_steps, desc="box triaxial")
    strains = {}
    H0 = top_z
    preload = None
    try:
        def measure():
            Lx, Ly, H = dims(state)
            return (-np.trace(_weber(model, state, "all", Lx * Ly * H)) / 3,
                    *wall_sigma(model, state))

        stages.set_stage("isotropic")
        iso_reached = _isotropic(stages, check_every, iso_max_steps, ramp_steps, p,
                                 lambda v: setattr(p_now, "value", v), measure, iso_tol,
                                 iso_hold)
        stage["value"] = 1
        stages.set_stage("loading")
        H0 = dims(state)[2]
        ref = state.position.copy()
        preload = _loading_start(model, state, st, float(np.prod(dims(state))))
        if wire and wire_prestrain:
            model = _prestrained(model, state, wire_prestrain)
        model = stages.model = model.with_drive(top, velocity=(0.0, 0.0, -rate * H0))
        n_load = int(math.ceil(eps_max / (rate * dt)))
        if not stages.interrupted:
            stages.run(n_load)
        stages.record_last()
        strains = _best_fit(ref, state, sand, bead_ids)
    finally:
        stages.close()
        hist.close()
    tri, iso = _split(rec, stage_of)
    res = _result("box_triaxial", tri, H0, history)
    res.params = dict(scale=scale, sample=st.source, preparation=preparation,
                      wire_density=st.wire_density,
                      wire_mode=wire_mode if sample is None else None,
                      wire_prestrain=wire_prestrain if wire else 0.0,
                      deposit_steps=deposit_steps if deposit is not None else None,
                      pressure=p, wire=wire, wire_law=repr(law), neighbour_contact=bool(wire and neighbour_contact),
                      bead_radius=st.bead_radius if wire else None, axial_strain=eps_max, strain_rate=rate,
                      inertial_number=I, loading_velocity=rate * H0, dt=dt, theta=theta,
                      tol=tol, max_iter=max_iter, anderson=anderson, threads=threads,
                      hot_sweeps=hot_sweeps, mu=mu, mu_wall=mu_wall,
                      mu_wire=mu_wire, compaction_mu=compaction_mu,
                      wall_mass=wall_mass, seed=seed, n_sand=int(st.sand_radii.size),
                      n_beads=st.n_beads, d_mean=d_mean, iso_reached=iso_reached)
    res.extra["start"] = _start_extra(st, deposit, preload)
    res.extra["isotropic"] = dict(time=iso.get("time"), mean_stress=_mean(iso.get("stress")),
                                  axial_stress=_axial(iso.get("stress")),
                                  wall_stress=iso.get("wall_stress"), reached=iso_reached)
    res.extra["wall_stress"] = tri.get("wall_stress")
    for half in ("upper", "lower"):
        t = tri.get(f"wire_stress_{half}")
        res.extra[f"wire_stress_{half}"] = t
        if t is not None and len(t) and np.all(np.isfinite(t[-1])):
            w, v = principal(t[-1])
            res.extra[f"wire_principal_{half}"] = (w, v)
    res.extra["best_fit_strain"] = strains
    return finish(res, stages, max_nonconverged)
