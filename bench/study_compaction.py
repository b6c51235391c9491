"""Study (issue 10, Fig. 14): what a low-friction compaction does to the cylinder samples.

The cylinder triaxial of the default-scale report (``workbench.paper.SCALES["default"]``:
scale 0.3, 10 % strain) for the sand, the elastic wire (k = 0.2 N) and the rigid wire, on
seeds 0-2, with the test's own friction throughout and with ``compaction_mu`` (default 0.1)
during the isotropic stage.  For each run: the sand's solid fraction at the start of the
loading (sand volume / π R₀² H₀, R₀ the confinement's radius, H₀ the wall distance) and the
deviator q at the final strain and averaged over the last fifth of the strain (ε >= 8 %); for each wire run, q relative to
the sand run of the same seed and preparation.

Usage: python bench/study_compaction.py [--mu 0.1] [--seeds 0,1,2] [--workers 2|1]
Writes bench/results/compaction-YYYYMMDD-HHMM.json (about 6 min on 2 idle cores).
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import numpy as np  # noqa: E402

import record  # noqa: E402


def summarize(runs_dir: str, name: str, n_sand_volume: float) -> dict:
    """Solid fraction at the start of the loading and q figures of one finished run."""
    from engine.io import read_history
    from workbench.paper import read_curves

    c = read_curves(os.path.join(runs_dir, f"{name}.curves.h5"))
    h = read_history(os.path.join(runs_dir, f"{name}.h5"))
    eps, q = np.asarray(c["axial_strain"]), np.asarray(c["deviator"])
    k0 = h.n_records - eps.size               # the record the loading starts from
    R0, H0 = float(h.extra["radius"][k0]), float(h.extra["height"][k0])
    return dict(phi0=n_sand_volume / (np.pi * R0 ** 2 * H0), R0=R0, H0=H0,
                eps_final=float(eps[-1]), q_final=float(q[-1]),
                q_mean_late=float(q[eps >= 0.8 * eps[-1]].mean()))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mu", type=float, default=0.1, help="compaction_mu of the second set")
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--scale", default="default", help="a workbench.paper scale (tiny: smoke)")
    ap.add_argument("--workers", type=int, default=2, choices=(1, 2),
                    help="2: campaign.sweep's LocalCluster; 1: one run after the other")
    a = ap.parse_args()
    from engine.prep import cylinder_sample
    from campaign import sweep
    from workbench.paper import SCALES, paper_case

    seeds = [int(s) for s in a.seeds.split(",")]
    cy = dict(SCALES[a.scale].cylinder)
    cases = []
    for prep, cmu in (("own", None), ("compacted", a.mu)):
        for w, k in (("none", None), ("elastic", 0.2), ("rigid", None)):
            for s in seeds:
                tag = {"none": "sand", "elastic": "k0.2", "rigid": "rigid"}[w]
                cases.append(dict(test="cylinder_triaxial", name=f"{prep}_{tag}_seed{s}",
                                  wire=w, k=k, seed=s, compaction_mu=cmu, **cy))
    busy = record.Busy()
    with tempfile.TemporaryDirectory() as tmp:
        runs = os.path.join(tmp, "runs")
        # None: campaign.sweep's LocalCluster (2 workers, one thread each); "serial": in turn
        table = sweep(paper_case, cases, None if a.workers > 1 else "serial",
                      out=os.path.join(tmp, "t.json"), fixed={"runs_dir": runs}, progress=True)
        failed = [r["params"]["name"] for r in table.failed]
        if failed:
            print("failed:", failed)
        rows = {}
        for c in cases:
            if c["name"] in failed:
                continue
            sand = cylinder_sample(cy["scale"], wire=c["wire"] != "none", seed=c["seed"])
            vs = float((4.0 / 3.0 * np.pi * sand.sand_radii ** 3).sum())
            rows[c["name"]] = dict(summarize(runs, c["name"], vs), seed=c["seed"],
                                   wire=c["wire"], compaction_mu=c["compaction_mu"])
    rel = {}
    for prep in ("own", "compacted"):
        for tag in ("k0.2", "rigid"):
            for key in ("q_final", "q_mean_late"):
                v = [rows[f"{prep}_{tag}_seed{s}"][key] / rows[f"{prep}_sand_seed{s}"][key] - 1
                     for s in seeds
                     if f"{prep}_{tag}_seed{s}" in rows and f"{prep}_sand_seed{s}" in rows]
                rel[f"{prep}/{tag}/{key}"] = dict(
                    per_seed=v, mean=float(np.mean(v)) if v else None,
                    std=float(np.std(v, ddof=1)) if len(v) > 1 else None)
    for k, v in rel.items():
        print(f"{k:32s} " + " ".join(f"{x:+.1%}" for x in v["per_seed"]))
    for prep in ("own", "compacted"):
        for tag in ("sand", "k0.2", "rigid"):
            print(f"phi0 {prep:9s} {tag:6s} " + " ".join(
                f"{rows[f'{prep}_{tag}_seed{s}']['phi0']:.4f}" for s in seeds
                if f"{prep}_{tag}_seed{s}" in rows))
    out = dict(benchmark="compaction", machine=record.machine(), busy=busy.finish(),
               git=record.git_commit(), params=dict(scale=a.scale, cylinder=cy, seeds=seeds, compaction_mu=a.mu,
                                                      workers=a.workers),
               runs=rows, q_relative_to_sand=rel, failed=failed)
    print(record.write("compaction", out, quick=a.scale != "default"))


if __name__ == "__main__":
    main()
