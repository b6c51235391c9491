"""The position correction (``overlap_tol``) on the demo's test and on the helix's closed form.

    .venv/bin/python bench/bench_overlap.py [--seeds 0,1,2] [--tols none,0.01,0.005]
                                            [--no-helix]

1. The demo's test, ``cylinder_triaxial(0.1, axial_strain=0.05)`` with its wire (the
   defaults: k = 1 N, tol 3e-4) and the sand alone, for each seed and each ``overlap_tol``
   (``none``: no correction), every step recorded: the largest overlap of any step (of the
   smaller radius of its pair), the steps at ``max_iter``, the NLGS sweeps per step, q at
   the end and the wall time (one run at a time, on a machine left alone).
2. The helix's closed form at rest (not the triaxial one: no failure, so little noise): the
   helix sample (``wire_mode="helix"``, one d_max deep) with an elastic wire prestrained at
   the loading (k = 1 N, ε₀ = 0.05) against its loose twin, loaded 0.2 % at 0.1 /s so that
   the ring settles; over the last 200 steps, the sand's radial stress in the core
   (``control_helix.core_stress``) against T/(R s) from the ring's own tension and radius.
   Mechanics (a thin ring on a column under uniform lateral pressure): the core's radial
   stress rises by T/(R s).

The criteria, fixed before the runs: the correction works when, at its default, the demo's
largest overlap is below 1 % of the smaller radius for every seed, sand and wire; the
coupling is right when the mean over the seeds of Δσ_rr / (T/(R s)) is within 1 ± 0.3 with
the correction.  JSON: bench/results/overlap-*.json.
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
import warnings
from pathlib import Path

HERE = Path(__file__).resolve().parent
for p in (str(HERE.parent), str(HERE)):
    if p not in sys.path:
        sys.path.insert(0, p)

import numpy as np  # noqa: E402

from record import Busy, machine, write  # noqa: E402


def _tol(text):
    return None if text == "none" else float(text)


def demo(seed, wire, tol, folder):
    """One run of the demo's test: its row."""
    import h5py

    from engine.experiments import cylinder_triaxial

    h5 = os.path.join(folder, f"demo-{wire}-{tol}-{seed}.h5")
    t = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = cylinder_triaxial(0.1, axial_strain=0.05, seed=seed, wire=wire, overlap_tol=tol,
                              record_every=1, history=h5, progress=False)
    wall = time.perf_counter() - t
    with h5py.File(h5, "r") as f:
        it = f["records/iterations"][:]
        ov = f["records/max_overlap"][:]
    return dict(seed=seed, wire=wire, overlap_tol=tol, wall_s=wall, steps=int(it.size),
                max_overlap=float(ov.max()), median_step_max_overlap=float(np.median(ov)),
                sweeps_per_step=float(it.mean()),
                non_converged_share=float(r.convergence.get("share") or 0.0),
                q_end=float(np.asarray(r.deviator)[-1]))


def helix(seed, tol, folder, scale=0.1):
    """The helix at rest with its prestrained ring and its loose twin: the core's radial
    stress gain against T/(R s)."""
    from control_helix import core_stress

    from engine import laws
    from engine.experiments import cylinder_triaxial

    out = {}
    for name, law in (("ring", laws.ElasticWire(stiffness=1.0)), ("loose", laws.LooseWire())):
        kw = dict(wire_prestrain=0.05) if name == "ring" else {}
        h5 = os.path.join(folder, f"helix-{name}-{tol}-{seed}.h5")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            cylinder_triaxial(scale, wire_mode="helix", helix_inset=0.8e-3, wire_law=law,
                              axial_strain=0.002, strain_rate=0.1, seed=seed, frames=10,
                              overlap_tol=tol, history=h5, progress=False, **kw)
        out[name] = core_stress(h5, last=20, every=2)
    (s_ring, z_ring, pred), (s_loose, z_loose, _) = out["ring"], out["loose"]
    return dict(seed=seed, overlap_tol=tol, scale=scale, core_srr_ring=s_ring,
                core_srr_loose=s_loose, d_srr=s_ring - s_loose, t_over_rs=pred,
                ratio=(s_ring - s_loose) / pred if pred else None)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--tols", default="none,0.01,0.005")
    ap.add_argument("--no-helix", action="store_true")
    ap.add_argument("--no-demo", action="store_true")
    a = ap.parse_args(argv)
    seeds = [int(s) for s in a.seeds.split(",")]
    tols = [_tol(t) for t in a.tols.split(",")]
    busy = Busy()
    rows, helix_rows = [], []
    with tempfile.TemporaryDirectory() as folder:
        if not a.no_demo:
            for seed in seeds:
                for wire in (True, False):
                    for tol in tols:
                        r = demo(seed, wire, tol, folder)
                        rows.append(r)
                        print(f"demo seed {seed} {'wire' if wire else 'sand'} overlap_tol "
                              f"{tol}: largest overlap {100 * r['max_overlap']:.2f} %, "
                              f"{r['sweeps_per_step']:.0f} sweeps/step, "
                              f"{100 * r['non_converged_share']:.1f} % at max_iter, q "
                              f"{r['q_end']:.0f} Pa, {r['wall_s']:.1f} s", flush=True)
        if not a.no_helix:
            for seed in seeds:
                for tol in tols:
                    r = helix(seed, tol, folder)
                    helix_rows.append(r)
                    print(f"helix seed {seed} overlap_tol {tol}: core d_srr {r['d_srr']:.0f} "
                          f"Pa, T/(R s) {r['t_over_rs']:.0f} Pa, ratio {r['ratio']:.2f}",
                          flush=True)
    summary = {}
    for tol in tols:
        d = [r for r in rows if r["overlap_tol"] == tol]
        h = [r["ratio"] for r in helix_rows if r["overlap_tol"] == tol]
        s = summary[str(tol)] = {}
        if d:
            s.update(largest_overlap=max(r["max_overlap"] for r in d),
                     below_1pct=all(r["max_overlap"] < 0.01 for r in d),
                     wall_s=sum(r["wall_s"] for r in d),
                     sweeps_per_step=float(np.mean([r["sweeps_per_step"] for r in d])))
        if h:
            s.update(helix_ratio_mean=float(np.mean(h)),
                     helix_ratio_2se=float(2 * np.std(h, ddof=1) / np.sqrt(len(h)))
                     if len(h) > 1 else None,
                     helix_within_30pct=bool(abs(np.mean(h) - 1) <= 0.3))
        print(f"overlap_tol {tol}: {s}", flush=True)
    out = dict(machine=machine(), busy=busy.finish(), seeds=seeds, demo=rows,
               helix=helix_rows, summary=summary,
               criterion="demo: largest overlap < 1 % of the smaller radius, every seed, "
                         "sand and wire; helix at rest: mean d_srr / (T/(R s)) within "
                         "1 +- 0.3")
    print(write("overlap", out))


if __name__ == "__main__":
    main()
