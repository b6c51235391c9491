"""The parameters of the paper's tests, one validating model per test (issue 33 item 3).

Every keyword of :func:`~engine.experiments.cylinder_triaxial`, :func:`box_triaxial`,
:func:`slope_deposit` and :func:`gravity_deposit` that is a number, a bool or a choice has a
field here, with the function's default (tests/workbench/test_cli.py checks they agree)
and the range the code can honour.  The same bounds hold wherever a test is started:

* in Python, each test function checks its arguments first (:func:`check_args`), before
  any sample is built or kernel compiled;
* ``nscd run`` files validate their ``[parameters]`` table with these models
  (:mod:`workbench.cli`);
* ``nscd sweep`` grids check every case with :func:`check_args` before any case runs
  (:mod:`engine.sweep`).

The sample size ``scale`` (:func:`~engine.experiments.common.check_scale`), the seed
(:data:`SEED_LIMIT`) and the wire (``wire``, ``wire_law``, ``neighbour_contact``) are
checked beside these models; the outputs (``history``, ``progress``) are not numbers.
"""
from __future__ import annotations

from typing import Literal, Optional

from pydantic import ConfigDict, Field, ValidationError, model_validator

from ..checks import InputError, NumbersOnly, describe
from ..model import MAX_ITER_LIMIT, no_solver_conflict

__all__ = ["PARAMS", "STEP_LIMIT", "SEED_LIMIT", "check_args", "SolverParams",
           "TriaxialParams", "CylinderParams", "BoxParams", "SlopeParams", "DepositParams"]

#: Largest step count of the tests' integer parameters (steps, frames, intervals).
STEP_LIMIT = 10**9


class Strict(NumbersOnly):
    """Unknown fields refused; numbers and bools strictly typed (:class:`~engine.checks.NumbersOnly`)."""

    model_config = ConfigDict(extra="forbid")


class SolverParams(Strict):
    dt: float = Field(5e-5, gt=0, le=1e-2, description="time step [s]")
    theta: float = Field(0.5, ge=0.5, le=1.0)
    tol: float = Field(3e-4, gt=0, lt=1)
    max_iter: int = Field(1000, ge=1, le=MAX_ITER_LIMIT)
    relax: float = Field(1.0, gt=0, lt=2,
                         description="NLGS relaxation (> 1: over-relaxation, needs anderson "
                                     "= 0 and threads = 1)")
    anderson: int = Field(0, ge=0, le=16,
                          description="NLGS Anderson acceleration depth (0: none)")
    threads: int = Field(1, ge=1, le=64,
                         description="NLGS threads (2 pays on tens of thousands of contacts)")
    hot_sweeps: int | None = Field(None, ge=0, le=8,
                                   description="re-sweeps of the contacts that changed most "
                                               "after each NLGS sweep (needs anderson = 0; "
                                               "default 2, 0 when anderson > 0)")
    mu: float = Field(0.5, ge=0, le=10)
    mu_wire: float = Field(0.3, ge=0, le=10)
    max_nonconverged: float = Field(0.25, ge=0, le=1)
    record_every: int = Field(10, ge=1, le=STEP_LIMIT)
    frames: int = Field(100, ge=0, le=STEP_LIMIT)

    _hot_alone = model_validator(mode="after")(lambda self: no_solver_conflict(self))


SAMPLE_HELP = ("a history or checkpoint file whose last state the test starts from "
               "(None: the test builds its sample; in Python also an engine.prep.Sample or "
               "a (model, state) pair)")


class TriaxialParams(SolverParams):
    sample: Optional[str] = Field(None, description=SAMPLE_HELP)
    pressure: float = Field(15e3, gt=0, le=1e9, description="[Pa]")
    axial_strain: float = Field(0.05, gt=0, le=0.5)
    strain_rate: Optional[float] = Field(None, gt=0, le=1e3, description="[1/s]")
    target_I: float = Field(5e-4, gt=0, le=0.1)
    allow_dynamic: bool = False
    iso_max_steps: int = Field(4000, ge=1, le=STEP_LIMIT)
    iso_tol: float = Field(0.02, gt=0, lt=1,
                           description="the isotropic stage ends when the stresses are "
                                       "within this fraction of the pressure ...")
    iso_hold: int = Field(5, ge=1, le=STEP_LIMIT, description="... for this many checks in a row")
    ramp_steps: int = Field(400, ge=0, le=STEP_LIMIT, description="steps over which the pressure is raised")
    preparation: Literal["geometric", "paper"] = Field(
        "geometric", description="geometric: the sample as built; paper: relaxed under "
                                 "gravity in its mould first (§2.4), then confined")
    wire_density: Optional[float] = Field(None, gt=0, le=1e8,
                                          description="[m/m³] (None: the paper's)")
    bead_radius: Optional[float] = Field(None, gt=0, le=1e-2,
                                         description="[m] the wire's bead radius r_w "
                                                     "(None: the paper's)")
    wire_mode: Literal["isotropic", "orthotropic"] = Field(
        "isotropic", description="the wire's walk: Eq. 16, or Eq. 17 in horizontal layers")
    wire_prestrain: float = Field(0.0, ge=0, le=1, description=(
        "ε₀ set on every link at the start of the loading: L = g/(1+ε₀)"))
    deposit_steps: int = Field(6000, ge=1, le=STEP_LIMIT,
                               description="most steps of the paper preparation's deposit")


