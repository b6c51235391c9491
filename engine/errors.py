"""Every error and warning type of the engine, in one module that imports nothing of it
(so any layer may raise them without an import circle).

The modules that raised them first keep their names (``engine.step.SimulationError``,
``engine.io.FormatError``, ``engine.checks.InputError``, ...): they are these classes.

Errors (what a user catches):

- :class:`InputError` (``ValueError``): a validated record refused its input.
- :class:`SimulationError` (``RuntimeError``): a non-finite value in a run.
- :class:`ConvergenceError` (``RuntimeError``): too many steps of a test did not converge.
- :class:`ConfinementError` (``RuntimeError``): a free-surface confinement lost its sample.
- :class:`DepositError` (``ValueError``): a geometric deposit could not place every grain.
- :class:`FormatError` (``ValueError``): not a readable nscd-workbench HDF5 file.
- :class:`FileProblem` (``OSError``) and its kinds :class:`WriteFailed` (a full disk, a
  quota, an I/O error) and :class:`RunLocked` (another process writes the history).

Warnings: :class:`NonConvergenceWarning` (steps at ``max_iter``) and
:class:`PhysicsWarning` (a run left the range where its results can be trusted).
"""
from __future__ import annotations

import os

__all__ = ["InputError", "SimulationError", "ConvergenceError", "ConfinementError",
           "DepositError", "FormatError", "FileProblem", "WriteFailed", "RunLocked",
           "NonConvergenceWarning", "PhysicsWarning"]


class InputError(ValueError):
    """A validated record refused its input; the message names every field at fault."""


class SimulationError(RuntimeError):
    """The simulation produced a non-finite value (step and bodies named)."""


class ConvergenceError(RuntimeError):
    """Too many steps of a test did not converge; ``result`` holds what was recorded."""

    def __init__(self, message, result):
        super().__init__(message)
        self.result = result


class ConfinementError(RuntimeError):
    """A free-surface confinement lost its sample: grains left the membrane and its radius
    ran away (:class:`engine.drivers.Confinement`'s ``max_growth``)."""


class DepositError(ValueError):
    """The container could not take every grain.

    Attributes ``placed`` (number of grains placed), ``centers`` (placed, 3) [m] and
    ``radii`` (placed,) [m] hold what was placed, in placement order."""

    def __init__(self, message, placed, centers, radii):
        super().__init__(message)
        self.placed, self.centers, self.radii = placed, centers, radii


class FormatError(ValueError):
    """The file is not a readable nscd-workbench HDF5 file of a supported version."""


class FileProblem(OSError):
    """An OSError whose ``str()`` is one line: ``FILE: what happened`` (the base of
    :class:`WriteFailed` and :class:`RunLocked`, which ``nscd`` tells apart: exit 1 and 2)."""

    def __str__(self) -> str:
        return f"{self.filename}: {self.strerror}"


class WriteFailed(FileProblem):
    """A file could not be written: a full disk (``errno.ENOSPC``), a quota, an I/O error.

    Raised by :class:`engine.io.History` (which then stops writing: the file keeps, marked
    complete, every record and frame of its last successful flush) and by
    :func:`engine.io.save` (the older checkpoint is kept).  ``str()`` is one line naming the
    file and the cause."""

    def __init__(self, path, errno_: int | None, what: str):
        super().__init__(errno_, what, os.fspath(path))


class RunLocked(FileProblem):
    """Another process is writing this history (its lock, ``.NAME.lock``, is held)."""


class NonConvergenceWarning(RuntimeWarning):
    """Some steps of a run hit ``max_iter`` before the NLGS residual reached ``tol``."""


class PhysicsWarning(RuntimeWarning):
    """A run left the range where its results can be trusted (overlaps above
    :data:`engine.sanity.OVERLAP_WARN`)."""
