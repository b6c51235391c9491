"""The cases of a campaign and their keys.

A case is one call ``experiment(**params, **fixed)``; its parameters are JSON-able (numbers,
strings, booleans, None, lists) because they are its key in the results table.
"""
from __future__ import annotations

import hashlib
import itertools
import json
import math
from typing import Mapping

import numpy as np

__all__ = ["expand_grid", "case_key", "case_id", "experiment_name"]


def expand_grid(grid) -> list[dict]:
    """The cases of a grid.

    ``grid`` is either a mapping ``{name: [values...]}`` (the Cartesian product, in the
    order of the mapping; a scalar value counts as a one-value list) or a sequence of
    mappings (explicit cases, taken as they are).  Duplicated cases are kept once.
    """
    if isinstance(grid, Mapping):
        names = list(grid)
        values = [v if isinstance(v, (list, tuple, np.ndarray)) else [v] for v in grid.values()]
        cases = [dict(zip(names, combo)) for combo in itertools.product(*values)]
    elif isinstance(grid, (list, tuple)):
        cases = []
        for c in grid:
            if not isinstance(c, Mapping):
                raise ValueError(f"grid: a list of cases must hold mappings, got {c!r}")
            cases.append(dict(c))
    else:
        raise ValueError(f"grid must be a mapping of lists or a list of mappings, got {type(grid)}")
    out, seen = [], set()
    for c in cases:
        c = {k: _plain(v, k) for k, v in c.items()}
        key = case_key("", c)
        if key not in seen:
            seen.add(key)
            out.append(c)
    return out


def _plain(v, name):
    """A JSON-able copy of a parameter value (numpy scalars to Python)."""
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, (list, tuple, np.ndarray)):
        return [_plain(x, name) for x in v]
    if v is None or isinstance(v, (bool, int, str)):
        return v
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ValueError(f"parameter {name!r}: {v!r} is not finite")
        return v
    raise ValueError(f"parameter {name!r}: {v!r} is not JSON-able (numbers, strings, booleans, "
                     f"None, lists); pass objects through fixed= or build them in the experiment")


def experiment_name(experiment) -> str:
    """The name an experiment has in the table: the name of a paper test, or the module and
    qualified name of a function."""
    if isinstance(experiment, str):
        return experiment
    mod = getattr(experiment, "__module__", None) or "?"
    return f"{mod}.{getattr(experiment, '__qualname__', repr(experiment))}"


def case_key(experiment, params: Mapping) -> str:
    """The key of a case in the table: the experiment's name and the parameters as
    canonical JSON (sorted keys), so the same parameters given in any order match."""
    return json.dumps({"experiment": experiment_name(experiment), "params": params},
                      sort_keys=True, separators=(",", ":"))


def case_id(experiment, params: Mapping) -> str:
    """A short, file-name-safe id of a case (experiment name + 10 hex digits of the key)."""
    name = experiment_name(experiment).rsplit(".", 1)[-1]
    return f"{name}-{hashlib.sha1(case_key(experiment, params).encode()).hexdigest()[:10]}"
