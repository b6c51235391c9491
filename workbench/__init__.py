"""nscd-workbench outputs: ParaView series and matplotlib figures for engine runs.

Submodules are imported on first attribute access (module ``__getattr__``, PEP 562), so
``import workbench`` stays cheap and never imports VTK or PyVista:

* :mod:`workbench.series` — :class:`~workbench.series.SeriesWriter`, VTU per frame +
  PVD collection (written with meshio), usable as an :func:`engine.run` writer;
* :mod:`workbench.figures` — matplotlib figures (Agg, no pyplot), e.g.
  :func:`~workbench.figures.deposit_figure`.
"""
from __future__ import annotations

import importlib

_SUBMODULES = ("series", "figures")

__all__ = list(_SUBMODULES)


def __getattr__(name: str):
    if name in _SUBMODULES:
        module = importlib.import_module(f"{__name__}.{name}")
        globals()[name] = module
        return module
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_SUBMODULES))
