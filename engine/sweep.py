"""Deprecated: the campaign code moved out of the engine, to the :mod:`campaign` package
(issue 32).  ``engine.sweep`` re-exports its public names (and, for old scripts, the
private helpers it had) and warns on import; use ``from campaign import sweep, ...``."""
from __future__ import annotations

import warnings

from campaign import *  # noqa: F401,F403  (the public names, __all__ below)
from campaign import __all__  # noqa: F401

warnings.warn("engine.sweep is deprecated: the campaign code moved to the 'campaign' package "
              "(from campaign import sweep, load_table, ...)", DeprecationWarning, stacklevel=2)

#: Names engine.sweep had outside __all__: where they are now (module, name).
_MOVED = {
    "TABLE_VERSION": ("campaign.table", "TABLE_VERSION"),
    "write_hdf5": ("campaign.table", "write_hdf5"),
    "_result_row": ("campaign.table", "result_row"),
    "_write_json": ("campaign.table", "write_json"),
    "_scalar": ("campaign.table", "_scalar"),
    "_experiment_name": ("campaign.cases", "experiment_name"),
    "_plain": ("campaign.cases", "_plain"),
    "_law": ("campaign.experiments", "_law"),
    "_paper_test": ("campaign.experiments", "_paper_test"),
    "_history_path": ("campaign.experiments", "_history_path"),
    "_check_paper_cases": ("campaign.experiments", "check_paper_cases"),
    "_resolve": ("campaign.experiments", "resolve"),
    "REPORT_EVERY": ("campaign.runner", "REPORT_EVERY"),
    "TOPIC": ("campaign.runner", "TOPIC"),
    "_reporter": ("campaign.runner", "_reporter"),
    "_error_text": ("campaign.runner", "_error_text"),
    "_run_dask": ("campaign.runner", "_run_dask"),
    "_ignore_ctrl_c_plugin": ("campaign.clusters", "_ignore_ctrl_c_plugin"),
}


def __getattr__(name):
    try:
        module, attr = _MOVED[name]
    except KeyError:
        raise AttributeError(f"module 'engine.sweep' has no attribute {name!r} (it moved to "
                             f"the 'campaign' package)") from None
    import importlib

    return getattr(importlib.import_module(module), attr)
