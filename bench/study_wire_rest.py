"""Study: what the wire does once a deposit's sand is at rest (the last frame of a history).

The rest criterion of the deposits looks at the sand only.  This study restarts a finished
history from its last frame (positions and velocities; the solver starts cold), runs
``--warmup`` steps, then ``--steps`` steps recording every bead's velocity, and reports:

- the beads faster than 1 mm/s and 5 mm/s, and the kinetic energy of beads and sand;
- the share of fast beads on a taut link (tension > 0 on either side);
- the ratio of each fast bead's net displacement over the recorded window to the path its
  speed would cover (1: it travels; << 1: it vibrates in place);
- for the 20 fastest beads, the dominant frequency of their velocity (FFT) against
  ω_N = 2 √(T / (m a)), the highest transverse mode of a beaded string under the bead's
  mean link tension T (docs/wire.md, "What limits the time step"), m the bead mass, a the
  link length.

``--tols`` repeats the warm-up and the window at each NLGS tolerance (``max_iter`` is raised
to ``--max-iter``): if the beads' motion were the solver's error it would shrink with tol.

Usage: python bench/study_wire_rest.py HISTORY.h5 [--tols 2e-4,1e-5] [--warmup 40]
                                       [--steps 400] [--max-iter 20000]
Writes bench/results/wire-rest-YYYYMMDD-HHMM.json.
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import record  # noqa: E402


def _energies(model, state, beads, sand):
    """Speeds [m/s] and the translational kinetic energy ½ m v² [J] of beads and sand (the
    spin is left out, unlike engine.analysis.kinetic_energy: the beads' motion is the
    question here)."""
    v = state.vel6[:, :3]
    speed = np.sqrt((v * v).sum(axis=1))
    m = model.body_mass
    return speed, 0.5 * float((m[beads] * speed[beads] ** 2).sum()), \
        0.5 * float((m[sand] * speed[sand] ** 2).sum())


def one(path: str, tol: float, max_iter: int, warmup: int, steps: int) -> dict:
    from engine.io import load
    from engine.step import step

    model, state = load(path, frame=-1)
    model = model.with_options(tol=tol, max_iter=max_iter)
    li, lj = model.link_i, model.link_j
    if li.size == 0:
        raise SystemExit(f"{path}: the history has no wire")
    beads = np.unique(np.concatenate([li, lj]))
    sand = np.where(model.body_group == model.group_id("sand"))[0]
    h = model.options.dt
    t0 = time.perf_counter()
    for _ in range(warmup):
        step(model, state)
    p0 = state.position[beads].copy()
    vel = np.empty((steps, beads.size, 3))
    tension = np.empty((steps, li.size))
    iterations = []
    for s in range(steps):
        stats = step(model, state)
        iterations.append(stats.iterations)
        vel[s] = state.vel6[beads, :3]
        tension[s] = state.links.tension
    wall = time.perf_counter() - t0
    speed, ke_beads, ke_sand = _energies(model, state, beads, sand)
    bead_speed = speed[beads]
    fast = bead_speed > 1e-3
    # taut on either side (beads is sorted: np.unique)
    taut_link = tension[-1] > 0.0
    on_taut = np.zeros(beads.size, bool)
    on_taut[np.searchsorted(beads, li[taut_link])] = True
    on_taut[np.searchsorted(beads, lj[taut_link])] = True
    mean_speed = np.sqrt((vel * vel).sum(axis=2)).mean(axis=0)
    net = np.sqrt(((state.position[beads] - p0) ** 2).sum(axis=1))
    travel = net / np.maximum(mean_speed * steps * h, 1e-300)
    top = np.argsort(mean_speed)[-20:]
    n_fft = 1 << int(np.ceil(np.log2(steps * 8)))
    freq = np.fft.rfftfreq(n_fft, h)
    modes = []
    for k in top:
        b = beads[k]
        sig = vel[:, k, :] - vel[:, k, :].mean(axis=0)
        amp = np.abs(np.fft.rfft(sig, axis=0, n=n_fft)).sum(axis=1)
        f = float(freq[1 + int(np.argmax(amp[1:]))])
        ls = np.where((li == b) | (lj == b))[0]
        t_mean = float(tension[:, ls].mean())
        a = float(model.link_ref_length[ls].mean())
        w_n = 2.0 * np.sqrt(max(t_mean, 0.0) / (model.body_mass[b] * a))
        modes.append(dict(bead=int(b), mean_speed=float(mean_speed[k]), tension=t_mean,
                          frequency=f, omega=2 * np.pi * f, omega_N=float(w_n),
                          ratio=float(2 * np.pi * f / w_n) if w_n > 0 else None))
    ratios = [m["ratio"] for m in modes if m["ratio"] is not None]
    return dict(
        tol=tol, max_iter=max_iter, warmup=warmup, steps=steps, dt=h,
        frequency_resolution=1.0 / (steps * h), wall_time=wall,
        mean_iterations=float(np.mean(iterations)),
        max_iterations=int(np.max(iterations)),
        beads=int(beads.size), beads_over_1mm_s=int(fast.sum()),
        beads_over_5mm_s=int((bead_speed > 5e-3).sum()),
        max_bead_speed=float(bead_speed.max()),
        kinetic_energy_beads=ke_beads, kinetic_energy_sand=ke_sand,
        fast_on_taut_link=float(on_taut[fast].mean()) if fast.any() else None,
        travel_ratio_fast_median=float(np.median(travel[mean_speed > 1e-3]))
        if (mean_speed > 1e-3).any() else None,
        omega_over_omega_N_median=float(np.median(ratios)) if ratios else None,
        modes=modes)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("history", help="an HDF5 history with frames and a wire")
    ap.add_argument("--tols", default="2e-4")
    ap.add_argument("--max-iter", type=int, default=20000)
    ap.add_argument("--warmup", type=int, default=40)
    ap.add_argument("--steps", type=int, default=400)
    a = ap.parse_args(argv)
    busy = record.Busy()
    rows = []
    for tol in (float(t) for t in a.tols.split(",")):
        rows.append(one(a.history, tol, a.max_iter, a.warmup, a.steps))
        print({k: (f"{v:.4g}" if isinstance(v, float) else v)
               for k, v in rows[-1].items() if k != "modes"}, flush=True)
    path = record.write("wire-rest", dict(
        what="a finished deposit restarted from its last frame: the beads' motion "
             "(bench/study_wire_rest.py)",
        history=os.path.abspath(a.history), commit=record.git_commit(),
        machine=record.machine(), busy=busy.finish(), rows=rows))
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
