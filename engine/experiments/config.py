"""One configuration schema per test (issue 32 §1): pydantic models with nested parts.

Each paper test has one model, :class:`CylinderConfig`, :class:`BoxConfig`,
:class:`SlopeConfig` and :class:`DepositConfig`, and so has the wire pull-out test
(:class:`PulloutConfig`, not one of the paper's), made of

* ``scale``, ``seed``, ``neighbour_contact`` and ``wire``: the wire's law, a discriminated
  union (:data:`WireSpec`, keyed by ``law``) of :class:`NoWire`, :class:`DefaultWire`,
  :class:`RigidRodSpec`, :class:`ElasticRodSpec`, :class:`RigidWireSpec`,
  :class:`ElasticWireSpec`, :class:`BrittleWireSpec` and :class:`LooseWireSpec`;
* ``solver``: :class:`Solver` (dt, θ, tol, max_iter, relax, threads, max_nonconverged and
  ``acceleration``, ONE field: :class:`HotSweeps` or :class:`Anderson`, so the two cannot be
  asked for together);
* ``friction``, ``preparation``, ``loading`` and ``recording`` (each test its own
  subclass, with its defaults).

Every field of a part has the name of the test function's keyword argument it stands for
(``config.loading.pressure`` is ``pressure=``), the function's default and the range the
code can honour; only ``solver.acceleration`` (the keywords ``anderson`` and
``hot_sweeps``) and ``wire`` (``wire`` and ``wire_law``) are spelled otherwise.

* :meth:`TestConfig.from_kwargs` builds a config from a test function's keywords (what
  each test does first; errors on one line: field, value, allowed range) and
  :meth:`TestConfig.kwargs` gives them back;
* :meth:`TestConfig.run` runs the test of a config;
* :func:`flat_model` derives the flat ``[parameters]`` model of ``nscd run`` files
  (:mod:`engine.experiments.params`) from these models: the bounds are written once, here;
* :func:`wire_spec` turns the user-facing spelling of a wire (``"elastic"``, ``"rigid"``,
  ... ``"none"``, with ``k``, ``prestrain``, ``max_tension``) into a :data:`WireSpec`: the
  one translation ``nscd run``, ``nscd sweep`` and ``nscd paper`` use.
"""
from __future__ import annotations

import os
from typing import Annotated, Any, ClassVar, Literal, Optional, Union

from pydantic import (ConfigDict, Discriminator, Field, Tag, ValidationError, create_model,
                      field_validator, model_validator)

from ..checks import InputError, NumbersOnly, describe
from ..model import (MAX_ITER_LIMIT, MAX_OVERLAP, OVERLAP_TOL, TRIAXIAL_OVERLAP_TOL,
                     solver_conflict)

__all__ = ["CONFIGS", "TestConfig", "CylinderConfig", "BoxConfig", "SlopeConfig",
           "DepositConfig", "PulloutConfig", "Solver", "HotSweeps", "Anderson", "WireSpec",
           "NoWire",
           "DefaultWire", "RigidRodSpec", "ElasticRodSpec", "RigidWireSpec", "ElasticWireSpec",
           "BrittleWireSpec", "LooseWireSpec", "wire_spec", "spec_of_law", "flat_model", "config_of",
           "STEP_LIMIT", "SEED_LIMIT", "HOT_SWEEPS"]

#: Largest step count of the tests' integer parameters (steps, frames, intervals).
STEP_LIMIT = 10**9
#: Seeds are 64-bit: numpy's generators take any integer >= 0, the histories store int64.
SEED_LIMIT = 2**63 - 1
#: The hot re-sweeps of the tests when ``anderson`` = 0 and ``hot_sweeps`` = None.
HOT_SWEEPS = 2


class Strict(NumbersOnly):
    """Unknown fields refused; numbers and bools strictly typed (:class:`~engine.checks.NumbersOnly`);
    an assignment validated as the construction is."""

    model_config = ConfigDict(extra="forbid", validate_assignment=True)


# -- the wire --------------------------------------------------------------------------------
class _Law(Strict):
    #: the engine.laws class of the spec (None: no law object)
    LAW: ClassVar[str | None] = None

    def to_law(self, default=None):
        """The :mod:`engine.laws` object (None for :class:`NoWire`; ``default`` for
        :class:`DefaultWire`)."""
        from .. import laws

        return getattr(laws, self.LAW)(**self.model_dump(exclude={"law"}))


class NoWire(_Law):
    """Sand only (``wire=False``; the name ``"none"``)."""
    law: Literal["none"] = "none"

    def to_law(self, default=None):  # noqa: D102
        return None


