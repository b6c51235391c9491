"""The positive control of the wire–sand coupling: a sand column encased by a helical wire.

For each seed, one helix sample (``cylinder_sample(scale, wire_mode="helix")``) is tested
twice, from the same packing: with the helix's links working (``--law``: rigid or elastic
k) and with them loose (:class:`engine.laws.LooseWire`: the same beads, no link force).
Mechanics gives the difference in closed form: the hoop tension T of a helix of radius R
and pitch s adds Δσ₃ = T/(R s) to the sand's lateral stress, and a column of passive
coefficient K_p = σ₁/σ₃ (measured on the loose run) gains Δq = K_p Δσ₃.

The criterion of the first runs (control-helix-20261207-1629.json, not met): the encased
column stronger than its loose twin beyond two standard errors over the seeds (at every
scale tried), and the measured Δq within ±30 % of K_p T/(R s) from the measured T and R (the
mean over the seeds of the ratio, at the end of the loading).  Its closed form leaves out
that q is measured over the membrane's whole section π R_m², of which the helix encases
π R² only: with the helix one d_max deep, (R/R_m)² = 0.29 at scale 0.1 and 0.44 at 0.3.

The criterion of the runs after it (verdict ``window``), fixed before they ran: over the
second half of the loading (strain >= half the final strain, every record), the mean Δq of
the pairs is above zero by more than two standard errors over the seeds, at every scale
tried; and the mean over the seeds of Δq / (K_p σ_w,rr) is within 1 ± 0.3, σ_w,rr the wire's
Weber stress in the section (Eq. 18 over π R_m² H: T R/(R_m² s), the ring's Δσ₃ over the
whole section).  The end-of-loading figures are reported beside it.

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
from workbench.campaign import not_interrupted  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))


def end_values(res, window=0.1):
    """(q [Pa], axial strain) at the end of the loading: the mean of the records in the
    last ``window`` of the strain range."""
    e, q = np.asarray(res.axial_strain), np.asarray(res.deviator)
    sel = e >= (1 - window) * e[-1]
    return float(q[sel].mean()), float(e[-1])


def loading_of(path):
    """The loading's records of a cylinder test's history (from the last isotropic one, as
    the test's result has them): history, step, axial_strain, deviator [Pa]."""
    from types import SimpleNamespace

    h = io.read_history(path, frames=False)
    st = np.asarray(h.extra["stage"])
    sel = slice(int(np.flatnonzero(st == 1)[0]) - 1, None)
    H = np.asarray(h.extra["height"])[sel]
    t = np.asarray(h.extra["stress"])[sel]
    return SimpleNamespace(history=path, step=np.asarray(h.step)[sel].astype(int),
                           axial_strain=1 - H / H[0],
                           deviator=-t[:, 2, 2] + (t[:, 0, 0] + t[:, 1, 1]) / 2,
                           wire_stress=np.asarray(h.extra["wire_stress"])[sel])


def window_values(enc, loose, pitch, pressure, lo=0.5):
    """Means over the second half of the loading (strain >= ``lo`` × the final strain) of
    the measured Δq [Pa] and of three predictions [Pa], q of both runs compared at the same
    strain and K_p = (q_loose + p)/p there:

    * ``ring``: K_p T/(R s), T and R from the encased run's frames (the thin ring of the
      helix's radius);
    * ``section``: K_p σ_w,rr, σ_w,rr = (σ_xx + σ_yy)/2 of the wire's Weber stress in the
      records (Eq. 18 over the sample's volume π R_m² H: T R/(R_m² s) for a helix of radius
      R in a membrane of radius R_m, the ring's Δσ₃ averaged over the whole section);
    * ``section_increment``: K_p (σ_w,rr − its value at the start of the loading).

    Returns a dict of the four means and the number of records and frames used."""
    def rr(w):
        w = np.asarray(w)
        return (w[:, 0, 0] + w[:, 1, 1]) / 2

    e = np.asarray(enc.axial_strain)
    sel = e >= lo * e[-1]
    q_l = np.interp(e, loose.axial_strain, loose.deviator)
    k_p = (q_l + pressure) / pressure
    w = rr(enc.wire_stress)
    out = dict(dq=float((enc.deviator - q_l)[sel].mean()),
               section=float((k_p * w)[sel].mean()),
               section_increment=float((k_p * (w - w[0]))[sel].mean()), records=int(sel.sum()))
    steps, _ = io.frame_index(enc.history)
    e_f = np.interp(steps, enc.step, e, left=np.nan, right=np.nan)
    frames = np.flatnonzero(np.isfinite(e_f) & (e_f >= lo * e[-1]))
    beads = io.load_model(enc.history).bodies_in("wire")
    ring = []
    for k, f in zip(frames, io.frame_arrays(enc.history, ["position", "link_tension"],
                                            frames=frames)):
        g = encasement(f["link_tension"], f["position"][beads], pitch=pitch)
        ql = np.interp(e_f[k], loose.axial_strain, loose.deviator)
        ring.append(g.deviator_gain((ql + pressure) / pressure))
    out.update(ring=float(np.mean(ring)) if ring else float("nan"), frames=int(len(ring)))
    return out


def core_stress(path, *, last=30, every=3, inner=0.8):
    """The sand's Weber stress (Eq. 18, contacts only) in the core of a helix run's last
    ``last`` frames (every ``every``-th): the region r < ``inner`` × the helix's radius (for
    a loose twin: its beads' mean radius), 0.2-0.8 of the sand's height.  Returns the mean
    (σ_rr, σ_zz) [Pa], compression positive, and the mean T/(R s) [Pa] of those frames
    (0 for a loose twin): whether the hoop tension reaches the sand it encases."""
    from engine.analysis import weber_stress
    from engine.prep import Cylinder

    steps, _ = io.frame_index(path)
    model = io.load_model(path)
    beads, sand = model.bodies_in("wire"), model.bodies_in("sand")
    pitch = PAPER["cylinder"]["d_max"]
    rows = []
    for k in range(max(0, len(steps) - last), len(steps), every):
        m, st = io.load(path, frame=k)
        x, r = st.position, m.body_radius
        z0, z1 = (x[sand, 2] - r[sand]).min(), (x[sand, 2] + r[sand]).max()
        rh = float(np.hypot(x[beads, 0], x[beads, 1]).mean())
        reg = Cylinder(inner * rh, 0.6 * (z1 - z0), (0.0, 0.0, z0 + 0.2 * (z1 - z0)))
        s = weber_stress(m, st, region=reg, part="sand").tensor
        t = float(st.links.tension.mean()) if m.n_links else 0.0
        rows.append((-(s[0, 0] + s[1, 1]) / 2, -s[2, 2], t / (rh * pitch)))
    return tuple(float(v) for v in np.mean(rows, axis=0))


def one_pair(scale, seed, law, strain, pitch, pressure, out_dir, frames=10, inset=None,
             **kw):
    """The helix run with ``law`` and its loose twin; returns the measured and predicted
    deviator gains at the end of the loading and over its second half (``frames``: the
    histories' frame interval [steps]; ``inset``: the helix's depth under the surface [m],
    None: d_min)."""
    common = dict(wire_mode="helix", helix_pitch=pitch, helix_inset=inset, axial_strain=strain,
                  pressure=pressure, seed=seed, progress=False, frames=frames, **kw)
    runs, t0 = {}, time.time()
    for name, lw in (("encased", law), ("loose", laws.LooseWire())):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            runs[name] = not_interrupted(cylinder_triaxial(
                scale, wire_law=lw, history=os.path.join(out_dir, f"{name}-{scale}-{seed}.h5"),
                **common), name, dict(scale=scale, seed=seed))
    q_enc, eps = end_values(runs["encased"])
    q_loose, _ = end_values(runs["loose"])
    model, state = io.load(runs["encased"].history, frame=-1)
    beads = model.bodies_in("wire")
    s = pitch if pitch is not None else PAPER["cylinder"]["d_max"]
    # (cylinder_sample's axis is x = y = 0)
    enc = encasement(state.links.tension, state.position[beads], pitch=s)
    k_p = (q_loose + pressure) / pressure
    pred = enc.deviator_gain(k_p)
    win = window_values(runs["encased"], runs["loose"], s, pressure)
    core = {n: core_stress(runs[n].history) for n in ("encased", "loose")}
    return dict(seed=seed, scale=scale, strain=eps, core=core, q_encased=q_enc, q_loose=q_loose,
                dq=q_enc - q_loose, dq_rel=q_enc / q_loose - 1, tension=enc.tension,
                helix_radius=enc.radius, pitch=s, k_p=k_p, delta_sigma3=enc.confinement,
                dq_predicted=pred, ratio=(q_enc - q_loose) / pred if pred else None,
                inset=inset, window=win,
                window_ratio={k: win["dq"] / win[k] for k in ("ring", "section",
                                                             "section_increment")},
                start_radius=[runs[n].extra["start"]["radius"] for n in ("encased", "loose")],
                n_beads=runs["encased"].params["n_beads"], wall=time.time() - t0)


def _window_verdict(rows) -> dict:
    """The criterion over the loading's second half (module doc): Δq above zero beyond two
    standard errors, and the mean of Δq / (K_p σ_w,rr) within 1 ± 0.3."""
    dq = np.array([r["window"]["dq"] for r in rows])
    ratio = np.array([r["window_ratio"]["section"] for r in rows])
    n = dq.size
    se = dq.std(ddof=1) / np.sqrt(n) if n > 1 else float("nan")
    rse = ratio.std(ddof=1) / np.sqrt(n) if n > 1 else float("nan")
    return dict(n=int(n), dq_mean=float(dq.mean()), dq_2se=float(2 * se),
                stronger=bool(dq.mean() > 2 * se), section_ratio_mean=float(ratio.mean()),
                section_ratio_2se=float(2 * rse),
                section_within_30pct=bool(abs(ratio.mean() - 1) <= 0.3),
                passed=bool(dq.mean() > 2 * se and abs(ratio.mean() - 1) <= 0.3))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scale", type=float, nargs="+", default=[0.1])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--law", choices=("rigid", "elastic"), default="rigid")
    ap.add_argument("--k", type=float, default=1.0, help="[N] the elastic law's stiffness")
    ap.add_argument("--strain", type=float, default=0.05)
    ap.add_argument("--pitch", type=float, default=None, help="[m] (default d_max)")
    ap.add_argument("--pressure", type=float, default=15e3, help="[Pa]")
    ap.add_argument("--inset", type=float, default=None,
                    help="[m] the helix's depth under the surface (default d_min)")
    ap.add_argument("--overlap-tol", default="default",
                    help="the position correction's overlap_tol (none: off; default: the "
                         "engine's default)")
    ap.add_argument("--out", default=os.path.join("out", "control-helix"))
    a = ap.parse_args(argv)
    os.makedirs(a.out, exist_ok=True)
    law = laws.RigidWire() if a.law == "rigid" else laws.ElasticWire(stiffness=a.k)
    extra = {} if a.overlap_tol == "default" else {
        "overlap_tol": None if a.overlap_tol == "none" else float(a.overlap_tol)}
    from engine.model import OVERLAP_TOL
    overlap_tol = extra.get("overlap_tol", OVERLAP_TOL)
    rows, verdicts = [], {}
    stamp = time.strftime("%Y%m%d-%H%M")
    path = os.path.join(HERE, "results", f"control-helix-{stamp}.json")
    for scale in a.scale:
        for seed in a.seeds:
            r = one_pair(scale, seed, law, a.strain, a.pitch, a.pressure, a.out, inset=a.inset,
                         **extra)
            rows.append(r)
            print(f"scale {scale:g} seed {seed}: q {r['q_encased']:.0f} vs {r['q_loose']:.0f} "
                  f"Pa (dq {r['dq']:.0f} Pa, {100 * r['dq_rel']:+.1f} %), T {1e3 * r['tension']:.2f}"
                  f" mN, R {1e3 * r['helix_radius']:.3f} mm, K_p {r['k_p']:.2f}, predicted "
                  f"{r['dq_predicted']:.0f} Pa, ratio {r['ratio']:.2f}; second half: dq "
                  f"{r['window']['dq']:.0f} Pa, ratios ring {r['window_ratio']['ring']:.2f} "
                  f"section {r['window_ratio']['section']:.2f} increment "
                  f"{r['window_ratio']['section_increment']:.2f} ({r['wall']:.0f} s)",
                  flush=True)
        sel = [r for r in rows if r["scale"] == scale]
        dq = np.array([r["dq"] for r in sel])
        ratio = np.array([r["ratio"] for r in sel])
        se = dq.std(ddof=1) / np.sqrt(dq.size) if dq.size > 1 else float("nan")
        verdicts[str(scale)] = dict(
            dq_mean=float(dq.mean()), dq_2se=float(2 * se),
            stronger=bool(dq.mean() > 2 * se), ratio_mean=float(ratio.mean()),
            ratio_2se=float(2 * ratio.std(ddof=1) / np.sqrt(ratio.size)) if ratio.size > 1
            else None, closed_form_within_30pct=bool(abs(ratio.mean() - 1) <= 0.3),
            window_ratio_mean={k: float(np.mean([r["window_ratio"][k] for r in sel]))
                               for k in ("ring", "section", "section_increment")},
            window=_window_verdict(sel))
        print(f"scale {scale:g}: {verdicts[str(scale)]}", flush=True)
        _write(path, a, law, overlap_tol, rows, verdicts)        # after every scale
    print(path)


def _write(path, a, law, overlap_tol, rows, verdicts):
    with open(path, "w") as f:
        json.dump(dict(law=repr(law), strain=a.strain, pressure=a.pressure, pitch=a.pitch,
                       inset=a.inset, overlap_tol=overlap_tol,
                       seeds=a.seeds, criterion="window: over the second half of the "
                       "loading, dq > 2 SE and mean dq / (K_p sigma_w,rr) within 1 +- 0.3 "
                       "(the first runs' end-of-loading ring criterion reported beside it)",
                       rows=rows, verdicts=verdicts), f, indent=1)


if __name__ == "__main__":
    main()
