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

Wire laws (point–point links between consecutive beads, Eq. 7–15) belong to the wire
issue; their codes are reserved here so that contacts and links share one table.
"""
from __future__ import annotations

from typing import ClassVar

from pydantic import BaseModel, ConfigDict, Field

#: Law codes seen by the kernels.
COULOMB = 0
RIGID_ROD = 1
ELASTIC_ROD = 2
RIGID_WIRE = 3
ELASTIC_WIRE = 4

#: Width of the parameter row of every law.
N_PARAM = 4


class Law(BaseModel):
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
        Friction coefficient [-], ``mu >= 0`` (0 = frictionless).

    Notes
    -----
    Local problem of Eq. (5)-(6) extended to friction: with ``u`` the relative velocity
    in the local frame (n, t, s) at the end of the step and ``p`` the impulse,
    ``0 <= u_n + max(g_m, 0)/h ⊥ p_n >= 0`` and ``‖p_t‖ <= μ p_n`` with ``p_t = -λ u_t`` when
    sliding (see :mod:`engine.solver.local`).
    """

    code: ClassVar[int] = COULOMB
    mu: float = Field(ge=0.0, description="friction coefficient [-]")

    def params(self) -> tuple[float, ...]:
        return (self.mu, 0.0, 0.0, 0.0)


__all__ = ["Law", "Coulomb", "COULOMB", "RIGID_ROD", "ELASTIC_ROD", "RIGID_WIRE",
           "ELASTIC_WIRE", "N_PARAM"]
