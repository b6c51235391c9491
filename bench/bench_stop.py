"""What a stop request inside a step costs and how fast it is seen (issue 33 item 4).

Run:  .venv/bin/python bench/bench_stop.py          (or ``make bench``; about 1 min)
      .venv/bin/python bench/bench_stop.py --quick  (a smoke run)

Writes bench/results/stop-<YYYYmmdd-HHMM>.json.

1. ``overhead``: wall time per step of :func:`engine.run` with its undo of an interrupted
   step (``engine.step._Undo``: positions, velocities, forces and link warm starts copied,
   contact buffers swapped, when the step's NLGS loop may run in chunks) against the same
   run with the undo switched off, interleaved repetitions in one process, minimum over
   them; on three scenes of 8 000 spheres (radii 0.95-1 mm, seeded): a cloud of 3 mm pitch
   falling (it reaches the floor), a cubic lattice of 2 mm pitch settling on a floor at the default tol 1e-4,
   and the same at tol 1e-6 (the piles measured from step 50 on, loaded).  Also the same runs
   without :mod:`engine.sanity`'s per-step checks (the overlap pass over the contacts, the
   spheres through walls, the reactions' kinetic-energy gain): ``checks_ratio``.  The ratio is the figure: the yardstick is the same run without it.
2. ``latency``: a child process in a step that cannot converge (tol 1e-300, max_iter 10^9)
   gets SIGTERM 2 s into it; the time from the signal to the run's return (measured in the
   child on the system-wide monotonic clock), median over repeats.
"""
from __future__ import annotations

import argparse
import copy
import os
import signal
import subprocess
import sys
import textwrap
import time
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT), str(ROOT / "bench")]

import numpy as np  # noqa: E402

import record  # noqa: E402


def lattice(n, spacing, **opt):
    from engine import Scene, laws

    k = int(np.ceil(n ** (1 / 3)))
    g = np.stack(np.meshgrid(*[np.arange(k)] * 3, indexing="ij"), -1).reshape(-1, 3)[:n]
    s = Scene(gravity=(0, 0, -9.81))
    radii = 1e-3 * np.random.default_rng(0).uniform(0.95, 1.0, len(g))   # seeded
    s.add_spheres(g * spacing + 1.01e-3, radii, density=2650.0)
    s.add_plane(point=(0, 0, 0), normal=(0, 0, 1), group="floor")
    s.interact("sand", "sand", laws.Coulomb(mu=0.5))
    s.interact("sand", "floor", laws.Coulomb(mu=0.5))
    return s.compile(dt=1e-4, **opt)


def checks_alone(model, state, repeats: int = 200) -> float:
    """Seconds per step of engine.sanity's three per-step checks alone, on ``state`` (its
    last step's contacts and free velocities), minimum of ``repeats`` calls: the run-level
    ratio is within the run-to-run noise, this is the cost itself."""
    from engine import sanity

    c = state.contacts_buf
    free = state.__dict__["_free_vel"]
    walls = model.wall_ids.astype(np.int64)
    best = np.inf
    for _ in range(repeats):
        t = time.perf_counter()
        sanity.max_overlap(c.count, c.gap, c.ri, c.rj, c.i, model.body_dof)
        sanity.through_walls(state.position, model.body_radius, model.body_group,
                             model.sphere_ids, walls, model.pair_law, model.body_kind,
                             model.body_axis, model.body_height, model.body_caps,
                             model.body_dof)
        sanity.reaction_gain(state.vel6, free, model.body_mass, model.body_inertia,
                             model.sphere_ids, model.body_dof)
        best = min(best, time.perf_counter() - t)
    return best