class CylinderParams(TriaxialParams):
    axial_strain: float = Field(0.1, gt=0, le=0.5)
    mu_wall: float = Field(0.5, ge=0, le=10, description="friction of the cylinder and plates")
    compaction_mu: Optional[float] = Field(None, ge=0.1, le=10,
                                           description="friction of the isotropic stage "
                                                       "(None: the test's own)")
    confine_every: int = Field(10, ge=1, le=STEP_LIMIT, description="steps between confinement updates")
    confinement: Literal["free_surface", "layer_crown"] = Field(
        "free_surface", description="free_surface: §3.3's membrane; layer_crown: LMGC90's "
                                    "3D membrane example")
    torus_strains: list[float] = [0.02, 0.05, 0.1]


class BoxParams(TriaxialParams):
    mu_wall: float = Field(0.0, ge=0, le=10, description="friction of the six walls")
    compaction_mu: Optional[float] = Field(None, ge=0, le=10,
                                           description="friction of the isotropic stage "
                                                       "(None: the test's own)")
    wall_mass: Optional[float] = Field(None, gt=0, le=1e6,
                                       description="[kg] (None: 0.2 x the sample's mass)")
    check_every: int = Field(10, ge=1, le=STEP_LIMIT, description="steps between isotropic-stage checks")


CHECKPOINT_HELP = ("[steps] a checkpoint (RUN.resume.h5) this often, and when Ctrl-C "
                   "stops the run (0: only then)")
RESUME_HELP = "go on from the checkpoint a stopped or killed run of the same file left"


class SlopeParams(SolverParams):
    sample: Optional[str] = Field(None, description=SAMPLE_HELP)
    tol: float = Field(1e-4, gt=0, lt=1)
    wire_density: Optional[float] = Field(None, gt=0, le=1e8, description="[m/m³]")
    steps: int = Field(4000, ge=1, le=STEP_LIMIT)
    ke_fraction: float = Field(1e-4, gt=0, lt=1)
    rubber_radius: float = Field(0.3e-3, gt=0, le=0.1)
    floor_extent: float = Field(5.0, gt=0, le=100)
    mu_floor: float = Field(0.8, ge=0, le=10)
    record_every: int = Field(20, ge=1, le=STEP_LIMIT)
    frames: int = Field(200, ge=0, le=STEP_LIMIT)
    checkpoint_every: int = Field(0, ge=0, le=STEP_LIMIT, description=CHECKPOINT_HELP)
    resume: bool = Field(False, description=RESUME_HELP)
    fit_degree: Optional[int] = Field(None, ge=1, le=11, description=(
        "degree of the heap's height regression whose steepest slope is the max slope "
        "(None: 1 for sand, 3 with a wire; the paper's TexSol(2): 8)"))


class DepositParams(SolverParams):
    dt: float = Field(1e-4, gt=0, le=1e-2, description="time step [s]")
    tol: float = Field(1e-4, gt=0, lt=1)
    sample: Literal["slope", "cylinder", "box"] = Field(
        "slope", description="the paper's sample relaxed in its mould")
    wire_density: Optional[float] = Field(None, gt=0, le=1e8,
                                          description="[m/m³] (None: the sample's own)")
    steps: int = Field(6000, ge=1, le=STEP_LIMIT)
    ke_fraction: float = Field(1e-4, gt=0, lt=1)
    mu_wall: float = Field(0.5, ge=0, le=10, description="friction of the mould")
    record_every: int = Field(20, ge=1, le=STEP_LIMIT)
    frames: int = Field(200, ge=0, le=STEP_LIMIT)
    checkpoint_every: int = Field(0, ge=0, le=STEP_LIMIT, description=CHECKPOINT_HELP)
    resume: bool = Field(False, description=RESUME_HELP)


PARAMS: dict[str, type[SolverParams]] = {"cylinder_triaxial": CylinderParams, "box_triaxial": BoxParams,
           "slope_deposit": SlopeParams, "gravity_deposit": DepositParams}


#: Seeds are 64-bit: numpy's generators take any integer >= 0, the histories store int64.
SEED_LIMIT = 2**63 - 1


def check_args(test: str, values: dict) -> None:
    """Check the arguments ``values`` (a test function's ``locals()`` on entry: keys that are
    not fields of the test's model are ignored) of paper test ``test`` against
    :data:`PARAMS`; raise :class:`~engine.checks.InputError` (a ValueError) naming, on one
    line, every field at fault, its value and the allowed range::

        cylinder_triaxial: pressure = 2e+09: must be a number in (0, 1e+09]
    """
    cls = PARAMS[test]
    given = {k: values[k] for k in cls.model_fields if k in values}
    if not isinstance(given.get("sample"), (str, type(None))):
        given.pop("sample")     # a Sample or a (model, state): engine.experiments.start
    problems = []
    try:
        cls(**given)
    except ValidationError as e:
        problems = [describe(err, cls) for err in e.errors()]
    for name in ("wire", "neighbour_contact", "progress"):   # the bools beside the model
        v = values.get(name, False)
        if not isinstance(v, bool):
            problems.append(f"{name} = {v!r}: must be true or false")
    seed = values.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= SEED_LIMIT:
        problems.append(f"seed = {seed!r}: must be an integer in [0, 2**63 - 1]")
    if problems:
        raise InputError(f"{test}: " + "; ".join(problems))