class DefaultWire(_Law):
    """The test's default: ``ElasticWire(k = 1 N)`` on a sample the test builds, the links'
    own laws on an end state (``wire=True, wire_law=None``)."""
    law: Literal["default"] = "default"

    def to_law(self, default=None):  # noqa: D102
        return default


_PRESTRAIN = Field(0.0, gt=-1.0, le=1.0, allow_inf_nan=False,
                   description="ε₀ [-]: reference length g(0)/(1+ε₀)")
_STIFFNESS = Field(1.0, gt=0, allow_inf_nan=False, description="k [N]")


class RigidRodSpec(_Law):
    LAW: ClassVar[str] = "RigidRod"
    law: Literal["rigid_rod"] = "rigid_rod"
    prestrain: float = _PRESTRAIN


class ElasticRodSpec(_Law):
    LAW: ClassVar[str] = "ElasticRod"
    law: Literal["elastic_rod"] = "elastic_rod"
    stiffness: float = _STIFFNESS
    prestrain: float = _PRESTRAIN


class RigidWireSpec(_Law):
    LAW: ClassVar[str] = "RigidWire"
    law: Literal["rigid"] = "rigid"
    prestrain: float = _PRESTRAIN


class ElasticWireSpec(_Law):
    LAW: ClassVar[str] = "ElasticWire"
    law: Literal["elastic"] = "elastic"
    stiffness: float = _STIFFNESS
    prestrain: float = _PRESTRAIN


class BrittleWireSpec(_Law):
    LAW: ClassVar[str] = "BrittleElasticWire"
    law: Literal["brittle"] = "brittle"
    stiffness: float = _STIFFNESS
    prestrain: float = _PRESTRAIN
    max_tension: float = Field(gt=0, allow_inf_nan=False, description="[N], required")


class LooseWireSpec(_Law):
    """The control "beads without links" (:class:`engine.laws.LooseWire`: no link force)."""
    LAW: ClassVar[str] = "LooseWire"
    law: Literal["loose"] = "loose"

    def to_law(self, default=None):  # noqa: D102
        from .. import laws

        return laws.LooseWire()


#: A test's wire: one of the laws, keyed by ``law`` (what a dump stores).
def _tagged_union(key: str, *classes):
    """A union of ``classes`` told apart by their field ``key`` (a callable discriminator:
    the strict models' before-validators rule out pydantic's ``Field(discriminator=)``)."""
    def tag(v):
        return v.get(key) if isinstance(v, dict) else getattr(v, key, None)

    return Annotated[Union[tuple(Annotated[c, Tag(c.model_fields[key].default)]
                                 for c in classes)], Discriminator(tag)]


_SPECS = {c.model_fields["law"].default: c for c in (
    NoWire, DefaultWire, RigidRodSpec, ElasticRodSpec, RigidWireSpec, ElasticWireSpec,
    BrittleWireSpec, LooseWireSpec)}
WireSpec = _tagged_union("law", *_SPECS.values())


def wire_spec(wire="elastic", k=None, prestrain=None, max_tension=None) -> _Law:
    """The wire of its user-facing spelling: ``wire`` a law's name (``"elastic"``,
    ``"rigid"``, ``"elastic_rod"``, ``"rigid_rod"``, ``"brittle"`` or ``"none"``; True and
    False for "elastic" and "none"), ``k`` its stiffness [N] (elastic laws; default 1),
    ``prestrain`` ε₀, ``max_tension`` [N] ("brittle", required).  A parameter the law has
    not is refused by name (:func:`engine.laws.wire_law`, whose checks these are)::

        wire_spec("rigid", k=2.0)  ->  ValueError: stiffness = 2.0: the 'rigid' wire has no ...
    """
    from .. import laws

    if wire is True:
        wire = "elastic"
    elif wire is False or wire is None:
        wire = "none"
    if k is not None:
        try:
            k = float(k)
        except (TypeError, ValueError):
            raise ValueError(f"k must be the elastic wire's stiffness in N (> 0), got {k!r}") \
                from None
    law = laws.wire_law(wire, stiffness=k, prestrain=prestrain, max_tension=max_tension)
    return spec_of_law(law)


def spec_of_law(law) -> _Law:
    """The :data:`WireSpec` of an :mod:`engine.laws` wire law (None: :class:`NoWire`)."""
    from .. import laws

    if law is None:
        return NoWire()
    if not isinstance(law, laws.WireLaw):
        raise ValueError(f"wire_law must be a wire law (engine.laws.RigidWire(), "
                         f"ElasticWire(k) ...), got {law!r}")
    for spec in _SPECS.values():
        if spec.LAW == type(law).__name__:
            return spec(**{k: v for k, v in law.model_dump().items() if k in spec.model_fields})
    raise ValueError(f"wire_law: no schema for {type(law).__name__}")  # pragma: no cover


