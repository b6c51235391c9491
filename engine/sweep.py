"""Deprecated: the campaign code moved out of the engine, to the :mod:`workbench.campaign` package
(issue 32).  ``engine.sweep`` re-exports its public names (and, for old scripts, the
private helpers it had) and warns on import; use ``from workbench.campaign import sweep, ...``."""
from __future__ import annotations

import warnings

from workbench.campaign import *  # noqa: F401,F403  (the public names, __all__ below)
from workbench.campaign import __all__  # noqa: F401

warnings.warn("engine.sweep is deprecated: the campaign code moved to the 'workbench.campaign' package "
              "(from workbench.campaign import sweep, load_table, ...)", DeprecationWarning, stacklevel=2)

#: Names engine.sweep had outside __all__: where they are now (module, name).
_MOVED = {
    "TABLE_VERSION": ("workbench.campaign.table", "TABLE_VERSION"),
    "write_hdf5": ("workbench.campaign.table", "write_hdf5"),
    "_result_row": ("workbench.campaign.table", "result_row"),
    "_write_json": ("workbench.campaign.table", "write_json"),
    "_scalar": ("workbench.campaign.table", "_scalar"),
    "_experiment_name": ("workbench.campaign.cases", "experiment_name"),
    "_plain": ("workbench.campaign.cases", "_plain"),
    "_law": ("workbench.campaign.experiments", "_law"),
    "_paper_test": ("workbench.campaign.experiments", "_paper_test"),
    "_history_path": ("workbench.campaign.experiments", "_history_path"),
    "_check_paper_cases": ("workbench.campaign.experiments", "check_paper_cases"),
    "_resolve": ("workbench.campaign.experiments", "resolve"),
    "REPORT_EVERY": ("workbench.campaign.runner", "REPORT_EVERY"),
    "TOPIC": ("workbench.campaign.runner", "TOPIC"),
    "_reporter": ("workbench.campaign.runner", "_reporter"),
    "_error_text": ("workbench.campaign.runner", "_error_text"),
    "_run_dask": ("workbench.campaign.runner", "_run_dask"),
    "_ignore_ctrl_c_plugin": ("workbench.campaign.clusters", "_ignore_ctrl_c_plugin"),
}


def __getattr__(name):
    try:
        module, attr = _MOVED[name]
    except KeyError:
        raise AttributeError(f"module 'engine.sweep' has no attribute {name!r} (it moved to "
                             f"the 'workbench.campaign' package)") from None
    import importlib

    return getattr(importlib.import_module(module), attr)
