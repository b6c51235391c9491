"""Analysis of a state (paper §3): pure functions ``(model, state, ...)`` -> arrays.

* :func:`weber_stress` — Eq. (18), sand / wire / total, principal values, mean pressure,
  equivalent stress ‖dev σ‖;
* :func:`best_fit_strain` — Eq. (19), principal, volumetric and deviatoric strains.

* :func:`force_network` — strong network, f/⟨f⟩ distribution, coordination number;
  :func:`wall_forces`, :func:`wall_stress` — force on and normal stress of each wall;
  :func:`box_strain`, :func:`cylinder_strain` — strains from wall distances or from a
  cylinder's outer particles;
* :func:`toroidal_map` — Weber stress on (r, z) torus cells (Fig. 13c);
* :func:`macro_stiffness` — H, the slope of the linear part of (ε_zz, σ_w^eq) (Table 2);
  :func:`loading_curves` — axial strain, q, p and the wire's stress per record of a
  triaxial test's history;
* :func:`solid_fraction` — the solid fraction of spheres in a cylinder region (each
  sphere's part inside);
* :func:`slope_profile` — h(r), floor pressure p(r), regressions, maximum slope (Fig. 10);
* :mod:`engine.analysis.wire` — wire length density, orientation tensor, direction
  histograms (Fig. 8-9), tortuosity (Fig. 7).
"""
from .curves import MacroStiffness, loading_curves, macro_stiffness
from .network import (ForceNetwork, box_strain, cylinder_strain, force_network, wall_forces,
                      wall_stress)
from .packing import solid_fraction, sphere_volume_in_cylinder
from .profiles import SlopeProfile, max_slope, slope_profile
from .strain import StrainResult, best_fit_strain
from .stress import StressResult, equivalent_stress, principal, weber_stress
from .torus import ToroidalMap, toroidal_map
from .wire import (WireStats, direction_histogram, length_density, orientation_tensor,
                   tortuosity, wire_chains, wire_length, wire_stats)

__all__ = ["weber_stress", "equivalent_stress", "principal", "StressResult", "best_fit_strain",
           "StrainResult", "force_network", "ForceNetwork", "wall_forces", "toroidal_map",
           "ToroidalMap", "macro_stiffness", "loading_curves", "MacroStiffness", "slope_profile", "SlopeProfile",
           "max_slope",
           "wall_stress", "box_strain", "cylinder_strain", "wire_chains", "wire_length",
           "length_density", "orientation_tensor", "direction_histogram", "tortuosity",
           "WireStats", "wire_stats", "solid_fraction", "sphere_volume_in_cylinder"]