# -- the solver ------------------------------------------------------------------------------
class HotSweeps(Strict):
    """NLGS with ``sweeps`` re-sweeps of the contacts that changed most after each sweep
    (:attr:`engine.model.Options.hot_sweeps`; 0: the plain sweep).  Keywords:
    ``anderson=0, hot_sweeps=sweeps``."""
    kind: Literal["hot_sweeps"] = "hot_sweeps"
    sweeps: int = Field(HOT_SWEEPS, ge=0, le=8)


class Anderson(Strict):
    """NLGS with Anderson mixing of ``depth`` (:mod:`engine.solver.anderson`), no hot
    re-sweeps.  Keywords: ``anderson=depth`` (``hot_sweeps`` None or 0)."""
    kind: Literal["anderson"] = "anderson"
    depth: int = Field(ge=1, le=16)


Acceleration = _tagged_union("kind", HotSweeps, Anderson)


class Solver(Strict):
    """The time step and the NLGS options of a test (:meth:`engine.Scene.compile`)."""
    dt: float = Field(5e-5, gt=0, le=1e-2, description="time step [s]")
    theta: float = Field(0.5, ge=0.5, le=1.0)
    tol: float = Field(3e-4, gt=0, lt=1)
    max_iter: int = Field(1000, ge=1, le=MAX_ITER_LIMIT)
    relax: float = Field(1.0, gt=0, lt=2,
                         description="NLGS relaxation (> 1: over-relaxation, needs anderson "
                                     "= 0 and threads = 1)")
    threads: int = Field(1, ge=1, le=64,
                         description="NLGS threads (2 pays on tens of thousands of contacts)")
    acceleration: Acceleration = HotSweeps()
    chain_solve: bool = Field(False, description="each wire solved as one chain in every NLGS "
                                                 "sweep (any threads, hot_sweeps or anderson)")
    contact_compliance: float = Field(0.0, ge=0, le=1,
                                      description="contacts' normal compliance ε as a fraction "
                                                  "of their Delassus diagonal (0: rigid; "
                                                  "0.01 cures the mould deposit's stagnation, "
                                                  "overlaps ε h² W_nn F)")
    overlap_tol: Optional[float] = Field(OVERLAP_TOL, gt=0, le=1, description=(
        "overlaps beyond this fraction of the smaller radius are pushed out after each step, "
        "on positions only (no energy added; None: never)"))
    max_overlap: float = Field(MAX_OVERLAP, gt=0, le=1e3, description=(
        "the run stops past this overlap, a fraction of the smaller radius of a contact's "
        "two bodies (results beyond it are not physical; raise it to go on anyway)"))
    max_nonconverged: float = Field(0.25, ge=0, le=1)

    @property
    def anderson(self) -> int:
        return self.acceleration.depth if isinstance(self.acceleration, Anderson) else 0

    @property
    def hot_sweeps(self) -> int:
        return self.acceleration.sweeps if isinstance(self.acceleration, HotSweeps) else 0

    @model_validator(mode="after")
    def _together(self):
        problem = solver_conflict(self.hot_sweeps, self.anderson, self.relax, self.threads,
                                  self.chain_solve, self.contact_compliance)
        if problem:
            raise ValueError(problem)
        return self


class TriaxialSolver(Solver):
    """The triaxial tests' solver: the position correction on by default."""
    overlap_tol: Optional[float] = Field(TRIAXIAL_OVERLAP_TOL, gt=0, le=1, description=(
        "overlaps beyond this fraction of the smaller radius are pushed out after each step, "
        "on positions only (no energy added; None: never)"))


class SlopeSolver(Solver):
    tol: float = Field(1e-4, gt=0, lt=1)


class DepositSolver(Solver):
    dt: float = Field(1e-4, gt=0, le=1e-2, description="time step [s]")
    tol: float = Field(1e-4, gt=0, lt=1)


#: The two keywords of ``solver.acceleration`` in the flat spelling (the test functions'
#: and the run files'), with the checks of the flat model.
_ACCELERATION_KWARGS = dict(
    anderson=(int, Field(0, ge=0, le=16, description="NLGS Anderson acceleration depth (0: none)")),
    hot_sweeps=(int | None, Field(None, ge=0, le=8,
                                  description="re-sweeps of the contacts that changed most "
                                              "after each NLGS sweep (needs anderson = 0; "
                                              "default 2, 0 when anderson > 0)")))


