"""Sample preparation (paper §2.4).

* :mod:`~engine.prep.granulometry` — grain radii (uniform in diameter by number or by
  volume, two-size mixes);
* :func:`random_walk` — the wire, bead by bead (Eq. 16-17); :func:`helix` — a helical wire
  about a cylinder's axis (not in the paper: a positive control);
* :func:`geometric` — the 3D geometric deposit of the sand around the wire;
* :func:`relax` — a deposit under gravity until the kinetic energy has died out;
* :func:`paper_sample` — the paper's cylinder, box and slope samples at a scale factor;
* :func:`pullout_sample` — a straight wire through a box of sand (the pull-out test's);
* :class:`Box`, :class:`Cylinder`, :class:`Sphere` — containers (also analysis regions).
"""
from . import granulometry
from .containers import Box, Cylinder, Sphere, TorusCell
from .deposit import DepositError, geometric
from .relax import RelaxReport, kinetic_energy, relax
from .samples import (PAPER, PULLOUT, Sample, box_sample, cylinder_sample, paper_sample,
                      pullout_sample, slope_sample)
from .wire import KM_PER_M3, helix, random_walk

__all__ = ["Box", "Cylinder", "Sphere", "TorusCell", "granulometry", "random_walk", "helix",
           "KM_PER_M3",
           "geometric", "DepositError", "relax", "RelaxReport", "kinetic_energy", "Sample",
           "paper_sample", "cylinder_sample", "box_sample", "slope_sample", "PAPER",
           "PULLOUT", "pullout_sample"]
