"""nscd-workbench engine: 3D Non-Smooth Contact Dynamics of rigid spheres and walls.

Public API (DESIGN.md §5)::

    from engine import Scene, laws, run, step
    model, state = Scene(...).compile(dt=..., theta=..., tol=..., max_iter=...)
    stats = step(model, state); summary = run(model, state, steps, writers, progress)
    run(model, state, steps, writers=[...], updaters=[...], until=...)   # engine.step

Between-step actions are updaters (:mod:`engine.trigger`); drive values are schedules
(:mod:`engine.schedules`), their current values in the State.

No VTK or PyVista is imported anywhere in this package.
"""
from . import laws
from .model import Model, Options
from .scene import Scene
from .state import State, StepStats
from .step import RunSummary, SimulationError, run, step

__all__ = ["Scene", "laws", "run", "step", "Model", "State", "Options", "StepStats",
           "RunSummary", "SimulationError"]
__version__ = "0.1.0"