def acceleration_of(anderson=0, hot_sweeps=None):
    """``solver.acceleration`` of the keywords ``anderson`` and ``hot_sweeps`` (None: 2
    without Anderson, 0 with it); both > 0 is refused (:func:`engine.model.solver_conflict`)."""
    a = int(anderson)
    if a == 0:
        return HotSweeps(sweeps=HOT_SWEEPS if hot_sweeps is None else int(hot_sweeps))
    if hot_sweeps:
        raise ValueError(solver_conflict(hot_sweeps, a, 1.0, 1))
    return Anderson(depth=a)


def _hot_sweeps_kwarg(solver) -> int | None:
    """The keyword ``hot_sweeps`` of a solver: None for the default (:data:`HOT_SWEEPS`
    re-sweeps, no Anderson), as the functions' default is spelled (a resumed deposit's
    checkpoint is tied to its keywords, :func:`~engine.experiments.common.run_identity`)."""
    if solver.acceleration == HotSweeps():
        return None
    return solver.hot_sweeps


# -- friction, preparation, loading, recording -------------------------------------------------
SAMPLE_HELP = ("a history or checkpoint file whose last state the test starts from "
               "(None: the test builds its sample; in Python also an engine.prep.Sample or "
               "a (model, state) pair)")
CHECKPOINT_HELP = ("[steps] a checkpoint (RUN.resume.h5) this often, and when Ctrl-C "
                   "stops the run (0: only then)")
RESUME_HELP = "go on from the checkpoint a stopped or killed run of the same file left"


class CylinderFriction(Strict):
    mu: float = Field(0.5, ge=0, le=10)
    mu_wall: float = Field(0.5, ge=0, le=10, description="friction of the cylinder and plates")
    mu_wire: float = Field(0.3, ge=0, le=10)


class BoxFriction(CylinderFriction):
    mu_wall: float = Field(0.0, ge=0, le=10, description="friction of the six walls")


class SlopeFriction(Strict):
    mu: float = Field(0.5, ge=0, le=10)
    mu_floor: float = Field(0.8, ge=0, le=10)
    mu_wire: float = Field(0.3, ge=0, le=10)


class DepositFriction(CylinderFriction):
    mu_wall: float = Field(0.5, ge=0, le=10, description="friction of the mould")


class PulloutFriction(CylinderFriction):
    mu_wall: float = Field(0.0, ge=0, le=10,
                           description="friction of the box's walls and top plate on the "
                                       "sand (0: none, the plate's stress reaches the wire "
                                       "undiminished)")
    mu_wire: float = Field(0.3, ge=0, le=10, description="wire-sand and wire-wire friction")


class TriaxialPreparation(Strict):
    sample: Optional[str] = Field(None, description=SAMPLE_HELP)
    preparation: Literal["geometric", "paper", "layered"] = Field(
        "geometric", description="geometric: the sample as built; paper: relaxed under "
                                 "gravity in its mould first (§2.4), then confined; "
                                 "layered: the sand laid in layers, each covering the wire "
                                 "walked on the layer below (as the TexSol machine lays "
                                 "them, §1.1), then as paper")
    wire_density: Optional[float] = Field(None, gt=0, le=1e8,
                                          description="[m/m³] (None: the paper's)")
    bead_radius: Optional[float] = Field(None, gt=0, le=1e-2,
                                         description="[m] the wire's bead radius r_w "
                                                     "(None: the paper's)")
    wire_mode: Literal["isotropic", "orthotropic", "helix"] = Field(
        "isotropic", description="the wire's walk: Eq. 16, or Eq. 17 in horizontal layers; "
                                 "helix: a helix one small-grain diameter inside the "
                                 "cylinder's surface (a positive control, not the paper's)")
    helix_pitch: Optional[float] = Field(None, gt=0, le=1.0,
                                         description="[m] the helix's rise per turn "
                                                     "(wire_mode = helix; None: d_max)")
    helix_inset: Optional[float] = Field(None, ge=0, le=0.1,
                                         description="[m] the helix's beads' outer edge this far "
                                                     "inside the cylinder's side (wire_mode = "
                                                     "helix; None: d_min)")
    remove_beads: Literal["never", "after_deposit", "at_loading"] = Field(
        "never", description="a control: the wire sample's beads taken out after the "
                             "geometric deposit (the sand laid around them, prepared and "
                             "tested without them) or at the start of the loading (the "
                             "same packing without its beads)")
    deposit_steps: int = Field(6000, ge=1, le=STEP_LIMIT,
                               description="most steps of the paper preparation's deposit")
    wire_prestrain: float = Field(0.0, ge=0, le=1, description=(
        "ε₀ set on every link at the start of the loading: L = g/(1+ε₀)"))
    wire_taut_at_loading: bool = Field(False, description=(
        "every link's reference length set to its length at the start of the loading "
        "(a slack wire made just taut; wire_prestrain > 0 does this and more)"))


