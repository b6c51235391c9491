"""Compile the engine's numba kernels into numba's on-disk cache, in parallel processes.

The kernels are compiled at their first call (``cache=True``: once per machine and source,
then loaded in a fraction of a second).  On a fresh clone the first run of anything pays
that compilation: about 100 s for a cylinder test, most of it in two kernels (the NLGS loop
with re-sweeps, about 45 s, and the geometric deposit of the sample preparation, about
40 s), 45-60 s more for the chain solve of the wires.  Two test workers that start
together compiled the same kernels twice, side by side.

``python -m engine.warm`` runs small scenes that reach the common kernels, each in its own
process, ``--jobs`` at a time (default: the CPU count, at most 4), so that each kernel is
compiled once and the heavy ones side by side; later processes load them from the cache.
``make test`` and ``make demo`` run it first.  It changes no result: only when kernels are
compiled.  A scene that fails is reported and the others go on (exit 0: the kernels it
missed compile at their first call as before).
"""
from __future__ import annotations

import argparse
import os
import sys
import time
import warnings
from concurrent.futures import ProcessPoolExecutor, as_completed

__all__ = ["SCENES", "STAGES", "warm"]


def _deposit():
    """The geometric deposit of the sample preparation (cylinder and box samples)."""
    from .prep import box_sample, cylinder_sample

    cylinder_sample(0.05, seed=0)
    box_sample(0.05, seed=0)


def _scene(law, **options):
    """20 steps of two layers of grains on a floor with a 6-bead wire on them."""
    import numpy as np

    from . import Scene, laws, run

    s = Scene(gravity=(0.0, 0.0, -9.81))
    s.add_plane(point=(0, 0, 0), normal=(0, 0, 1), group="wall")
    r = 1e-3
    xy = np.array([[x, y] for x in range(4) for y in range(4)], float) * 2.05 * r
    centers = np.column_stack([xy, np.full(len(xy), r)])
    s.add_spheres(np.vstack([centers, centers + [0, 0, 2.05 * r]]), r, density=2650.0,
                  group="sand")
    s.add_wire([[k * 2.2 * 0.5e-3, 0, 5 * r] for k in range(6)], 0.5e-3, density=1400.0,
               law=law)
    s.interact("sand", "sand", laws.Coulomb(mu=0.5))
    s.interact("sand", "wall", laws.Coulomb(mu=0.5))
    s.interact("wire", "sand", laws.Coulomb(mu=0.3))
    s.interact("wire", "wall", laws.Coulomb(mu=0.3))
    s.interact("wire", "wire", None)
    model, state = s.compile(dt=5e-5, tol=3e-4, max_iter=200, **options)
    run(model, state, 20, progress=False)


def _solver_tests():
    """The NLGS path of the tests (re-sweeps of the hot contacts), an elastic wire, and the
    position correction."""
    from . import laws

    _scene(laws.ElasticWire(stiffness=1.0), hot_sweeps=2)
    _scene(laws.ElasticWire(stiffness=1.0), hot_sweeps=2, overlap_tol=0.005)


def _solver_scene():
    """The NLGS path of a user's scene (plain sweeps) and a rigid wire."""
    from . import laws

    _scene(laws.RigidWire())


def _chains():
    """The chain solve of the wires (``chain_solve=True``)."""
    from . import laws

    _scene(laws.RigidWire(), chain_solve=True)


def _triaxial():
    """A small cylinder triaxial test (membrane, pressure-driven plates, analysis)."""
    from .experiments import cylinder_triaxial

    cylinder_triaxial(0.05, axial_strain=0.001, progress=False)


#: The scenes in stages: a process each, ``jobs`` at a time in this order (the chain solve,
#: the longest to compile, first; the re-sweep loop last, once the contact detection and
#: the solve's set-up it shares with the plain sweeps are in the cache), the next stage
#: once they are all done (the triaxial test then only loads).
STAGES = (("chains", "deposit", "solver_scene", "solver_tests"), ("triaxial",))
SCENES = {"deposit": _deposit, "solver_tests": _solver_tests, "solver_scene": _solver_scene,
          "chains": _chains, "triaxial": _triaxial}


def _one(name):
    t = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")       # (small scenes: overlaps, rest not reached)
        SCENES[name]()
    return name, time.perf_counter() - t


def warm(jobs: int | None = None, quiet: bool = False) -> dict:
    """Run the scenes of :data:`STAGES`, ``jobs`` processes at a time; returns
    {name: seconds, or the error's one line}."""
    jobs = jobs or min(4, os.cpu_count() or 1)
    out = {}
    with ProcessPoolExecutor(max_workers=jobs) as pool:
        for stage in STAGES:
            futures = {pool.submit(_one, n): n for n in stage}
            for f in as_completed(futures):
                n = futures[f]
                try:
                    out[n] = f.result()[1]
                    line = f"{out[n]:.0f} s"
                except Exception as e:          # noqa: BLE001  (reported, the rest go on)
                    out[n] = f"{type(e).__name__}: {(str(e).splitlines() or [''])[0]}"
                    line = f"failed ({out[n]})"
                if not quiet:
                    print(f"warm: {n} {line}", flush=True)
    return out


def main(argv=None) -> int:
    def jobs(text):
        if not text.isdigit() or not 1 <= int(text) <= 64:
            raise argparse.ArgumentTypeError(f"{text!r}: an integer in [1, 64]")
        return int(text)

    ap = argparse.ArgumentParser(prog="python -m engine.warm",
                                 description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=jobs, default=None,
                    help="processes at a time (default: the CPU count, at most 4)")
    ap.add_argument("--quiet", action="store_true")
    a = ap.parse_args(argv)
    t = time.perf_counter()
    warm(jobs=a.jobs, quiet=a.quiet)
    if not a.quiet:
        print(f"warm: the kernels are in numba's cache ({time.perf_counter() - t:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
