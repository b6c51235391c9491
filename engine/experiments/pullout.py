"""The wire pull-out test (not one of the paper's tests): a straight wire, a chain of beads,
lies along x at mid-height through a box of sand under a vertical stress σ_v, and its end
outside the box is pulled along the wire at a constant velocity.  The pull force F against
the pulled end's displacement is the test's curve; its peak gives the apparent friction of
the wire in the sand

    μ* = F_peak / (σ_v π d_w L),

d_w = 2 r_w the wire's diameter and L its embedded length (DESIGN §4; the geotechnical
definition for a reinforcement of perimeter π d_w).

The sample is :func:`engine.prep.pullout_sample` (the cylinder's sand, Ø0.3–0.8 mm, laid by
the geometric deposit around the wire in a box 10 × 6 × 6 mm at ``scale`` 1).  The box has a
fixed floor, four fixed side planes and a top plate driven by the pressure σ_v (group
"wall"), except the +x side, through which the wire leaves: it is its own group ("front"),
with a law for the sand and none for the wire, so the beads pass through it.

Two stages, each one :meth:`~engine.experiments.common.Stages.run`:

1. **consolidation**: σ_v raised on the top plate over ``ramp_steps``
   (:class:`~engine.schedules.Ramp`, :class:`~engine.schedules.FollowSchedules`), the
   pulled end held (a zero velocity drive), until the top plate's stress is within
   ``consolidation_tol`` of σ_v and the sand's kinetic energy at most ``ke_fraction`` of its
   peak for ``consolidation_hold`` checks in a row, at most ``consolidation_max_steps``
   (a RuntimeWarning if not reached; the pull starts from there);
2. **pull**: the pulled end's drive switched to the velocity ``pull_velocity`` along +x for
   ``pull_distance``; σ_v held.

The pull force is the tension of the link between the pulled bead and its neighbour
(``state.links.tension``, > 0 in tension), recorded every ``record_every`` steps as its
mean over those steps (the tension of one step carries the NLGS's step-to-step noise).

A caveat measured on small runs (docs/pullout.md): at the default ``tol`` = 3e-4 the
grains sink into the light beads step after step (the overlap drift of docs/tradeoff.md),
by 30-50 % of r_w over a run; the peak of F depends on ``tol`` (μ* 0.145 at 3e-4 against
0.35-0.45 at 1e-4 and 3e-5, scale 0.1, seed 0), the residual force does not.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field, replace
from types import SimpleNamespace

import numpy as np

from .. import laws
from ..analysis import wall_forces
from ..analysis.energy import kinetic_energy
from ..model import MAX_OVERLAP, OVERLAP_TOL, Drive
from ..prep.samples import pullout_sample
from ..scene import Scene
from ..schedules import FollowSchedules, Ramp
from .common import (Recorder, Stages, _run_scalars, check_scale, compile_options, finish,
                     history_writer, interrupted_note, run_meta, solver_choice,
                     wire_law_or_default)
from .config import PulloutConfig

__all__ = ["pullout_test", "PulloutResult"]

G = 9.81
SAND_DENSITY = 2650.0   # [kg/m³]
BEAD_DENSITY = 1400.0   # [kg/m³]

#: What the test records (and the unit of each).
UNITS = dict(force="N", displacement="m", back_displacement="m", top_stress="Pa",
             kinetic_energy="J", stage="-", time="s", step="-")


@dataclass
class PulloutResult:
    """What :func:`pullout_test` returns.

    Attributes
    ----------
    name : str
    time, step : (n,) [s], [-]     the pull's records.
    displacement : (n,) [m]        the pulled end's, along +x from the pull's start.
    force : (n,) [N]               the pull force F: the tension of the pulled bead's link,
                                   its mean over each record's steps (> 0 in tension).
    back_displacement : (n,) [m]   the embedded (free) end's, along +x.
    top_stress : (n,) [Pa]         the top plate's stress (compression positive).
    F_peak : float [N]             the largest mean of F over ``peak_window`` of travel.
    F_max : float [N]              the largest record of F.
    F_residual : float [N]         the mean of F over the pull's second half.
    displacement_at_peak : float [m]
    F_start : float [N]            F at the pull's start (the clamped wire's tension after
                                   the consolidation).
    sigma_v : float [Pa]           the applied vertical stress.
    embedded_length : float [m]    L, the chain's length inside the box at the pull's start
                                   (from the embedded end's back to the +x face).
    wire_diameter : float [m]      d_w = 2 r_w.
    mu_star : float [-]            μ* = F_peak / (σ_v π d_w L).
    mu_residual : float [-]        F_residual / (σ_v π d_w L).
    peak_passed : bool             the peak lies before the last 10 % of the pull.
    consolidated : bool            the consolidation's criterion was met.
    history : str;  params, convergence, extra : dict   (``extra["consolidation"]``: its
                                   records' time, top stress and sand kinetic energy, and
                                   at its end: ``reached``, ``steps``, ``stress_end`` [Pa],
                                   ``ke_ratio`` (kinetic energy / its peak),
                                   ``sand_rms_velocity`` √(2 E_k / M) [m/s].)
    """

    name: str
    time: np.ndarray
    step: np.ndarray
    displacement: np.ndarray
    force: np.ndarray
    back_displacement: np.ndarray
    top_stress: np.ndarray
    F_peak: float
    F_max: float
    F_residual: float
    displacement_at_peak: float
    F_start: float
    sigma_v: float
    embedded_length: float
    wire_diameter: float
    mu_star: float
    mu_residual: float
    peak_passed: bool
    consolidated: bool
    history: str
    params: dict = field(default_factory=dict)
    convergence: dict = field(default_factory=dict)
    extra: dict = field(default_factory=dict)

    def __str__(self):
        c = self.convergence
        s = (f"{self.name}: {len(self.time)} pull records, {c.get('steps', 0)} steps"
             f"{interrupted_note(self)}, {c.get('non_converged', 0)} not converged "
             f"({c.get('share', 0):.1%}); ")
        if not self.consolidated and not c.get("interrupted"):
            s += "consolidation NOT reached (see the warning); "
        s += (f"F_peak {self.F_peak:.4g} N at {self.displacement_at_peak * 1e3:.3f} mm"
              f"{'' if self.peak_passed else ' (peak NOT passed)'}, σ_v {self.sigma_v:.4g} "
              f"Pa, L {self.embedded_length * 1e3:.2f} mm, d_w "
              f"{self.wire_diameter * 1e3:.3f} mm, μ* = {self.mu_star:.3f} (residual "
              f"{self.mu_residual:.3f}); ")
        return s + f"history {self.history}"

    def scalars(self) -> dict:
        """The test's scalar results (what a campaign's table keeps): the run's steps and
        convergence, F_peak, F_max, F_residual, the displacement at the peak, F at the
        start, σ_v, L, d_w, μ* and the residual μ, whether the peak was passed and the
        consolidation reached, the top plate's stress at its end, the pull velocity, the
        grain and bead counts."""
        out = _run_scalars(self)
        out.update(records=len(self.time), F_peak=self.F_peak, F_max=self.F_max,
                   F_residual=self.F_residual, mu_residual=self.mu_residual,
                   displacement_at_peak=self.displacement_at_peak, F_start=self.F_start,
                   sigma_v=self.sigma_v, embedded_length=self.embedded_length,
                   wire_diameter=self.wire_diameter, mu_star=self.mu_star,
                   peak_passed=bool(self.peak_passed), consolidated=bool(self.consolidated),
                   consolidation_stress=self.extra.get("consolidation", {}).get("stress_end"),
                   pull_velocity=self.params.get("pull_velocity"),
                   n_sand=self.params.get("n_sand"), n_beads=self.params.get("n_beads"))
        return out


def pullout_test(scale: float = 0.2, *, pressure: float = 15e3, wire: bool = True,
                 wire_law=None, neighbour_contact: bool = True,
                 bead_radius: float | None = None, pull_velocity: float = 5e-3,
                 pull_distance: float = 6e-4, peak_window: float = 2.5e-5,
                 allow_dynamic: bool = False,
                 wall_mass: float | None = None, ramp_steps: int = 400,
                 consolidation_tol: float = 0.02, ke_fraction: float = 1e-3,
                 consolidation_hold: int = 5, consolidation_max_steps: int = 4000,
                 check_every: int = 10, dt: float = 5e-5, theta: float = 0.5,
                 tol: float = 3e-4, max_iter: int = 1000, relax: float = 1.0,
                 anderson: int = 0, threads: int = 1, hot_sweeps: int | None = None,
                 chain_solve: bool = False, contact_compliance: float = 0.0,
                 overlap_tol: float | None = OVERLAP_TOL,
                 max_overlap: float = MAX_OVERLAP,
                 mu: float = 0.5, mu_wall: float = 0.0, mu_wire: float = 0.3,
                 record_every: int = 10, frames: int = 100, max_nonconverged: float = 0.25,
                 history: str = "out/pullout_test.h5", seed: int = 0,
                 progress: bool = True) -> PulloutResult:
    """The wire pull-out test (module docstring): consolidation under ``pressure`` σ_v [Pa],
    then the wire's outer end pulled along +x at ``pull_velocity`` [m/s] over
    ``pull_distance`` [m].

    ``scale``: the box's volume and grain count (1: 10 × 6 × 6 mm, about 2 000 grains;
    lengths by scale^(1/3)); below about 0.096 the box is narrower than 5 mean grain
    diameters and is refused.  ``bead_radius`` r_w [m] (None: 0.135 mm, the paper's
    cylinder beads); ``wire_law`` the links' law (None: ``ElasticWire(k = 1 N)``, the
    paper's); ``mu`` sand–sand, ``mu_wire`` wire–sand and wire–wire, ``mu_wall`` the walls'
    and the top plate's friction on the sand.  ``pull_velocity`` is refused if its inertial
    number I = v √(ρ/σ_v) exceeds 0.1, unless ``allow_dynamic``.  ``wall_mass`` [kg] of the
    top plate (None: 0.2 × the sand's mass).  Solver options as in
    :func:`engine.experiments.box_triaxial`.  Errors name the keyword, its value and the
    allowed range on one line.
    """
    cfg = _config(dict(locals()))
    rig = _rig(cfg)
    rec, hist, stages = _recording(rig, cfg)
    try:
        cfg.consolidated = _consolidation(stages, rig, cfg)
        if not stages.interrupted:
            _pull(stages, rig, cfg)
        stages.record_last()
    finally:
        stages.close()
        hist.close()
    return finish(_result(rig, cfg, rec, stages.interrupted), stages, cfg.max_nonconverged)


def _config(args) -> SimpleNamespace:
    """The keywords checked and turned into the test's config (``cfg.config``), the run's
    values from it, the solver choice resolved, the pull's inertial number checked."""
    config = PulloutConfig.from_kwargs(**args)
    cfg = SimpleNamespace(**config.kwargs(), config=config)
    cfg.scale = check_scale(cfg.scale)
    cfg.anderson, cfg.hot_sweeps = solver_choice(cfg.anderson, cfg.hot_sweeps)
    cfg.law = wire_law_or_default(cfg.wire_law)
    cfg.I = cfg.pull_velocity * math.sqrt(SAND_DENSITY / cfg.pressure)
    if cfg.I > 0.1 and not cfg.allow_dynamic:
        raise ValueError(f"pullout_test: pull_velocity = {cfg.pull_velocity!r}: inertial "
                         f"number v √(ρ/σ_v) = {cfg.I:.3g} > 0.1 (a dynamic pull); use "
                         f"pull_velocity <= {0.1 * math.sqrt(cfg.pressure / SAND_DENSITY):.3g} "
                         f"m/s or allow_dynamic=True")
    cfg.n_pull = int(math.ceil(cfg.pull_distance / (cfg.pull_velocity * cfg.dt) - 1e-9))
    cfg.est_steps = cfg.consolidation_max_steps + cfg.n_pull
    return cfg


@dataclass(eq=False)
class _Rig:
    """The compiled test: model and state, the sample, the ids the stages measure (sand,
    beads, the pulled bead and the embedded end, the pulled link, the top plate), the
    plate's area [m²], the references of the displacements and the stage (0, 1)."""

    model: object
    state: object
    smp: object
    sand: np.ndarray
    beads: np.ndarray
    link: int
    top: int
    area: float
    x_ref: np.ndarray
    stage: int = 0
    F_start: float = math.nan
    consolidation: dict = field(default_factory=dict)
    L: float = math.nan             # [m] the embedded length at the pull's start
    tension_sum: float = 0.0
    tension_n: int = 0

    @property
    def pulled(self) -> int:
        return int(self.beads[-1])

    @property
    def back(self) -> int:
        return int(self.beads[0])


def _rig(cfg) -> _Rig:
    """The sample in its box: floor, −x, ±y sides and the top plate (group "wall"), the +x
    side (group "front", which the wire passes through), the top plate driven by the
    pressure ramp on the constant area L_x L_y, the pulled bead held by a zero velocity."""
    try:
        smp = pullout_sample(cfg.scale, bead_radius=cfg.bead_radius, seed=cfg.seed)
    except ValueError as e:                         # (a bead radius too large for the box)
        raise ValueError(f"pullout_test: {e}") from None
    lo, hi = smp.container.bounds()
    sc = Scene(gravity=(0.0, 0.0, -G))
    sand, beads = smp.add_to(sc, sand_density=SAND_DENSITY, bead_density=BEAD_DENSITY,
                             wire_law=cfg.law, neighbour_contact=cfg.neighbour_contact)
    beads = beads[0]
    sc.add_plane(point=lo, normal=(0, 0, 1), group="wall")
    for pt, n in ((lo, (1, 0, 0)), (lo, (0, 1, 0)), (hi, (0, -1, 0))):
        sc.add_plane(point=pt, normal=n, group="wall")
    sc.add_plane(point=hi, normal=(-1, 0, 0), group="front")
    top = sc.add_plane(point=(0, 0, lo[2] + smp.info["sand_top"]), normal=(0, 0, -1),
                       group="wall")
    area = float((hi[0] - lo[0]) * (hi[1] - lo[1]))
    sand_mass = SAND_DENSITY * 4 / 3 * math.pi * float(np.sum(smp.sand_radii ** 3))
    cfg.wall_mass = 0.2 * sand_mass if cfg.wall_mass is None else float(cfg.wall_mass)
    sc.drive(top, pressure=Ramp(0.0, cfg.pressure, cfg.ramp_steps, every=cfg.check_every),
             mass=cfg.wall_mass, area=area)
    sc.drive(int(beads[-1]), velocity=(0.0, 0.0, 0.0))
    _laws(sc, cfg)
    model, state = sc.compile(**compile_options(cfg))
    pair = {int(beads[-2]), int(beads[-1])}
    link = next(k for k in range(model.n_links)
                if {int(model.link_i[k]), int(model.link_j[k])} == pair)
    return _Rig(model, state, smp, np.asarray(sand), np.asarray(beads), link, top, area,
                x_ref=state.position[[beads[0], beads[-1]], 0].copy())


def _laws(sc, cfg) -> None:
    """Sand–sand ``mu``; the walls' and the front's on the sand ``mu_wall``; wire–sand,
    wire–wire and wire–wall ``mu_wire``; wire–front none (the wire passes through)."""
    sc.interact("sand", "sand", laws.Coulomb(mu=cfg.mu))
    sc.interact("sand", "wall", laws.Coulomb(mu=cfg.mu_wall))
    sc.interact("sand", "front", laws.Coulomb(mu=cfg.mu_wall))
    for g in ("sand", "wire", "wall"):
        sc.interact("wire", g, laws.Coulomb(mu=cfg.mu_wire))
    sc.interact("wire", "front", None)


def _top_stress(rig, model, state) -> float:
    """The top plate's stress [Pa], compression positive (the sand pushes it up)."""
    f = wall_forces(model, state, [rig.top])[0]
    return float(-f @ model.body_axis[rig.top]) / rig.area


class _Values(Recorder):
    """The test's recorder: every ``record_every`` steps the mean pull force over the steps
    since the last record (:class:`_TensionSum` adds each step's), the two ends'
    displacements along x from ``rig.x_ref``, the top plate's stress, the sand's kinetic
    energy and the stage."""

    def __init__(self, rig, every):
        super().__init__({k: None for k in UNITS}, every)
        self.rig = rig

    def values(self, model, state) -> dict:
        rig = self.rig
        F = (rig.tension_sum / rig.tension_n if rig.tension_n
             else float(state.links.tension[rig.link]))
        rig.tension_sum, rig.tension_n = 0.0, 0
        x = state.position[[rig.back, rig.pulled], 0] - rig.x_ref
        return dict(force=F, displacement=float(x[1]), back_displacement=float(x[0]),
                    top_stress=_top_stress(rig, model, state),
                    kinetic_energy=kinetic_energy(model, state, rig.sand), stage=rig.stage,
                    time=state.time, step=state.step)


class _TensionSum:
    """A writer of every step: the pulled link's tension [N] added to the rig's sum (what
    :class:`_Values` averages); listed before the recorder, so a recorded step counts."""

    def __init__(self, rig):
        self.rig = rig

    def trigger(self, step) -> bool:
        return True

    def write(self, model, state) -> None:
        t = state.link_impulse[self.rig.link] / state.last_dt if state.last_dt else 0.0
        self.rig.tension_sum += float(t)
        self.rig.tension_n += 1


def _recording(rig, cfg):
    """(recorder, history, stages): :class:`_Values` every ``record_every`` steps into the
    HDF5 history (its first record the state as built), the stages reporting every
    ``check_every`` steps."""
    rec = _Values(rig, cfg.record_every)
    hist = history_writer(cfg.history, rec, UNITS, cfg.record_every, cfg.frames,
                          meta=run_meta("pullout_test", cfg.est_steps,
                                        config=cfg.config.model_dump(mode="json"),
                                        **_meta(rig, cfg)))
    try:
        stages = Stages(rig.model, rig.state, [_TensionSum(rig), rec, hist],
                        progress=cfg.progress, total=cfg.est_steps, desc="pullout test",
                        report_every=cfg.check_every)
        rec.write(rig.model, rig.state)
        hist.write(rig.model, rig.state)
    except BaseException:
        hist.close()
        raise
    return rec, hist, stages


def _meta(rig, cfg) -> dict:
    """What the history says of the run (:func:`run_meta`)."""
    return dict(scale=cfg.scale, seed=cfg.seed, pressure=cfg.pressure, wire_law=cfg.law,
                bead_radius=rig.smp.bead_radius, neighbour_contact=cfg.neighbour_contact,
                pull_velocity=cfg.pull_velocity, pull_distance=cfg.pull_distance, dt=cfg.dt,
                theta=cfg.theta, tol=cfg.tol, max_iter=cfg.max_iter, mu=cfg.mu,
                mu_wall=cfg.mu_wall, mu_wire=cfg.mu_wire)


class _Consolidated:
    """The consolidation's stop condition, every ``check_every`` steps: σ_v fully applied,
    the top plate's stress within ``consolidation_tol`` of it and the sand's kinetic
    energy at most ``ke_fraction`` of its peak so far, for ``consolidation_hold`` checks
    in a row."""

    def __init__(self, rig, cfg):
        self.rig, self.cfg = rig, cfg
        self.ok, self.peak, self.stress, self.ke = 0, 0.0, math.nan, math.nan

    def trigger(self, step) -> bool:
        return step % self.cfg.check_every == 0

    def __call__(self, model, state) -> bool:
        rig, cfg = self.rig, self.cfg
        self.stress = _top_stress(rig, model, state)
        self.ke = kinetic_energy(model, state, rig.sand)
        self.peak = max(self.peak, self.ke)
        ok = (state.drive_pressure[rig.top] == cfg.pressure
              and abs(self.stress / cfg.pressure - 1) < cfg.consolidation_tol
              and self.ke <= cfg.ke_fraction * self.peak)
        self.ok = self.ok + 1 if ok else 0
        return self.ok >= cfg.consolidation_hold


def _consolidation(stages, rig, cfg) -> bool:
    """Stage 1: σ_v ramped (:class:`FollowSchedules`) until :class:`_Consolidated` holds,
    at most ``consolidation_max_steps`` rounded up to a multiple of ``check_every``;
    whether it held (if not, a RuntimeWarning with the stress and energy reached)."""
    stages.set_stage("consolidation")
    until = _Consolidated(rig, cfg)
    every = cfg.check_every
    steps = -(-cfg.consolidation_max_steps // every) * every
    stages.run(steps, updaters=[FollowSchedules(every)], until=until)
    reached = until.ok >= cfg.consolidation_hold
    mass = float(rig.model.body_mass[rig.sand].sum())
    rig.consolidation = dict(reached=reached, steps=stages.steps, stress_end=until.stress,
                             ke_ratio=until.ke / until.peak if until.peak else 0.0,
                             sand_rms_velocity=math.sqrt(2 * until.ke / mass))
    if not reached and not stages.interrupted:
        warnings.warn(f"pullout_test: the consolidation did not reach σ_v = {cfg.pressure:.4g} "
                      f"Pa (within {cfg.consolidation_tol:.0%}, kinetic energy <= "
                      f"{cfg.ke_fraction:g} of its peak, {cfg.consolidation_hold} checks in a "
                      f"row) in {stages.steps} steps: top plate {until.stress:.4g} Pa, kinetic "
                      f"energy {until.ke / until.peak if until.peak else 0:.3g} of its peak; "
                      f"the pull starts from there. Raise consolidation_max_steps",
                      RuntimeWarning, stacklevel=3)
    return reached


def _pull(stages, rig, cfg) -> None:
    """Stage 2: the pulled bead (outside the box: it touches nothing) moved to its
    neighbour's height and y at the same distance, so that the pull acts along the wire's
    line with the link's tension unchanged (the sand's settlement has lowered the wire; a
    lab aligns its clamp likewise); the embedded length and the displacements' references
    taken; the pulled bead's drive switched to ``pull_velocity`` along +x; ``n_pull``
    steps."""
    state = rig.state
    rig.stage = 1
    stages.set_stage("pull")
    x = state.position
    nb = int(rig.beads[-2])
    g = float(np.linalg.norm(x[rig.pulled] - x[nb]))       # the link's length, kept
    x[rig.pulled] = x[nb] + (g, 0.0, 0.0)                   # the clamp on the wire's line
    rig.F_start = (rig.tension_sum / rig.tension_n if rig.tension_n
                   else float(state.links.tension[rig.link]))
    rig.x_ref = state.position[[rig.back, rig.pulled], 0].copy()
    rig.L = rig.smp.info["exit_x"] - (rig.x_ref[0] - rig.smp.bead_radius)
    rig.tension_sum, rig.tension_n = 0.0, 0
    rig.model = stages.model = _pulled(rig.model, rig.pulled, (cfg.pull_velocity, 0.0, 0.0))
    stages.run(cfg.n_pull, updaters=[FollowSchedules(cfg.check_every)])


def _pulled(model, bead, velocity):
    """A copy of ``model`` whose velocity-driven sphere ``bead`` moves at ``velocity`` (3,)
    [m/s] from the next step on: :meth:`engine.model.Model.with_drive` takes walls only,
    and the bead is already a velocity-driven body (its degrees of freedom imposed since
    the compile), so only its drive's value changes."""
    v = np.asarray(velocity, float)
    drives = tuple(Drive(body=d.body, kind="velocity", value=v) if d.body == bead else d
                   for d in model.drives)
    return replace(model, drives=drives)


def _result(rig, cfg, rec, interrupted) -> PulloutResult:
    """The pull's curves and the peak, μ*, the consolidation's records in ``extra``; a
    RuntimeWarning when the peak lies in the pull's last 10 % (unless ``interrupted``)."""
    stage = rec.array("stage") if rec.rows.get("stage") else np.zeros(0)
    pull = stage == 1
    c = {k: rec.array(k)[pull] if len(stage) else np.zeros(0) for k in UNITS}
    cons = dict(rig.consolidation)
    cons.update({k: rec.array(k)[~pull] if len(stage) else np.zeros(0)
                 for k in ("time", "top_stress", "kinetic_energy")})
    F, u = c["force"], c["displacement"]
    F_peak, u_peak = _peak(F, u, cfg)
    F_res = float(np.mean(F[u >= 0.5 * cfg.pull_distance])) if np.any(
        u >= 0.5 * cfg.pull_distance) else math.nan
    L, d_w = float(rig.L), 2 * rig.smp.bead_radius
    nominal = cfg.pressure * math.pi * d_w * L      # [N] σ_v on the wire's embedded surface
    res = PulloutResult(
        name="pullout_test", time=c["time"], step=c["step"].astype(np.int64),
        displacement=u, force=F, back_displacement=c["back_displacement"],
        top_stress=c["top_stress"], F_peak=F_peak,
        F_max=float(F.max()) if F.size else math.nan, F_residual=F_res,
        displacement_at_peak=u_peak, F_start=rig.F_start, sigma_v=float(cfg.pressure),
        embedded_length=L, wire_diameter=d_w, mu_star=F_peak / nominal,
        mu_residual=F_res / nominal,
        peak_passed=bool(F.size and u_peak < 0.9 * cfg.pull_distance),
        consolidated=bool(cfg.consolidated), history=cfg.history,
        params=_params(rig, cfg), extra={"consolidation": cons})
    if F.size and not res.peak_passed and not interrupted:
        warnings.warn(f"pullout_test: the pull force was still at its largest in the last "
                      f"10 % of the pull ({u_peak * 1e3:.3f} of "
                      f"{cfg.pull_distance * 1e3:.3f} mm): F_peak and μ* are lower bounds; "
                      f"raise pull_distance", RuntimeWarning, stacklevel=3)
    return res


def _peak(F, u, cfg) -> tuple[float, float]:
    """(F_peak [N], the displacement at it [m]): the largest mean of ``F`` over
    ``peak_window`` of travel (the records in a window, at least one; the displacement at
    the window's middle)."""
    if not F.size:
        return math.nan, math.nan
    per = cfg.pull_velocity * cfg.dt * cfg.record_every          # [m] of travel per record
    n = int(min(max(1, round(cfg.peak_window / per)), F.size))
    mean = np.convolve(F, np.ones(n) / n, mode="valid")
    k = int(np.argmax(mean))
    return float(mean[k]), float(np.mean(u[k:k + n]))


def _params(rig, cfg) -> dict:
    """``result.params``."""
    smp = rig.smp
    lo, hi = smp.container.bounds()
    return dict(scale=cfg.scale, seed=cfg.seed, pressure=cfg.pressure,
                wire_law=repr(cfg.law), neighbour_contact=cfg.neighbour_contact,
                bead_radius=smp.bead_radius, pull_velocity=cfg.pull_velocity,
                pull_distance=cfg.pull_distance, peak_window=cfg.peak_window,
                inertial_number=cfg.I,
                wall_mass=cfg.wall_mass, box=(hi - lo).tolist(),
                sand_top=smp.info["sand_top"], embedded_length_built=smp.info["embedded_length"],
                embedded_length=rig.L,
                dt=cfg.dt, theta=cfg.theta, tol=cfg.tol, max_iter=cfg.max_iter,
                relax=cfg.relax, anderson=cfg.anderson, threads=cfg.threads,
                hot_sweeps=cfg.hot_sweeps, chain_solve=cfg.chain_solve,
                contact_compliance=cfg.contact_compliance,
                overlap_tol=cfg.overlap_tol, mu=cfg.mu, mu_wall=cfg.mu_wall,
                mu_wire=cfg.mu_wire, n_sand=int(smp.sand_radii.size), n_beads=smp.n_beads,
                consolidated=bool(cfg.consolidated), config=cfg.config.model_dump(mode="json"))