class CylinderPreparation(TriaxialPreparation):
    compaction_mu: Optional[float] = Field(None, ge=0.1, le=10,
                                           description="friction of the isotropic stage "
                                                       "(None: the test's own)")


class BoxPreparation(TriaxialPreparation):
    compaction_mu: Optional[float] = Field(None, ge=0, le=10,
                                           description="friction of the isotropic stage "
                                                       "(None: the test's own)")


class SlopePreparation(Strict):
    sample: Optional[str] = Field(None, description=SAMPLE_HELP)
    wire_density: Optional[float] = Field(None, gt=0, le=1e8, description="[m/m³]")
    rubber_radius: float = Field(0.3e-3, gt=0, le=0.1)
    floor_extent: float = Field(5.0, gt=0, le=100)


class PulloutPreparation(Strict):
    bead_radius: Optional[float] = Field(None, gt=0, le=1e-2,
                                         description="[m] the wire's bead radius r_w (None: "
                                                     "the paper's cylinder beads, 0.135 mm)")


class DepositPreparation(Strict):
    sample: Literal["slope", "cylinder", "box"] = Field(
        "slope", description="the paper's sample relaxed in its mould")
    wire_density: Optional[float] = Field(None, gt=0, le=1e8,
                                          description="[m/m³] (None: the sample's own)")


class TriaxialLoading(Strict):
    pressure: float = Field(15e3, gt=0, le=1e9, description="[Pa]")
    axial_strain: float = Field(0.05, gt=0, le=0.5)
    strain_rate: Optional[float] = Field(None, gt=0, le=1e3, description="[1/s]")
    target_I: float = Field(5e-4, gt=0, le=0.1)
    allow_dynamic: bool = False
    ramp_steps: int = Field(400, ge=0, le=STEP_LIMIT,
                            description="steps over which the pressure is raised")
    iso_tol: float = Field(0.02, gt=0, lt=1,
                           description="the isotropic stage ends when the stresses are "
                                       "within this fraction of the pressure ...")
    iso_hold: int = Field(5, ge=1, le=STEP_LIMIT, description="... for this many checks in a row")
    iso_max_steps: int = Field(4000, ge=1, le=STEP_LIMIT)


class CylinderLoading(TriaxialLoading):
    axial_strain: float = Field(0.1, gt=0, le=0.5)
    confinement: Literal["free_surface", "layer_crown"] = Field(
        "free_surface", description="free_surface: §3.3's membrane; layer_crown: LMGC90's "
                                    "3D membrane example")
    confine_every: int = Field(10, ge=1, le=STEP_LIMIT,
                               description="steps between confinement updates")


class BoxLoading(TriaxialLoading):
    wall_mass: Optional[float] = Field(None, gt=0, le=1e6,
                                       description="[kg] (None: 0.2 x the sample's mass)")
    check_every: int = Field(10, ge=1, le=STEP_LIMIT,
                             description="steps between isotropic-stage checks")


class PulloutLoading(Strict):
    pressure: float = Field(15e3, gt=0, le=1e9,
                            description="σ_v [Pa], the vertical stress of the top plate")
    pull_velocity: float = Field(5e-3, gt=0, le=10,
                                 description="[m/s] of the pulled end along +x (5 mm/s: "
                                             "inertial number v √(ρ/σ_v) = 2e-3 at 15 kPa)")
    pull_distance: float = Field(6e-4, gt=0, le=0.1,
                                 description="[m] the pulled end's travel (0.6 mm: 2.2 "
                                             "wire diameters, past the peak)")
    peak_window: float = Field(2.5e-5, ge=0, le=1e-2,
                               description="[m] F_peak is the largest mean of the pull "
                                           "force over this much of the pulled end's "
                                           "travel (0: the largest record)")
    allow_dynamic: bool = Field(False, description="accept a pull_velocity of inertial "
                                                   "number v √(ρ/σ_v) > 0.1")
    wall_mass: Optional[float] = Field(None, gt=0, le=1e6,
                                       description="[kg] of the top plate (None: 0.2 x the "
                                                   "sand's mass)")
    ramp_steps: int = Field(400, ge=0, le=STEP_LIMIT,
                            description="steps over which the pressure is raised")
    consolidation_tol: float = Field(0.02, gt=0, lt=1,
                                     description="the consolidation ends when the top "
                                                 "plate's stress is within this fraction of "
                                                 "σ_v ...")
    ke_fraction: float = Field(1e-3, gt=0, lt=1,
                               description="... and the sand's kinetic energy at most this "
                                           "fraction of its peak ...")
    consolidation_hold: int = Field(5, ge=1, le=STEP_LIMIT,
                                    description="... for this many checks in a row")
    consolidation_max_steps: int = Field(4000, ge=1, le=STEP_LIMIT)
    check_every: int = Field(10, ge=1, le=STEP_LIMIT,
                             description="steps between consolidation checks")


