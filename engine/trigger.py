"""Triggers and updaters, the between-steps operations of :func:`engine.step.run`.

A trigger is a boolean function of the step number (HOOMD-blue's ``hoomd.trigger``); an
updater is an object with a ``trigger`` and ``update(model, state)`` that :func:`run` calls
after the writers of each step the trigger fires on (:mod:`engine.step` has the order).
This module imports nothing of the engine, so that the drives' updaters
(:mod:`engine.drivers`, :mod:`engine.schedules`) can build on it.
"""
from __future__ import annotations

from typing import Callable

import numpy as np

__all__ = ["every", "as_trigger", "Updater", "CallbackUpdater"]


def every(n: int) -> Callable[[int], bool]:
    """Trigger firing every ``n`` steps (on step numbers that are multiples of n)."""
    if int(n) < 1:
        raise ValueError(f"every(n): n must be >= 1, got {n!r}")
    n = int(n)
    return lambda s: s % n == 0


class Updater:
    """A between-steps action: ``update(model, state)`` when ``trigger(step)`` fires, after
    the step's writers (the module docstring has the order).  A subclass sets ``trigger``
    (an int n: every n steps, :func:`every`; or a callable ``step -> bool``) and defines
    :meth:`update`; any object with ``trigger(step) -> bool`` and ``update(model, state)``
    (and optionally ``start(model, state)``, called before a run's first step) is an
    updater.  An updater changes the state only (``state.load``, the drive values, ...),
    never the model: a stage that needs another model (a drive switched, other friction)
    is another :func:`~engine.step.run` call."""

    trigger: Callable[[int], bool]

    def update(self, model, state) -> None:  # pragma: no cover - abstract
        raise NotImplementedError


class CallbackUpdater(Updater):
    """An updater calling ``fn(model, state)`` when ``trigger(step)`` fires (an int n: every
    n steps)."""

    def __init__(self, fn: Callable, trigger: Callable[[int], bool] | int = 1):
        if not callable(fn):
            raise ValueError(f"CallbackUpdater: fn must be a callable (model, state), got {fn!r}")
        self.fn = fn
        self.trigger = as_trigger(trigger, "CallbackUpdater")

    def update(self, model, state) -> None:
        self.fn(model, state)


def as_trigger(trigger, who: str) -> Callable[[int], bool]:
    if isinstance(trigger, (int, np.integer)) and not isinstance(trigger, bool):
        return every(trigger)
    if not callable(trigger):
        raise ValueError(f"{who}: trigger must be an int >= 1 (every n steps) or a callable "
                         f"step -> bool, got {trigger!r}")
    return trigger