def overhead(quick: bool) -> list:
    from engine import run

    step_mod = sys.modules["engine.step"]
    scenes = {"cloud falling on a floor": (lattice(8000, 3e-3), 200),
              "lattice pile, tol 1e-4": (lattice(8000, 2.0e-3), 100),
              "lattice pile, tol 1e-6": (lattice(8000, 2.0e-3, tol=1e-6), 20)}
    out = []
    for name, ((model, state0), steps) in scenes.items():
        if quick:
            steps = max(2, steps // 10)
        run(model, state0, 3 if "cloud" in name else 50, progress=False)   # loaded piles
        times = {"with undo": [], "without": [], "without checks": []}
        keep = step_mod._Undo.__dict__["needed"]
        checks = step_mod._check_physics, step_mod.max_overlap, step_mod.reaction_gain
        for rep in range(2 if quick else 5):
            for mode in times:
                if mode == "without":
                    step_mod._Undo.needed = staticmethod(lambda m, s: False)
                if mode == "without checks":     # engine.sanity's per-step checks off
                    step_mod._check_physics = lambda *a: None
                    step_mod.max_overlap = lambda *a: (0.0, -1)
                    step_mod.reaction_gain = lambda *a: (0.0, 0.0)
                s = copy.deepcopy(state0)
                t = time.perf_counter()
                summary = run(model, s, steps, progress=False)
                times[mode].append((time.perf_counter() - t) / steps)
                step_mod._Undo.needed = keep
                step_mod._check_physics, step_mod.max_overlap, step_mod.reaction_gain = checks
        a, b, c = (min(times[k]) for k in times)
        alone = checks_alone(model, s)
        row = dict(scene=name, bodies=model.n_bodies, steps=steps,
                   sweeps_per_step=summary.mean_iterations, contacts=summary.max_contacts,
                   step_s_with_undo=a, step_s_without=b, ratio=a / b,
                   step_s_without_checks=c, checks_ratio=a / c,
                   checks_alone_s=alone, checks_alone_share=alone / a)
        print(f"  {name:34s} {a * 1e3:8.3f} ms/step with the undo, {b * 1e3:8.3f} without: "
              f"x{a / b:.3f}; without the sanity checks {c * 1e3:8.3f}: x{a / c:.3f} "
              f"({summary.mean_iterations:.0f} sweeps, {summary.max_contacts} contacts); "
              f"the checks timed alone {alone * 1e6:.1f} us/step ({100 * alone / a:.2f} %)")
        out.append(row)
    return out


CHILD = textwrap.dedent("""
    import sys, time, warnings
    sys.path[:0] = [sys.argv[1], sys.argv[1] + "/bench"]
    warnings.simplefilter("ignore")
    from bench_stop import lattice
    from engine import run
    import dataclasses
    model, state = lattice(2000, 2.0e-3)
    run(model, state, 50, progress=False)        # the pile loaded: contacts carry impulses
    model = dataclasses.replace(model, options=model.options.model_copy(
        update=dict(tol=1e-300, max_iter=10**9)))
    print("stepping", flush=True)
    s = run(model, state, 2, progress=False)
    print(s.interrupted, s.steps, repr(time.monotonic()), flush=True)
""")


def latency(quick: bool) -> dict:
    lat = []
    for _ in range(1 if quick else 3):
        proc = subprocess.Popen([sys.executable, "-c", CHILD, str(ROOT)], cwd=ROOT,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        assert proc.stdout.readline().strip() == "stepping"
        time.sleep(2.0)
        sent = time.monotonic()
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=120)
        interrupted, steps, t = out.split()
        assert interrupted == "True" and steps == "0", (out, err[-1000:])
        lat.append(float(t) - sent)
    print(f"  SIGTERM inside a step of 2 000 spheres: the run returned {np.median(lat) * 1e3:.0f} ms "
          f"after the signal (median of {len(lat)}; max {max(lat) * 1e3:.0f} ms)")
    return dict(bodies=2001, latency_s=lat, median_s=float(np.median(lat)))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    a = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    busy = record.Busy()
    print("stop requests inside a step:")
    res = dict(overhead=overhead(a.quick), latency=latency(a.quick))
    out = dict(bench="stop", machine=record.machine(), busy=busy.finish(), **res)
    print(f"wrote {record.write('stop', out, quick=a.quick)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