class Settling(Strict):
    """The run to rest of the deposits."""
    steps: int = Field(6000, ge=1, le=STEP_LIMIT)
    ke_fraction: float = Field(1e-4, gt=0, lt=1)


class SlopeSettling(Settling):
    steps: int = Field(4000, ge=1, le=STEP_LIMIT)


class Recording(Strict):
    record_every: int = Field(10, ge=1, le=STEP_LIMIT)
    frames: int = Field(100, ge=0, le=STEP_LIMIT)
    history: str = "out/run.h5"
    progress: bool = True


class CylinderRecording(Recording):
    history: str = "out/cylinder_triaxial.h5"
    torus_strains: list[float] = Field([0.02, 0.05, 0.1], max_length=100, description=(
        "axial strains of the toroidal maps (at most 100)"))


class BoxRecording(Recording):
    history: str = "out/box_triaxial.h5"


class DepositRecording(Recording):
    record_every: int = Field(20, ge=1, le=STEP_LIMIT)
    frames: int = Field(200, ge=0, le=STEP_LIMIT)
    history: str = "out/gravity_deposit.h5"
    checkpoint_every: int = Field(0, ge=0, le=STEP_LIMIT, description=CHECKPOINT_HELP)
    resume: bool = Field(False, description=RESUME_HELP)


class PulloutRecording(Recording):
    history: str = "out/pullout_test.h5"


class SlopeRecording(DepositRecording):
    history: str = "out/slope_deposit.h5"
    fit_degree: Optional[int] = Field(None, ge=1, le=11, description=(
        "degree of the heap's height regression whose steepest slope is the max slope "
        "(None: 1 for sand, 3 with a wire; the paper's TexSol(2): 8)"))


# -- the tests ---------------------------------------------------------------------------------
#: The parts of a config (fields whose own fields are the test's keywords).
PARTS = ("solver", "friction", "preparation", "loading", "recording")


