"""The positive control of the wire–sand coupling: a sand column encased by a helical wire.

For each seed, one helix sample (``cylinder_sample(scale, wire_mode="helix")``) is tested
twice, from the same packing: with the helix's links working (``--law``: rigid or elastic
k) and with them loose (:class:`engine.laws.LooseWire`: the same beads, no link force).
Mechanics gives the difference in closed form: the hoop tension T of a helix of radius R
and pitch s adds Δσ₃ = T/(R s) to the sand's lateral stress, and a column of passive
coefficient K_p = σ₁/σ₃ (measured on the loose run) gains Δq = K_p Δσ₃.

The criterion, fixed before the runs: the encased column is stronger than its loose twin
beyond two standard errors over the seeds (at every scale tried), and the measured Δq is
within ±30 % of K_p T/(R s) computed from the measured T and R (the mean over the seeds of
the ratio, at the end of the loading).

    python bench/control_helix.py --scale 0.1 --seeds 0 1 2 [--law rigid|elastic] [--k 1]

Writes ``bench/results/control-helix-<date>.json``.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from engine import io, laws  # noqa: E402
from engine.analysis.wire import encasement  # noqa: E402
from engine.experiments import cylinder_triaxial  # noqa: E402
from engine.prep import PAPER  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))


def end_values(res, window=0.1):
    """(q [Pa], axial strain) at the end of the loading: the mean of the records in the
    last ``window`` of the strain range."""
    e, q = np.asarray(res.axial_strain), np.asarray(res.deviator)
    sel = e >= (1 - window) * e[-1]
    return float(q[sel].mean()), float(e[-1])


def one_pair(scale, seed, law, strain, pitch, pressure, out_dir, **kw):
    """The helix run with ``law`` and its loose twin; returns the measured and predicted
    deviator gains at the end of the loading."""
    common = dict(wire_mode="helix", helix_pitch=pitch, axial_strain=strain,
                  pressure=pressure, seed=seed, progress=False, **kw)
    runs, t0 = {}, time.time()
    for name, lw in (("encased", law), ("loose", laws.LooseWire())):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            runs[name] = cylinder_triaxial(
                scale, wire_law=lw, history=os.path.join(out_dir, f"{name}-{scale}-{seed}.h5"),
                **common)
    q_enc, eps = end_values(runs["encased"])
    q_loose, _ = end_values(runs["loose"])
    model, state = io.load(runs["encased"].history, frame=-1)
    beads = model.bodies_in("wire")
    s = pitch if pitch is not None else PAPER["cylinder"]["d_max"]
    # (cylinder_sample's axis is x = y = 0)
    enc = encasement(state.links.tension, state.position[beads], pitch=s)
    k_p = (q_loose + pressure) / pressure
    pred = enc.deviator_gain(k_p)
    return dict(seed=seed, scale=scale, strain=eps, q_encased=q_enc, q_loose=q_loose,
                dq=q_enc - q_loose, dq_rel=q_enc / q_loose - 1, tension=enc.tension,
                helix_radius=enc.radius, pitch=s, k_p=k_p, delta_sigma3=enc.confinement,
                dq_predicted=pred, ratio=(q_enc - q_loose) / pred if pred else None,
                start_radius=[runs[n].extra["start"]["radius"] for n in ("encased", "loose")],
                n_beads=runs["encased"].params["n_beads"], wall=time.time() - t0)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scale", type=float, nargs="+", default=[0.1])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--law", choices=("rigid", "elastic"), default="rigid")
    ap.add_argument("--k", type=float, default=1.0, help="[N] the elastic law's stiffness")
    ap.add_argument("--strain", type=float, default=0.05)
    ap.add_argument("--pitch", type=float, default=None, help="[m] (default d_max)")
    ap.add_argument("--pressure", type=float, default=15e3, help="[Pa]")
    ap.add_argument("--out", default=os.path.join("out", "control-helix"))
    a = ap.parse_args(argv)
    os.makedirs(a.out, exist_ok=True)
    law = laws.RigidWire() if a.law == "rigid" else laws.ElasticWire(stiffness=a.k)
    rows, verdicts = [], {}
    for scale in a.scale:
        for seed in a.seeds:
            r = one_pair(scale, seed, law, a.strain, a.pitch, a.pressure, a.out)
            rows.append(r)
            print(f"scale {scale:g} seed {seed}: q {r['q_encased']:.0f} vs {r['q_loose']:.0f} "
                  f"Pa (dq {r['dq']:.0f} Pa, {100 * r['dq_rel']:+.1f} %), T {1e3 * r['tension']:.2f}"
                  f" mN, R {1e3 * r['helix_radius']:.3f} mm, K_p {r['k_p']:.2f}, predicted "
                  f"{r['dq_predicted']:.0f} Pa, ratio {r['ratio']:.2f} ({r['wall']:.0f} s)",
                  flush=True)
        sel = [r for r in rows if r["scale"] == scale]
        dq = np.array([r["dq"] for r in sel])
        ratio = np.array([r["ratio"] for r in sel])
        se = dq.std(ddof=1) / np.sqrt(dq.size) if dq.size > 1 else float("nan")
        verdicts[str(scale)] = dict(
            dq_mean=float(dq.mean()), dq_2se=float(2 * se),
            stronger=bool(dq.mean() > 2 * se), ratio_mean=float(ratio.mean()),
            ratio_2se=float(2 * ratio.std(ddof=1) / np.sqrt(ratio.size)) if ratio.size > 1
            else None, closed_form_within_30pct=bool(abs(ratio.mean() - 1) <= 0.3))
        print(f"scale {scale:g}: {verdicts[str(scale)]}", flush=True)
    stamp = time.strftime("%Y%m%d-%H%M")
    path = os.path.join(HERE, "results", f"control-helix-{stamp}.json")
    with open(path, "w") as f:
        json.dump(dict(law=repr(law), strain=a.strain, pressure=a.pressure, pitch=a.pitch,
                       seeds=a.seeds, criterion="stronger beyond 2 SE; mean measured/predicted "
                       "dq within 1 +- 0.3", rows=rows, verdicts=verdicts), f, indent=1)
    print(path)


if __name__ == "__main__":
    main()
