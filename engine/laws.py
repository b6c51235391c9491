"""Interaction laws as data.

A law is a small frozen, validated record: an integer ``code`` that the NLGS kernel
branches on and a row of float parameters (``params``).  No class hierarchy reaches the
kernels (DESIGN.md §3): :meth:`Scene.compile` turns the laws declared with
:meth:`Scene.interact` into the columns ``law_code (nlaw,) int16`` and
``law_param (nlaw, 4) float64`` of the :class:`~engine.model.Model`.

Contact laws (between bodies that touch):

``Coulomb(mu)``
    Signorini unilateral contact (Eq. 6, at velocity level with the gap prediction of
    the θ-method) with 3D Coulomb friction ‖p_t‖ ≤ μ p_n.  ``mu = 0`` is frictionless.

Wire laws (point–point links between consecutive beads of :meth:`Scene.add_wire`, normal
direction only, no tangential reaction; Eq. 7–15).  With L = g_ref = g(0)/(1+ε₀) the
reference length (Eq. 7; ε₀ > 0 starts the wire in tension), k the stiffness [N] (force per
unit strain) and T the tension [N] (positive in tension):

``RigidRod()``                       g = L, T of any sign (Eq. 7, 9)
``ElasticRod(stiffness, prestrain)``  T = k (g − L)/L, any sign (Eq. 10-11)
``RigidWire()``                      g <= L, T >= 0, T (L − g) = 0 (Eq. 12-13)
``ElasticWire(stiffness, prestrain)`` T = k max(g − L, 0)/L (Eq. 14-15)
``BrittleElasticWire(stiffness, prestrain, max_tension)``
    an elastic wire whose link breaks for good once T exceeds ``max_tension``.
``LooseWire()``                      T = 0 always: the beads without their links' force
    (a control: the beads keep their masses, contacts and the linked pairs' exclusion from
    contact, so a sample with a loose wire differs from its TexSol twin by the links' force
    alone).

The rigid laws also take ``prestrain`` (their reference length is then g(0)/(1+ε₀)).
"""
from __future__ import annotations

from typing import ClassVar

import numpy as np
from pydantic import ConfigDict, Field

from .checks import Checked

#: Law codes seen by the kernels.
COULOMB = 0
RIGID_ROD = 1
ELASTIC_ROD = 2
RIGID_WIRE = 3
ELASTIC_WIRE = 4
LOOSE_WIRE = 5

#: Width of the parameter row of every law.
N_PARAM = 4


class Law(Checked):
    """Base of all laws: frozen, validated (a bad value raises ``ValueError``)."""

    model_config = ConfigDict(frozen=True, extra="forbid")
    code: ClassVar[int]

    def params(self) -> tuple[float, ...]:
        """Parameter row passed to the kernels (length :data:`N_PARAM`)."""
        raise NotImplementedError


class Coulomb(Law):
    """Signorini contact + 3D Coulomb friction.

    Parameters
    ----------
    mu : float
        Friction coefficient [-], ``mu >= 0`` (0 = frictionless, ``inf`` = perfectly rough:
        the tangential impulse is never bounded, contacts never slide); NaN is refused.

    Notes
    -----
    Local problem of Eq. (5)-(6) extended to friction: with ``u`` the relative velocity
    in the local frame (n, t, s) at the end of the step and ``p`` the impulse,
    ``0 <= u_n + max(g_m, 0)/h ⊥ p_n >= 0`` and ``‖p_t‖ <= μ p_n`` with ``p_t = -λ u_t`` when
    sliding (see :mod:`engine.solver.local`).
    """

    code: ClassVar[int] = COULOMB
    mu: float = Field(ge=0.0, description="friction coefficient [-] (inf: no sliding)")

    def params(self) -> tuple[float, ...]:
        return (self.mu, 0.0, 0.0, 0.0)


#: Largest prestrain ε₀ of a wire law: at 1 a link's reference length is half its initial
#: length.  Beyond, the reference length tends to 0 (g(0)/(1+ε₀)): ε₀ = 1e6 was accepted and
#: pulled a wire's beads onto one another (issue 33).
MAX_PRESTRAIN = 1.0


class WireLaw(Law):
    """Base of the point–point wire laws (Eq. 7-15): parameter row
    (stiffness [N] (inf = rigid), prestrain ε₀ [-], max_tension [N] (inf = unbreakable),
    unilateral flag (1 = wire: tension only, 0 = rod: any sign))."""

    prestrain: float = Field(0.0, gt=-1.0, le=MAX_PRESTRAIN, allow_inf_nan=False,
                             description="ε₀ of g_ref = g(0)/(1+ε₀) [-], in (-1, 1]")
    unilateral: ClassVar[bool]

    @property
    def stiffness_value(self) -> float:
        return float(getattr(self, "stiffness", np.inf))

    def params(self) -> tuple[float, ...]:
        return (self.stiffness_value, self.prestrain, float(getattr(self, "max_tension", np.inf)),
                1.0 if self.unilateral else 0.0)


class RigidRod(WireLaw):
    """Bilateral rigid link: g = g_ref, tension of any sign (Eq. 7, 9)."""

    code: ClassVar[int] = RIGID_ROD
    unilateral: ClassVar[bool] = False