class TestConfig(Strict):
    """Base of the tests' configs: the parts' fields are the test's keywords."""

    __test__ = False            # (not a pytest class)
    TEST: ClassVar[str] = ""

    scale: float = Field(0.05, gt=0, le=10.0, description="sample size (1: the paper's)")
    seed: int = Field(0, ge=0, le=SEED_LIMIT)
    wire: WireSpec = DefaultWire()
    neighbour_contact: bool = Field(False, description="linked beads also touch like two "
                                                       "spheres")

    # -- keywords <-> config
    @classmethod
    def keywords(cls) -> dict[str, tuple[str | None, Any]]:
        """Every keyword of the test function: {name: (part or None, default)} (``wire``
        and ``wire_law``, ``anderson`` and ``hot_sweeps`` with the function's defaults)."""
        out = {}
        for name, f in cls.model_fields.items():
            ann = f.annotation
            if name in PARTS:
                for n, g in ann.model_fields.items():
                    if n == "acceleration":
                        out.update(anderson=("solver", 0), hot_sweeps=("solver", None))
                    else:
                        out[n] = (name, g.default)
            elif name == "wire":
                out.update(wire=(None, True), wire_law=(None, None))
            else:
                out[name] = (None, f.default)
        return out

    @classmethod
    def from_kwargs(cls, **kw) -> "TestConfig":
        """The config of a call of the test function with keywords ``kw`` (left out: the
        function's defaults).  Raises :class:`~engine.checks.InputError` naming, on one line,
        every keyword at fault, its value and the allowed range::

            cylinder_triaxial: pressure = 2e+09: must be a number in (0, 1e+09]
        """
        keys = cls.keywords()
        bad = sorted(set(kw) - set(keys))
        if bad:
            raise InputError(f"{cls.TEST}: no parameter {', '.join(map(repr, bad))}")
        kw = dict(kw)
        if not isinstance(kw.get("sample"), (str, type(None))):
            kw.pop("sample")     # a Sample or a (model, state): a runtime keyword of run()
        flat = flat_model(cls)
        given = {k: v for k, v in kw.items() if k in flat.model_fields}
        problems = []
        try:
            flat(**given)
        except ValidationError as e:
            problems = [describe(err, flat) for err in e.errors()]
        wire, law = kw.get("wire", True), kw.get("wire_law")
        for name, v in (("wire", wire), ("neighbour_contact", kw.get("neighbour_contact", False)),
                        ("progress", kw.get("progress", True))):
            if not isinstance(v, bool):
                problems.append(f"{name} = {v!r}: must be true or false")
        seed = kw.get("seed", 0)
        if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= SEED_LIMIT:
            problems.append(f"seed = {seed!r}: must be an integer in [0, 2**63 - 1]")
        if problems:
            raise InputError(f"{cls.TEST}: " + "; ".join(problems))
        from .common import check_scale

        if "scale" in kw:
            kw["scale"] = check_scale(kw["scale"])
        if isinstance(kw.get("history"), os.PathLike):
            kw["history"] = os.fspath(kw["history"])
        nested: dict = {p: {} for p in PARTS}
        for k, v in kw.items():
            part, _ = keys[k]
            if k in ("anderson", "hot_sweeps", "wire", "wire_law"):
                continue
            (nested[part] if part else nested)[k] = v
        nested["solver"]["acceleration"] = acceleration_of(kw.get("anderson", 0),
                                                           kw.get("hot_sweeps"))
        nested["wire"] = (NoWire() if not wire else DefaultWire() if law is None
                          else spec_of_law(law))
        try:
            return cls(**nested)
        except ValidationError as e:   # what the flat model cannot see (a path, a law)
            raise InputError(f"{cls.TEST}: " + "; ".join(
                cls._describe(err) for err in e.errors())) from None

    @classmethod
    def _describe(cls, err) -> str:
        """An error of the model in the keywords' names (a part's field by its own name)."""
        loc = tuple(err.get("loc", ()))
        if len(loc) > 1 and loc[0] in PARTS:
            return describe(dict(err, loc=loc[1:]), cls.model_fields[loc[0]].annotation)
        return describe(err, cls)

    def kwargs(self) -> dict:
        """The test function's keywords of this config (``wire_law`` a law object or None;
        ``hot_sweeps`` None for the default acceleration, ``HotSweeps(sweeps=2)``)."""
        out = {}
        for name in type(self).model_fields:
            v = getattr(self, name)
            if name in PARTS:
                for n in type(v).model_fields:
                    if n == "acceleration":
                        out.update(anderson=v.anderson, hot_sweeps=_hot_sweeps_kwarg(v))
                    else:
                        x = getattr(v, n)
                        out[n] = list(x) if isinstance(x, list) else x
            elif name == "wire":
                out["wire"] = not isinstance(v, NoWire)
                out["wire_law"] = v.to_law(None)
            else:
                out[name] = v
        return out

    def run(self, **runtime):
        """Run the test of this config: the test function called with :meth:`kwargs`;
        ``runtime``: keywords the schema does not hold (a ``sample`` object: an
        :class:`engine.prep.Sample`, a ``(model, state)`` pair, a result)."""
        from .. import experiments

        return getattr(experiments, self.TEST)(**{**self.kwargs(), **runtime})


class CylinderConfig(TestConfig):
    """:func:`engine.experiments.cylinder_triaxial` (§3.3)."""
    TEST: ClassVar[str] = "cylinder_triaxial"
    solver: TriaxialSolver = TriaxialSolver()
    friction: CylinderFriction = CylinderFriction()
    preparation: CylinderPreparation = CylinderPreparation()
    loading: CylinderLoading = CylinderLoading()
    recording: CylinderRecording = CylinderRecording()


class BoxConfig(TestConfig):
    """:func:`engine.experiments.box_triaxial` (§3.2)."""
    TEST: ClassVar[str] = "box_triaxial"
    solver: TriaxialSolver = TriaxialSolver()
    friction: BoxFriction = BoxFriction()
    preparation: BoxPreparation = BoxPreparation()
    loading: BoxLoading = BoxLoading()
    recording: BoxRecording = BoxRecording()


class SlopeConfig(TestConfig):
    """:func:`engine.experiments.slope_deposit` (§3.1)."""
    TEST: ClassVar[str] = "slope_deposit"
    scale: float = Field(0.02, gt=0, le=10.0, description="sample size (1: the paper's)")
    solver: SlopeSolver = SlopeSolver()
    friction: SlopeFriction = SlopeFriction()
    preparation: SlopePreparation = SlopePreparation()
    loading: SlopeSettling = SlopeSettling()
    recording: SlopeRecording = SlopeRecording()


