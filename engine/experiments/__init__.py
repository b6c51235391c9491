"""The paper's deposit under gravity (§2.4) and its three mechanical tests (§3.1-3.3), each
a function with the paper's parameters as defaults and a ``scale`` argument (1 = the
paper's size; the default a small size), recording an HDF5 history
(:class:`engine.io.History`) and returning its curves (:class:`TestResult`,
:class:`SlopeResult`, :class:`DepositResult`).

* :func:`gravity_deposit` — §2.4, Fig. 7: a geometric sample relaxed in its mould;
* :func:`slope_deposit` — §3.1, Fig. 8-10;
* :func:`box_triaxial` — §3.2, Fig. 11-12;
* :func:`cylinder_triaxial` — §3.3, Fig. 13-16, Table 2;
* :func:`pullout_test` — not in the paper: a straight wire pulled out of a box of sand
  under a vertical stress, its apparent friction μ* (:class:`PulloutResult`, docs/pullout.md).

Each test has one configuration schema (:mod:`engine.experiments.config`:
:class:`CylinderConfig`, :class:`BoxConfig`, :class:`SlopeConfig`, :class:`DepositConfig`,
:class:`PulloutConfig`),
which the function builds from its keyword arguments first; ``config.run()`` runs the test
of a config.
"""
from .common import ConfinementError, ConvergenceError, TestResult, inertial_number, inertial_rate
from .config import BoxConfig, CylinderConfig, DepositConfig, PulloutConfig, SlopeConfig
from .deposit import DepositResult, gravity_deposit
from .pullout import PulloutResult, pullout_test
from .slope import SlopeResult, slope_deposit
from .triaxial import box_triaxial, cylinder_triaxial

__all__ = ["gravity_deposit", "DepositResult", "slope_deposit", "box_triaxial",
           "cylinder_triaxial", "TestResult", "SlopeResult", "ConvergenceError",
           "ConfinementError", "inertial_rate", "inertial_number", "CylinderConfig",
           "BoxConfig", "SlopeConfig", "DepositConfig", "pullout_test", "PulloutResult",
           "PulloutConfig"]
