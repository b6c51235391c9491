"""Analysis of a state (paper §3): pure functions ``(model, state, ...)`` -> arrays.

* :func:`weber_stress` — Eq. (18), sand / wire / total, principal values, mean pressure,
  equivalent stress ‖dev σ‖;
* :func:`best_fit_strain` — Eq. (19), principal, volumetric and deviatoric strains.

Force chains, toroidal maps, slope profiles, boundary measures and the macro-stiffness H
come with the rest of the analysis issue.
"""
from .strain import StrainResult, best_fit_strain
from .stress import StressResult, equivalent_stress, principal, weber_stress

__all__ = ["weber_stress", "equivalent_stress", "principal", "StressResult", "best_fit_strain",
           "StrainResult"]
