"""The runs of a report: their names and their parameters (:func:`catalogue`).  Which of
them a report makes is the union of the runs its claims read (:func:`.registry.cases_for`)."""
from __future__ import annotations

from .scales import R_MIN_BOX, Scale, _fmt_k, fig10_seeds

TAGS10 = ("sand", "w400", "w800")        # the slope heaps of Fig. 10
TAGS14 = ("sand", "k0.2", "rigid")       # the cylinders of Fig. 14
#: The controls beside Fig. 14 (docs/reinforcement.md): the TexSol samples' sand laid around
#: their beads and tested without them, and the TexSol sample with its links loose.
TAGS14_PARTS = ("matched", "loose")


def deposits(scale: Scale) -> list:
    """The deposits in the mould (Fig. 7), one per Fig. 10 seed."""
    return [f"deposit_w400_seed{sd}" for sd in fig10_seeds(scale)]


def slopes(scale: Scale) -> list:
    """The slope deposits of Fig. 10: sand, 400 and 800 km·m⁻³ on each seed."""
    return [f"slope_{tag}_seed{sd}" for sd in fig10_seeds(scale) for tag in TAGS10]


def boxes(scale: Scale, divisions=(1, 3, 4)) -> list:
    """The box triaxials of Fig. 11-12 (r_w = r_min / division) on every seed."""
    return [f"box_rw{d}_seed{sd}" for sd in scale.fig14_seeds for d in divisions]


def tags15(scale: Scale) -> list:
    """The cylinders of Fig. 15-16 (seed 0): each k of the scale, and the rigid wire."""
    return [f"k{_fmt_k(k)}" for k in scale.k_list] + ["rigid"]


def cylinders(scale: Scale, tags, seeds=(0,)) -> list:
    """Cylinder triaxials by wire tag ("sand", "k0.2", "rigid", …), tag by tag."""
    return [f"cylinder_{tag}_seed{sd}" for tag in tags for sd in seeds]


def catalogue(scale: Scale) -> dict:
    """{name: case} of every run a report at ``scale`` may make, in the order they run: the
    JSON-able parameters of :func:`.runner.paper_case`, each with its ``name`` (the run's
    file stem).  A run that several claims read (the cylinder with k = 1 N of Fig. 13 is
    also Table 2's) appears once."""
    cases = {}
    for seed in fig10_seeds(scale):                          # Fig. 7 (§2.4), in the mould
        _add(cases, dict(test="gravity_deposit", name=f"deposit_w400_seed{seed}",
                         wire="elastic", k=1.0, seed=seed, **scale.deposit))
    for seed in fig10_seeds(scale):                          # Fig. 8-10 (10 on every seed)
        for wire, dens in (("none", None), ("elastic", 400e3), ("elastic", 800e3)):
            tag = "sand" if wire == "none" else f"w{int(dens / 1e3)}"
            _add(cases, dict(test="slope_deposit", name=f"slope_{tag}_seed{seed}", wire=wire,
                             k=1.0, wire_density=dens, seed=seed, **scale.slope))
    for s in [0] + [sd for sd in scale.fig14_seeds if sd != 0]:   # Fig. 11 and 12
        for div in (1, 3, 4):
            _add(cases, dict(test="box_triaxial", name=f"box_rw{div}_seed{s}", wire="elastic",
                             k=1.0, bead_radius=R_MIN_BOX / div, seed=s,
                             overlap_tol=TRIAXIAL_OVERLAP_TOL, **scale.box))
    for s in scale.fig14_seeds:                              # Fig. 13 (13c on every seed)
        _cylinder(cases, scale, "elastic", 1.0, s)
    for s in scale.fig14_seeds:                              # Fig. 14
        _cylinder(cases, scale, "none", None, s)
        _cylinder(cases, scale, "elastic", 0.2, s)
        _cylinder(cases, scale, "rigid", None, s)
    for s in scale.fig14_seeds:                              # beside Fig. 14: the controls
        _cylinder(cases, scale, "elastic", 1.0, s, tag="matched", remove_beads="after_deposit")
        _cylinder(cases, scale, "loose", None, s)
    for k in scale.k_list:                                   # Fig. 15-16, Table 2
        _cylinder(cases, scale, "elastic", k, 0)
    _cylinder(cases, scale, "rigid", None, 0)
    return cases


#: The position correction of every triaxial run of the report, box and cylinder (the
#: tests' own default now, passed explicitly so that the cases say it): see
#: :data:`engine.model.TRIAXIAL_OVERLAP_TOL`.
from engine.model import TRIAXIAL_OVERLAP_TOL  # noqa: E402


def _add(cases, case):
    cases.setdefault(case["name"], case)


def _cylinder(cases, scale, wire, k, seed, tag=None, **more):
    if tag is None:
        tag = ("sand" if wire == "none" else wire if wire in ("rigid", "loose")
               else f"k{_fmt_k(k)}")
    _add(cases, dict(test="cylinder_triaxial", name=f"cylinder_{tag}_seed{seed}", wire=wire,
                     k=(None if wire != "elastic" else float(k)), seed=seed,
                     overlap_tol=TRIAXIAL_OVERLAP_TOL, **scale.cylinder, **more))
