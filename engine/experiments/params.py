"""The flat parameter models of the paper's tests, derived from their configuration schema
(:mod:`engine.experiments.config`, issue 32 §1).

One model per test, one field per keyword argument of the test function that is a number, a
bool or a choice (not the sample size, the seed, the wire and the outputs: a run file sets
them elsewhere): the ``[parameters]`` table of ``nscd run`` files (:mod:`workbench.cli`).
Each is :func:`~engine.experiments.config.flat_model` of the test's config, so its defaults,
bounds and descriptions are the config's parts' own (tests/workbench/test_cli.py checks that
they are the functions' defaults); ``anderson`` and ``hot_sweeps`` stand for the config's
``solver.acceleration``.

:func:`check_args` checks a test's keywords as :meth:`~engine.experiments.config.TestConfig.from_kwargs`
does (it is that call, its config dropped).
"""
from __future__ import annotations

from .config import (SEED_LIMIT, STEP_LIMIT, BoxConfig, CylinderConfig, DepositConfig,
                     PulloutConfig, SlopeConfig, Strict, TestConfig, flat_model)

__all__ = ["PARAMS", "STEP_LIMIT", "SEED_LIMIT", "check_args", "SolverParams",
           "TriaxialParams", "CylinderParams", "BoxParams", "SlopeParams", "DepositParams",
           "PulloutParams"]

CylinderParams = flat_model(CylinderConfig)
BoxParams = flat_model(BoxConfig)
SlopeParams = flat_model(SlopeConfig)
DepositParams = flat_model(DepositConfig)
PulloutParams = flat_model(PulloutConfig)
#: The base of the flat models (the names of the models these replaced, kept for imports).
SolverParams = TriaxialParams = Strict

PARAMS: dict[str, type[Strict]] = {"cylinder_triaxial": CylinderParams,
                                   "box_triaxial": BoxParams, "slope_deposit": SlopeParams,
                                   "gravity_deposit": DepositParams,
                                   "pullout_test": PulloutParams}

_CONFIGS = {"cylinder_triaxial": CylinderConfig, "box_triaxial": BoxConfig,
            "slope_deposit": SlopeConfig, "gravity_deposit": DepositConfig,
            "pullout_test": PulloutConfig}


def check_args(test: str, values: dict) -> TestConfig:
    """Check the arguments ``values`` (a test function's keywords: keys that are not its
    keywords are ignored) of paper test ``test``; raise :class:`~engine.checks.InputError`
    (a ValueError) naming, on one line, every field at fault, its value and the allowed
    range::

        cylinder_triaxial: pressure = 2e+09: must be a number in (0, 1e+09]

    Returns the test's config (:meth:`~engine.experiments.config.TestConfig.from_kwargs`)."""
    cls = _CONFIGS[test]
    keys = cls.keywords()
    return cls.from_kwargs(**{k: v for k, v in values.items() if k in keys})
