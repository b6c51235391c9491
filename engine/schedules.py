"""Drive values as data: how a pressure drive's pressure and area evolve, stored in the
static :class:`~engine.model.Model` (and so in a checkpoint or a history), with their
current values in the :class:`~engine.state.State` (``state.drive_pressure`` [Pa] and
``state.drive_area`` [m²], per body), which is what a step reads.

* :class:`Constant` — a value that never changes (a plain number given to
  :meth:`engine.Scene.drive` is one);
* :class:`Ramp` — from ``start`` to ``end`` over ``steps`` steps, updated every ``every``
  steps by the :class:`FollowSchedules` updater (the triaxial tests' pressure ramp);
* :class:`Servo` — a value an updater measures from the state between steps, e.g. the
  area of a wall that follows the sample (:class:`engine.drivers.BoxFaces`, the membrane's
  top plate in :class:`engine.drivers.MembraneUpdater`): the Model says who sets it, the
  State holds what it set.

A schedule is a small frozen dataclass: :func:`to_dict` / :func:`from_dict` turn it into
JSON and back (:mod:`engine.io`).  A Python callable given to :meth:`Scene.drive` still
works (a user's own law of time), but a checkpoint cannot hold it (:class:`engine.io.UnsavedCallable`).
"""
from __future__ import annotations

import math
import numbers
from dataclasses import asdict, dataclass

import numpy as np

from .trigger import Updater, as_trigger

__all__ = ["Constant", "Ramp", "Servo", "Schedule", "FollowSchedules", "SCHEDULES", "drive_values",
           "to_dict", "from_dict"]


def _finite(value, name: str, who: str) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real) \
            or not math.isfinite(value):
        raise ValueError(f"{who}: {name} must be a finite number, got {value!r}")
    return float(value)


def _count(value, name: str, who: str, least: int) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < least:
        raise ValueError(f"{who}: {name} must be an integer >= {least}, got {value!r}")
    return int(value)


class Schedule:
    """Base of the schedules: ``at(step)`` is the value for the steps after ``step``."""

    def at(self, step: int) -> float:  # pragma: no cover - abstract
        raise NotImplementedError


@dataclass(frozen=True)
class Constant(Schedule):
    """A value that never changes."""

    value: float

    def __post_init__(self):
        object.__setattr__(self, "value", _finite(self.value, "value", "Constant"))

    def at(self, step: int) -> float:
        return self.value


@dataclass(frozen=True)
class Ramp(Schedule):
    """From ``start`` to ``end`` linearly over ``steps`` steps from step ``origin``, then
    ``end``; held between updates ``every`` steps apart: the value after step s is
    start + (end − start) · min(1, n / steps), n = s − origin rounded down to a multiple of
    ``every`` (0 before ``origin``).  ``steps = 0``: ``end`` from the first update on."""

    start: float
    end: float
    steps: int
    every: int = 1
    origin: int = 0

    def __post_init__(self):
        for name in ("start", "end"):
            object.__setattr__(self, name, _finite(getattr(self, name), name, "Ramp"))
        object.__setattr__(self, "steps", _count(self.steps, "steps", "Ramp", 0))
        object.__setattr__(self, "every", _count(self.every, "every", "Ramp", 1))
        object.__setattr__(self, "origin", _count(self.origin, "origin", "Ramp", 0))

    def at(self, step: int) -> float:
        n = max(int(step) - self.origin, 0) // self.every * self.every
        return self.start + (self.end - self.start) * min(1.0, n / max(self.steps, 1))


@dataclass(frozen=True)
class Servo(Schedule):
    """A value an updater sets from the state between steps (``by`` names it, e.g.
    ``"box faces"``); ``initial`` is the value before it first runs (None: none; a step
    that reads it then stops with an error naming the drive and ``by``)."""

    by: str
    initial: float | None = None

    def __post_init__(self):
        if not isinstance(self.by, str) or not self.by:
            raise ValueError(f"Servo: by must name the updater that sets the value, got "
                             f"{self.by!r}")
        if self.initial is not None:
            object.__setattr__(self, "initial", _finite(self.initial, "initial", "Servo"))

    def at(self, step: int) -> float:
        return math.nan if self.initial is None else self.initial


#: The schedule types a file may name (:func:`from_dict`).
SCHEDULES = {c.__name__: c for c in (Constant, Ramp, Servo)}


def to_dict(schedule: Schedule) -> dict:
    """``{"type": name, **fields}`` (JSON)."""
    return {"type": type(schedule).__name__, **asdict(schedule)}


def from_dict(d: dict) -> Schedule:
    """The schedule :func:`to_dict` wrote; ValueError for an unknown type."""
    d = dict(d)
    cls = SCHEDULES.get(d.pop("type", None))
    if cls is None:
        raise ValueError(f"unknown schedule {d!r}: the types are {', '.join(SCHEDULES)}")
    return cls(**d)


def _initial(value, step: int) -> float:
    if isinstance(value, Schedule):
        return float(value.at(step))
    if value is None or callable(value):
        return 0.0                      # a callable is evaluated at each step instead
    return float(value)


def drive_values(model, state) -> tuple[np.ndarray, np.ndarray]:
    """``(state.drive_pressure, state.drive_area)``, (nb,) [Pa] and [m²]: the current
    pressure and area of each pressure-driven wall (0 elsewhere, and for a callable,
    evaluated at each step instead; nan for a :class:`~engine.schedules.Servo` no updater
    has set yet).  Made from the drives' schedules at ``state.step`` when
    the state has none (a state built by hand, or read from a file written before
    schedules)."""
    if state.drive_pressure is None or state.drive_area is None:
        n = model.n_bodies
        pressure, area = np.zeros(n), np.zeros(n)
        for d in model.drives:
            if d.kind == "pressure":
                pressure[d.body] = _initial(d.value, state.step)
                area[d.body] = _initial(d.area, state.step)
        state.drive_pressure, state.drive_area = pressure, area
    return state.drive_pressure, state.drive_area


class FollowSchedules(Updater):
    """The updater of the :class:`Ramp` (and :class:`Constant`) pressures of a model's
    pressure drives: every ``every`` steps (an int, or a callable ``step -> bool``),
    ``state.drive_pressure[b] = schedule.at(step)`` for each such drive (the others are
    left alone: a callable, a :class:`Servo`, or a drive switched to a velocity)."""

    def __init__(self, every=1):
        self.trigger = as_trigger(every, "FollowSchedules")

    def update(self, model, state) -> None:
        pressure, _ = drive_values(model, state)
        for d in model.drives:
            if d.kind == "pressure" and isinstance(d.value, (Ramp, Constant)):
                pressure[d.body] = d.value.at(state.step)