class DepositConfig(TestConfig):
    """:func:`engine.experiments.gravity_deposit` (§2.4)."""
    TEST: ClassVar[str] = "gravity_deposit"
    solver: DepositSolver = DepositSolver()
    friction: DepositFriction = DepositFriction()
    preparation: DepositPreparation = DepositPreparation()
    loading: Settling = Settling()
    recording: DepositRecording = DepositRecording()


class PulloutConfig(TestConfig):
    """:func:`engine.experiments.pullout_test` (a wire pulled out of a box of sand; not
    one of the paper's tests).  Its wire is one whose links carry tension (not "none" nor
    "loose"), its scale one whose box is at least 5 mean grain diameters wide
    (:func:`engine.prep.samples.pullout_box`)."""
    TEST: ClassVar[str] = "pullout_test"
    scale: float = Field(0.2, gt=0, le=10.0, description="sample size (1: a 10 x 6 x 6 mm box)")
    neighbour_contact: bool = Field(True, description="linked beads also touch like two "
                                                      "spheres (False: a slack link lets its "
                                                      "beads overlap, and the wire shortens "
                                                      "as the sand settles)")
    solver: Solver = Solver()
    friction: PulloutFriction = PulloutFriction()
    preparation: PulloutPreparation = PulloutPreparation()
    loading: PulloutLoading = PulloutLoading()
    recording: PulloutRecording = PulloutRecording()

    @field_validator("scale")
    @classmethod
    def _box_wide_enough(cls, v):
        from ..prep.samples import pullout_box

        pullout_box(v)          # ValueError "scale = ...: ... use scale >= ..."
        return v

    @field_validator("wire")
    @classmethod
    def _pulled_wire(cls, v):
        if isinstance(v, (NoWire, LooseWireSpec)):
            raise ValueError(f"wire = {v.law!r}: the pull-out test pulls on a wire whose "
                             f"links carry tension (elastic, rigid, elastic_rod, rigid_rod "
                             f"or brittle)")
        return v


#: The configs by test name.
CONFIGS: dict[str, type[TestConfig]] = {c.TEST: c for c in (
    CylinderConfig, BoxConfig, SlopeConfig, DepositConfig, PulloutConfig)}

#: Keywords of the tests that a run file's ``[parameters]`` does not set: the sample size
#: and seed (top level), the wire (``[wire]``) and the outputs.
NOT_PARAMETERS = ("scale", "seed", "wire", "wire_law", "neighbour_contact", "history",
                  "progress")

_FLAT: dict = {}


def flat_model(cls: type[TestConfig]) -> type[Strict]:
    """The flat model of ``cls``: one field per keyword of the test (but
    :data:`NOT_PARAMETERS`), with the parts' fields as they are (same defaults, bounds and
    descriptions) and ``anderson``, ``hot_sweeps`` for ``solver.acceleration``: the
    ``[parameters]`` table of ``nscd run`` files (:mod:`engine.experiments.params`)."""
    if cls in _FLAT:
        return _FLAT[cls]
    fields = {}
    for part in PARTS:
        for n, f in cls.model_fields[part].annotation.model_fields.items():
            if n in NOT_PARAMETERS:
                continue
            if n == "acceleration":
                fields.update(_ACCELERATION_KWARGS)
            else:
                fields[n] = (f.annotation, f)

    def together(self):
        problem = solver_conflict(self.hot_sweeps, self.anderson, self.relax, self.threads,
                                  getattr(self, "chain_solve", False),
                                  getattr(self, "contact_compliance", 0.0))
        if problem:
            raise ValueError(problem)
        return self

    name = cls.__name__.replace("Config", "Params")
    model = create_model(name, __base__=Strict, __module__="engine.experiments.params",
                         __validators__={"_together": model_validator(mode="after")(together)},
                         **fields)
    _FLAT[cls] = model
    return model


def config_of(test: str, config=None, **kw) -> TestConfig:
    """The config of test ``test``: ``config`` (a config of that test) or, for None, the one
    of the keywords ``kw`` (:meth:`TestConfig.from_kwargs`)."""
    cls = CONFIGS[test]
    if config is None:
        return cls.from_kwargs(**kw)
    if not isinstance(config, cls):
        raise InputError(f"{test}: config must be a {cls.__name__}, got {type(config).__name__}")
    return config
