"""nscd-workbench outputs: ParaView series, PyVista pictures and matplotlib figures for engine runs.

Submodules are imported on first attribute access (module ``__getattr__``, PEP 562), so
``import workbench`` stays cheap and never imports VTK or PyVista:

* :mod:`workbench.meshes` — beads, wire links, contact force lines and walls as arrays
  (:class:`~workbench.meshes.Part`) and as :class:`pyvista.PolyData`;
* :mod:`workbench.series` — :class:`~workbench.series.SeriesWriter`, VTU per frame +
  PVD collection (written with meshio), usable as an :func:`engine.run` writer;
* :mod:`workbench.render` — off-screen PyVista pictures,
  :func:`~workbench.render.snapshot` with presets ``beads``, ``wire``, ``forces``, ``torus``;
* :mod:`workbench.figures` — matplotlib figures (Agg, no pyplot), e.g.
  :func:`~workbench.figures.deposit_figure`;
* :mod:`workbench.view` — the interactive viewer (trame): ``nscd view``,
  :func:`~workbench.view.show` in Jupyter (docs/view.md);
* :mod:`workbench.units` — units chosen for reading (mN, µm/s, kPa);
* :mod:`workbench.campaign` — many runs at once: parameter grids on Dask (a LocalCluster,
  a scheduler, a batch cluster by name), the results table, resume.
"""
from __future__ import annotations

import importlib

_SUBMODULES = ("meshes", "series", "render", "figures", "view", "units", "campaign")

__all__ = list(_SUBMODULES)


def __getattr__(name: str):
    if name in _SUBMODULES:
        module = importlib.import_module(f"{__name__}.{name}")
        globals()[name] = module
        return module
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_SUBMODULES))