class ElasticRod(WireLaw):
    """Bilateral elastic link: T = k (g − g_ref)/g_ref, any sign (Eq. 10-11).

    Parameters
    ----------
    stiffness : float [N], > 0 (force per unit strain)
    prestrain : float [-], in (-1, 1] (:data:`MAX_PRESTRAIN`)
    """

    code: ClassVar[int] = ELASTIC_ROD
    unilateral: ClassVar[bool] = False
    stiffness: float = Field(gt=0.0, allow_inf_nan=False, description="k [N], > 0")


class RigidWire(WireLaw):
    """Unilateral rigid link: g <= g_ref, T >= 0, complementary (Eq. 12-13)."""

    code: ClassVar[int] = RIGID_WIRE
    unilateral: ClassVar[bool] = True


class ElasticWire(WireLaw):
    """Unilateral elastic link: T = k max(g − g_ref, 0)/g_ref (Eq. 14-15).

    Parameters
    ----------
    stiffness : float [N], > 0
    prestrain : float [-], in (-1, 1] (:data:`MAX_PRESTRAIN`)
    """

    code: ClassVar[int] = ELASTIC_WIRE
    unilateral: ClassVar[bool] = True
    stiffness: float = Field(gt=0.0, allow_inf_nan=False, description="k [N], > 0")


class BrittleElasticWire(ElasticWire):
    """Elastic wire whose link breaks for good when its tension exceeds ``max_tension``.

    The break is decided at the end of a step on the step's converged tension; from the
    next step on the link carries nothing and its two beads touch like any two spheres.
    """

    max_tension: float = Field(gt=0.0, allow_inf_nan=False, description="[N], > 0")


class LooseWire(WireLaw):
    """A link that carries no force, ever (T = 0): the control "beads without links".

    Its stiffness is 0 (the limit k -> 0 of :class:`ElasticWire`); the solver skips such a
    link, so its impulse is exactly 0 at every step.  The two beads keep their exclusion
    from contact (as a linked pair of :meth:`engine.Scene.add_wire` with
    ``neighbour_contact=False``), so the contacts are those of the same sample with a
    working wire.
    """

    code: ClassVar[int] = LOOSE_WIRE
    unilateral: ClassVar[bool] = True
    prestrain: float = Field(0.0, ge=0.0, le=0.0, description="0: a loose wire has no "
                                                               "reference length to prestrain")

    @property
    def stiffness_value(self) -> float:
        return 0.0


#: The default stiffness k [N] of an elastic law named in a run file or a sweep grid (the
#: paper's ElasticWire(k = 1 N)).
DEFAULT_STIFFNESS = 1.0

#: Wire laws by the name run files and sweep grids give them ("none": sand only).
WIRE_LAWS = {"elastic": ElasticWire, "rigid": RigidWire, "elastic_rod": ElasticRod,
             "rigid_rod": RigidRod, "brittle": BrittleElasticWire, "loose": LooseWire}


def wire_law(name, *, stiffness=None, prestrain=None, max_tension=None) -> WireLaw | None:
    """The wire law called ``name`` (a key of :data:`WIRE_LAWS`, or ``"none"``: no wire,
    None), with its parameters: ``stiffness`` k [N] for the elastic laws (default
    :data:`DEFAULT_STIFFNESS`), ``max_tension`` [N] for ``"brittle"`` (required),
    ``prestrain`` ε₀ for every law.  A parameter the law does not have is refused by name
    (a stiffness given to the rigid wire was ignored before: issue 33)."""
    names = ", ".join(map(repr, [*WIRE_LAWS, "none"]))
    if not isinstance(name, str) or name not in (*WIRE_LAWS, "none"):
        raise ValueError(f"wire must be one of {names}, got {name!r}")
    given = {k: v for k, v in (("stiffness", stiffness), ("prestrain", prestrain),
                               ("max_tension", max_tension)) if v is not None}
    if name == "none":
        if given:
            raise ValueError("; ".join(f"{k} = {v!r}: the wire is 'none' (sand only)"
                                       for k, v in given.items()))
        return None
    cls = WIRE_LAWS[name]
    for field, v in given.items():
        if field not in cls.model_fields:
            elastic = [n for n, c in WIRE_LAWS.items() if field in c.model_fields]
            raise ValueError(f"{field} = {v!r}: the {name!r} wire has no {field} "
                             f"({', '.join(elastic)} only)")
    if "stiffness" in cls.model_fields:
        given.setdefault("stiffness", DEFAULT_STIFFNESS)
    if cls is BrittleElasticWire and "max_tension" not in given:
        raise ValueError("max_tension: required by the 'brittle' wire [N]")
    return cls(**given)


__all__ = ["wire_law", "WIRE_LAWS", "DEFAULT_STIFFNESS", "Law", "Coulomb", "WireLaw", "RigidRod", "ElasticRod", "RigidWire", "ElasticWire",
           "BrittleElasticWire", "LooseWire", "COULOMB", "RIGID_ROD", "ELASTIC_ROD",
           "RIGID_WIRE", "ELASTIC_WIRE", "LOOSE_WIRE", "N_PARAM"]
