"""When does the wire reinforce the sand? (issue 30 §3-4; bench/study_reinforcement.py,
docs/reinforcement.md)

The cylinder triaxial test (§3.3) of every case of :func:`cases`, one factor at a time from
a baseline, each wire run against the sand run of the same seed, preparation and
confinement.  :func:`case` runs one (a module-level function: the sweep's Dask workers
import it) and returns its scalars; :func:`summarize` pairs them by seed into Δq/q with
two standard errors; :func:`figure` draws Δq/q against each factor.

Baseline: the paper's cylinder at ``scale`` (1: Ø9 mm × 20 mm, 6 200 grains, a wire of
250 km·m⁻³ walked by Eq. 16), ElasticWire(k = 1 N), μ = 0.5, μ_wire = 0.3, p = 15 kPa, 10 %
strain, the paper's preparation (§2.4: the geometric sample relaxed under gravity in its
mould, then confined on its free surface, §3.3).
"""
from __future__ import annotations

import math
import os

import numpy as np

__all__ = ["BASELINE", "FACTORS", "STRAINS", "cases", "case", "summarize", "figure",
           "markdown_table", "CHAIN", "SIDE", "chain_cases", "chain_case", "summarize_chain",
           "chain_markdown"]

#: The strains at which q is compared [-].
STRAINS = (0.02, 0.05, 0.10)

#: The baseline's parameters (a case is the baseline with one of them changed).
BASELINE = dict(wire="elastic", k=1.0, preparation="paper", wire_density=None,
                wire_mode="isotropic", mu_wire=0.3, wire_prestrain=0.0,
                confinement="free_surface")

#: factor -> [(level label, the parameters that differ from the baseline)], in the order the
#: study runs them: the law with the paper's preparation (Fig. 14, Table 2), then the
#: positive controls of issue 30 §3, then the law with the geometric preparation.
FACTORS = {
    "law, paper preparation": [("rigid", dict(wire="rigid", k=None)), ("k = 0.2 N", dict(k=0.2)),
                               ("k = 1 N", {}), ("k = 10 N", dict(k=10.0))],
    "wire–sand friction": [("μ_wire = 0.5 (the sand's)", dict(mu_wire=0.5)),
                           ("μ_wire = 0.8", dict(mu_wire=0.8))],
    "prestrain at the loading": [("ε₀ = 1 %", dict(wire_prestrain=0.01)),
                                 ("ε₀ = 5 %", dict(wire_prestrain=0.05))],
    "wire content": [("2 × (500 km/m³)", dict(wire_density=500e3)),
                     ("4 × (1 000 km/m³)", dict(wire_density=1000e3))],
    "orthotropic wire (Eq. 17)": [("orthotropic", dict(wire_mode="orthotropic"))],
    "layer-crown confinement": [("k = 1 N", dict(confinement="layer_crown"))],
    # added after the first 28 cases (the prestrain relaxed at once: do the beads slip
    # through the pores, or fold onto each other?): not in BASELINE, so the cases run
    # before keep their keys
    "bead size": [("r_w = 0.27 mm (2 ×)", dict(bead_radius=0.27e-3))],
    "solid beads (neighbour_contact)": [("linked beads touch", dict(neighbour_contact=True))],
    "law, geometric preparation": [
        ("rigid", dict(wire="rigid", k=None, preparation="geometric")),
        ("k = 0.2 N", dict(k=0.2, preparation="geometric")),
        ("k = 1 N", dict(preparation="geometric")),
        ("k = 10 N", dict(k=10.0, preparation="geometric"))],
}


#: Wire knobs some levels set and the baseline leaves out (its cases' keys stay as they
#: were): the bead radius [m] and solid beads.
EXTRA_KEYS = ("bead_radius", "neighbour_contact")

#: The keys of a case that are not factors.
_NOT_FACTORS = ("seed", "scale", "axial_strain", "name")


def _sand_key(params) -> tuple:
    """What the sand run a wire run is compared with shares with it."""
    return params["seed"], params["preparation"], params["confinement"]


def cases(seeds, scale=1.0, *, factors=None, axial_strain=0.1) -> list[dict]:
    """Every case of the study for ``seeds`` (seed-major within each factor, so the first
    seeds of the first factors finish first), the sand runs they need first; each a dict of
    JSON-able parameters with its ``name``."""
    out, seen = [], set()
    for factor in (factors or FACTORS):
        for label, change in FACTORS[factor]:
            for seed in seeds:
                p = dict(BASELINE, **change, seed=int(seed), scale=float(scale),
                         axial_strain=float(axial_strain))
                sand = dict(p, wire="none", k=None, wire_density=None, wire_mode="isotropic",
                            mu_wire=BASELINE["mu_wire"], wire_prestrain=0.0)
                for key in EXTRA_KEYS:          # wire-only knobs: the same sand run
                    sand.pop(key, None)
                for c in (sand, p):
                    c["name"] = _name(c)
                    if c["name"] not in seen:
                        seen.add(c["name"])
                        out.append(c)
    return out


def _name(p) -> str:
    if p["wire"] == "none":
        parts = ["sand"]
    else:
        parts = [p["wire"] if p["k"] is None else f"k{p['k']:g}"]
        if p["wire_density"] is not None:
            parts.append(f"wd{p['wire_density'] / 1e3:g}k")
        if p["wire_mode"] != "isotropic":
            parts.append(p["wire_mode"])
        if p["mu_wire"] != BASELINE["mu_wire"]:
            parts.append(f"muw{p['mu_wire']:g}")
        if p["wire_prestrain"]:
            parts.append(f"eps{p['wire_prestrain']:g}")
        if p.get("bead_radius") is not None:
            parts.append(f"rw{p['bead_radius'] * 1e3:g}mm")
        if p.get("neighbour_contact"):
            parts.append("solid")
    parts += [p["preparation"], p["confinement"], f"seed{p['seed']}"]
    return "_".join(parts)


def _q_parts(stress) -> np.ndarray:
    """q = σ_a − σ_r (compression positive) of Weber tensors (tension positive) (n, 3, 3)."""
    s = np.asarray(stress)
    return -s[:, 2, 2] + (s[:, 0, 0] + s[:, 1, 1]) / 2


def case(*, name, wire, k, seed, runs_dir, scale=1.0, **params) -> dict:
    """One cylinder triaxial run of the study; its scalars (q, its sand and wire parts at
    :data:`STRAINS`, the state at the start of the loading, the wire–sand sliding, the
    solver's figures)."""
    from engine.experiments import cylinder_triaxial
    from engine.experiments.config import wire_spec
    from workbench.campaign import not_interrupted

    os.makedirs(runs_dir, exist_ok=True)
    law = wire_spec(wire, k).to_law()
    kw = {n: v for n, v in params.items() if v is not None or n == "overlap_tol"}
    if wire == "none":
        kw.pop("wire_prestrain", None)
    res = not_interrupted(cylinder_triaxial(
        scale, wire=law is not None, wire_law=law, seed=seed,
        history=os.path.join(runs_dir, f"{name}.h5"), progress=False, **kw),
        name, dict(seed=seed, **params))
    eps = np.asarray(res.axial_strain)
    out = _q_at(eps, res.deviator, res.sand_stress, res.wire_stress)
    start = res.extra.get("start", {})
    out.update(wire_eq_start=float(res.wire_equivalent[0]) if eps.size else math.nan,
               mean_stress_start=float(res.mean_stress[0]) if eps.size else math.nan,
               solid_fraction=start.get("solid_fraction", math.nan),
               **{key: start.get(key, math.nan) for key in START_KEYS},
               taut_share=start.get("taut_share", math.nan),
               mean_tension=start.get("mean_tension", math.nan),
               max_tension=start.get("max_tension", math.nan),
               iso_reached=bool(res.params.get("iso_reached")),
               n_sand=res.params["n_sand"], n_beads=res.params["n_beads"],
               steps=res.convergence.get("steps"),
               non_converged_share=res.convergence.get("share"),
               wall_time=res.convergence.get("wall_time"))
    dep = start.get("deposit")
    if dep:
        out.update(deposit_steps=dep["steps"], deposit_at_rest=bool(dep["at_rest"]),
                   deposit_settlement=dep["settlement"])
    fits = res.extra.get("best_fit_strain", {})
    if "wire" in fits and "sand" in fits:
        ew, es = fits["wire"].principal, fits["sand"].principal
        out["sliding_gap"] = float(np.linalg.norm(ew - es) / max(np.linalg.norm(es), 1e-300))
    return out


#: What the cylinder test reports of the loading start on the basis every sample shares
#: (``extra["start"]``: the membrane wraps grains and beads).
START_KEYS = ("solid_fraction_all", "core_solid_fraction", "core_sand_fraction", "radius",
              "sand_outer_radius")

#: A run's last record counts as reaching a strain of :data:`STRAINS` this close below it
#: [-] (the loading's last step ends within one step of the target: 0.09998 for 0.1).
STRAIN_SLACK = 1e-3


def _q_at(eps, q, sand_stress, wire_stress) -> dict:
    """q, its sand and wire parts, the wire's equivalent stress ‖dev σ_w‖ (Fig. 15) and its
    mean stress tr σ_w / 3 (tension positive: the preload, which ‖dev σ_w‖ misses when it
    is isotropic) [Pa] at each strain of :data:`STRAINS` (nan beyond the run's last strain), the record count
    and the final strain."""
    from engine.analysis import equivalent_stress

    eps = np.asarray(eps)
    out = dict(records=int(eps.size), final_strain=float(eps[-1]) if eps.size else math.nan)
    if eps.size:
        k = int(np.argmax(q))
        out.update(q_peak=float(np.asarray(q)[k]), strain_peak=float(eps[k]))
    parts = (("q", np.asarray(q)), ("q_sand", _q_parts(sand_stress)),
             ("q_wire", _q_parts(wire_stress)),
             ("wire_eq", np.array([equivalent_stress(t) for t in np.asarray(wire_stress)])),
             ("wire_mean", np.trace(np.asarray(wire_stress), axis1=1, axis2=2) / 3))
    for e in STRAINS:
        tag = f"{round(e * 100):d}"
        ok = eps.size and eps[-1] >= e - STRAIN_SLACK
        for key, arr in parts:
            out[f"{key}_{tag}"] = float(np.interp(e, eps, arr)) if ok else math.nan
    return out


def rescore(name, result, runs_dir) -> dict:
    """``result`` with its q figures recomputed from the run's history ``runs_dir/name.h5``
    (the loading's records, from the last isotropic one), as :func:`case` computes them
    now; ``result`` as it is when the history is not there."""
    from engine.io import read_history

    path = os.path.join(runs_dir, f"{name}.h5")
    if not os.path.isfile(path):
        return dict(result)
    h = read_history(path, frames=False)
    st = np.asarray(h.extra["stage"])
    first = int(np.flatnonzero(st == 1)[0])
    sel = slice(first - 1, None)
    H = np.asarray(h.extra["height"])[sel]
    stress = np.asarray(h.extra["stress"])[sel]
    q = -stress[:, 2, 2] + (stress[:, 0, 0] + stress[:, 1, 1]) / 2
    out = dict(result)
    out.update(_q_at(1 - H / H[0], q, np.asarray(h.extra["sand_stress"])[sel],
                     np.asarray(h.extra["wire_stress"])[sel]), rescored=True)
    return out


def _stats(values) -> dict:
    v = np.asarray([x for x in values if x is not None and math.isfinite(x)], float)
    n = int(v.size)
    mean = float(v.mean()) if n else math.nan
    se = float(v.std(ddof=1) / math.sqrt(n)) if n > 1 else math.nan
    return dict(n=n, mean=mean, two_se=2 * se, per_seed=[float(x) for x in v])


def summarize(rows: list[dict]) -> dict:
    """``rows``: (params, result) of the finished cases.  Per factor and level: Δq/q against
    the sand run of the same seed, preparation and confinement at each strain of
    :data:`STRAINS` (mean, two standard errors, per seed), and the means of the other
    figures; the sand runs' own figures per preparation and confinement."""
    by_name = {p["name"]: (p, r) for p, r in rows}
    sand = {_sand_key(p): r for p, r in rows if p["wire"] == "none"}
    out = {"factors": {}, "sand": {}}
    for (seed, prep, conf), r in sorted(sand.items()):
        s = out["sand"].setdefault(f"{prep}, {conf}", {"seeds": []})
        s["seeds"].append(seed)
        for key in ("q_2", "q_5", "q_10", "solid_fraction", "mean_stress_start"):
            s.setdefault(key, []).append(r.get(key))
    for factor, levels in FACTORS.items():
        f = out["factors"][factor] = {}
        for label, change in levels:
            want = dict(BASELINE, **change)
            runs = [(p, r) for p, r in rows if p["wire"] != "none"
                    and set(p) - set(_NOT_FACTORS) == set(want)
                    and all(p.get(n) == v for n, v in want.items())]
            if not runs:
                continue
            lv = f[label] = {"seeds": [p["seed"] for p, _ in runs]}
            for e in STRAINS:
                tag = f"{round(e * 100):d}"
                rel = []
                for p, r in runs:
                    ref = sand.get(_sand_key(p))
                    if ref is not None and ref.get(f"q_{tag}") and r.get(f"q_{tag}") is not None:
                        rel.append(r[f"q_{tag}"] / ref[f"q_{tag}"] - 1)
                lv[f"dq_{tag}"] = _stats(rel)
                lv[f"q_wire_share_{tag}"] = _stats(
                    [r.get(f"q_wire_{tag}", math.nan) / r[f"q_{tag}"] for _, r in runs
                     if r.get(f"q_{tag}")])
            for key in ("wire_eq_start", "wire_eq_2", "wire_eq_10", "wire_mean_2",
                        "wire_mean_10", "taut_share",
                        "mean_tension", "solid_fraction", "sliding_gap",
                        "non_converged_share", "wall_time"):
                lv[key] = _stats([r.get(key, math.nan) for _, r in runs])
    del by_name
    return out


def figure(summary: dict, path, tags=("2", "5", "10")):
    """Δq/q at the strains of :data:`STRAINS` (``tags``: their values in %, one panel each)
    against each factor's levels: the mean over seeds with two standard errors and each
    seed; the paper's Fig. 14 gains as dashed lines."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [(factor, label, lv) for factor, levels in summary["factors"].items()
            for label, lv in levels.items()]
    fig, axes = plt.subplots(1, len(tags), figsize=(4.2 + 2.6 * len(tags),
                                                    0.36 * len(rows) + 1.7),
                             sharey=True, squeeze=False)
    y = np.arange(len(rows))[::-1]
    for ax, tag in zip(axes[0], tags):
        for yi, (factor, label, lv) in zip(y, rows):
            st = lv[f"dq_{tag}"]
            if not st["n"]:
                continue
            ax.errorbar(100 * st["mean"], yi, xerr=100 * st["two_se"] if st["n"] > 1 else None,
                        fmt="o", color="C0", capsize=3, ms=5)
            ax.plot(100 * np.asarray(st["per_seed"]), np.full(st["n"], yi), "x", color="0.45",
                    ms=4)
        ax.axvline(0, color="k", lw=0.8)
        for val in (7, 23):
            ax.axvline(val, color="C3", lw=0.8, ls="--")
        ax.set_title(f"at {tag} % axial strain", fontsize=9)
        ax.set_xlabel("Δq/q against the sand [%]", fontsize=8)
        ax.tick_params(labelsize=8)
        ax.grid(axis="x", lw=0.3, color="0.8")
    axes[0][0].set_yticks(y, [f"{factor}: {label}" for factor, label, _ in rows], fontsize=8)
    axes[0][0].set_ylim(-0.8, len(rows) - 0.2)
    fig.suptitle("Cylinder triaxial (paper size): q of the wire runs against the sand of the "
                 "same seed — mean ± 2 SE (o), each seed (×); dashed: the paper's +7 % "
                 "(k = 0.2 N) and +23 % (rigid)", fontsize=8)
    fig.tight_layout()
    from engine.files import replacing

    try:
        with replacing(path, "the figure could not be written") as tmp:
            fig.savefig(tmp, dpi=150)
    finally:
        plt.close(fig)
    return path


def _pm(st, scale=100.0, fmt="+.1f"):
    if not st["n"]:
        return "—"
    if st["n"] < 2:
        return f"{scale * st['mean']:{fmt}} (1 seed)"
    return f"{scale * st['mean']:{fmt}} ± {scale * st['two_se']:{fmt.lstrip('+')}}"


def markdown_table(summary: dict) -> str:
    """The summary as a Markdown table: per factor and level, the seeds, Δq/q [%] at each
    strain of :data:`STRAINS` (mean ± 2 SE), the wire's share of q at 10 %, the wire's
    equivalent stress [Pa], share of taut links and mean tension [mN] at the start of the
    loading, the solid fraction then, and the wire–sand sliding gap; then the sand runs."""
    head = ("| factor | level | seeds | Δq/q 2 % | Δq/q 5 % | Δq/q 10 % | q_wire/q 10 % [%] "
            "| σ_w,eq start / 2 % / 10 % [Pa] | tr σ_w/3 2 % / 10 % [Pa] | taut links "
            "| mean T [mN] | solid fraction | sliding gap |")
    lines = [head, "|" + "---|" * 13]
    for factor, levels in summary["factors"].items():
        for label, lv in levels.items():
            lines.append("| " + " | ".join([
                factor, label, ",".join(map(str, lv["seeds"])),
                _pm(lv["dq_2"]), _pm(lv["dq_5"]), _pm(lv["dq_10"]),
                _pm(lv["q_wire_share_10"], fmt=".2f"),
                " / ".join(_pm(lv[k], 1.0, ".0f") for k in ("wire_eq_start", "wire_eq_2",
                                                              "wire_eq_10")),
                " / ".join(_pm(lv[k], 1.0, ".0f") for k in ("wire_mean_2", "wire_mean_10")),
                _pm(lv["taut_share"], 1.0, ".2f"),
                _pm(lv["mean_tension"], 1e3, ".2f"), _pm(lv["solid_fraction"], 1.0, ".3f"),
                _pm(lv["sliding_gap"], 1.0, ".2f")]) + " |")
    lines += ["", "| sand runs | seeds | q 2 % [kPa] | q 5 % [kPa] | q 10 % [kPa] | solid fraction |",
              "|---|---|---|---|---|---|"]
    for key, s in summary["sand"].items():
        def cell(name, scale, fmt):
            v = [x for x in s.get(name, []) if x is not None and math.isfinite(x)]
            return ", ".join(f"{scale * x:{fmt}}" for x in v) or "—"
        lines.append(f"| {key} | {','.join(map(str, s['seeds']))} | {cell('q_2', 1e-3, '.2f')} "
                     f"| {cell('q_5', 1e-3, '.2f')} | {cell('q_10', 1e-3, '.2f')} "
                     f"| {cell('solid_fraction', 1.0, '.3f')} |")
    return "\n".join(lines) + "\n"


# -- the decomposition: sand -> matched sand -> loose beads -> TexSol -------------------------
#: The chain that splits the gap between a TexSol sample and the sand, each step differing
#: from the one before by one thing: the packing the beads leave in the sand (the TexSol
#: sample's sand, laid around the beads, then prepared and tested without them), the beads
#: as bodies (the TexSol sample with its links loose, :class:`engine.laws.LooseWire`), the
#: links' force (the TexSol sample itself).
CHAIN = (("sand", dict(wire="none", k=None)),
         ("matched sand", dict(remove_beads="after_deposit")),
         ("loose beads", dict(wire="loose", k=None)),
         ("TexSol", {}))

#: A control beside the chain: the TexSol sample's own packing at the start of the loading,
#: its beads taken out there (``remove_beads="at_loading"``).
SIDE = (("packing without beads", dict(remove_beads="at_loading")),)

#: What every case of the chain shares unless a case says otherwise.
CHAIN_BASE = dict(wire="elastic", k=1.0, preparation="paper", pressure=15e3,
                  remove_beads="never")

#: The figures :func:`summarize_chain` compares: q at each strain of :data:`STRAINS` and at
#: its peak.
CHAIN_TAGS = ("2", "5", "10", "peak")


#: ``overlap_tol`` of :func:`chain_cases` when it is not given: the cases carry none (the
#: engine's default then, and the keys of the tables run before the position correction).
UNSET = object()


def chain_cases(seeds, scale=1.0, *, pressures=(15e3,), preparations=("paper",),
                wire="elastic", k=1.0, axial_strain=0.1, side=True,
                overlap_tol=UNSET) -> list[dict]:
    """The cases of the decomposition (:data:`CHAIN`, and :data:`SIDE` with ``side``) for
    every seed, pressure [Pa] and preparation, seed-major; the TexSol sample's law is
    ``wire`` with stiffness ``k`` [N] (None for the rigid wire).  ``overlap_tol``, when
    given (None too), goes into every case and its name (``_ov0.005``, ``_ovnone``), so
    that runs with and without the position correction never share a table row or a
    history."""
    out = []
    steps = CHAIN + (SIDE if side else ())
    for prep in preparations:
        for p in pressures:
            for seed in seeds:
                for step, change in steps:
                    c = dict(CHAIN_BASE, wire=wire, k=k, preparation=prep, pressure=float(p))
                    c.update(change, seed=int(seed), scale=float(scale),
                             axial_strain=float(axial_strain), step=step)
                    if overlap_tol is not UNSET:
                        c["overlap_tol"] = overlap_tol
                    c["name"] = _chain_name(c)
                    out.append(c)
    return out


def _chain_name(c) -> str:
    law = "sand" if c["wire"] == "none" else (
        c["wire"] if c["k"] is None else f"{c['wire']}{c['k']:g}")
    parts = ["chain", law]
    if c["remove_beads"] != "never":
        parts.append(f"removed-{c['remove_beads']}")
    parts += [c["preparation"], f"p{c['pressure'] / 1e3:g}k", f"seed{c['seed']}"]
    if "overlap_tol" in c:
        parts.append("ovnone" if c["overlap_tol"] is None else f"ov{c['overlap_tol']:g}")
    return "_".join(parts)


def chain_case(*, step, **params) -> dict:
    """One case of the chain (:func:`case`; ``step`` names its place in :data:`CHAIN`)."""
    return case(**params)


def _chain_group(p) -> str:
    return f"{p['preparation']} preparation, p = {p['pressure'] / 1e3:g} kPa"


def summarize_chain(rows: list[dict]) -> dict:
    """``rows``: (params, result) of finished chain cases.  Per preparation and pressure:
    each step of :data:`CHAIN` against the one before it, each step and the side control
    against the sand, and the TexSol sample against its loose twin, as Δq/q paired by seed
    at each of :data:`CHAIN_TAGS` (mean, two standard errors, per seed); and each step's
    state at the start of the loading (solid fractions, core solid fraction, the membrane's
    radius, the sand's outer radius)."""
    groups: dict = {}
    for p, r in rows:
        g = groups.setdefault(_chain_group(p), {})
        g.setdefault(p["step"], {})[p["seed"]] = r
    names = [n for n, _ in CHAIN]
    pairs = [(b, a) for a, b in zip(names, names[1:])]
    pairs += [(n, "sand") for n in names[2:]] + [(n, "sand") for n, _ in SIDE]
    pairs += [(n, "TexSol") for n, _ in SIDE]
    out = {}
    for key, g in groups.items():
        o = out[key] = {"seeds": sorted({s for v in g.values() for s in v}), "pairs": {},
                        "start": {}, "q": {}}
        for b, a in pairs:
            if a not in g or b not in g:
                continue
            seeds = sorted(set(g[a]) & set(g[b]))
            entry = o["pairs"][f"{b} / {a}"] = {"seeds": seeds}
            for tag in CHAIN_TAGS:
                rel = [g[b][s][f"q_{tag}"] / g[a][s][f"q_{tag}"] - 1 for s in seeds
                       if g[a][s].get(f"q_{tag}") and g[b][s].get(f"q_{tag}") is not None]
                entry[f"dq_{tag}"] = _stats(rel)
        for step, runs in g.items():
            o["start"][step] = {k: _stats([r.get(k, math.nan) for r in runs.values()])
                                for k in ("solid_fraction", *START_KEYS, "mean_tension",
                                          "taut_share")}
            o["q"][step] = {f"q_{t}": _stats([r.get(f"q_{t}", math.nan) for r in runs.values()])
                            for t in CHAIN_TAGS}
    return out


def chain_markdown(summary: dict) -> str:
    """The decomposition as Markdown: per preparation and pressure, each comparison's Δq/q
    [%] (mean ± 2 SE) at 2, 5, 10 % and the peak; then each step's start."""
    lines = []
    for key, o in summary.items():
        lines += [f"### {key} (seeds {', '.join(map(str, o['seeds']))})", "",
                  "| comparison | seeds | Δq/q 2 % | Δq/q 5 % | Δq/q 10 % | Δq/q peak |",
                  "|---|---|---|---|---|---|"]
        for name, e in o["pairs"].items():
            lines.append(f"| {name} | {len(e['seeds'])} | " + " | ".join(
                _pm(e[f"dq_{t}"]) for t in CHAIN_TAGS) + " |")
        lines += ["", "| sample | q 2 / 5 / 10 % / peak [kPa] | solid fraction (sand; all) | "
                      "core solid fraction | R [mm] | sand's outer radius [mm] |",
                  "|---|---|---|---|---|---|"]
        for step, st in o["start"].items():
            q = " / ".join(_pm(o["q"][step][f"q_{t}"], 1e-3, ".2f") for t in CHAIN_TAGS)
            lines.append(f"| {step} | {q} | {_pm(st['solid_fraction'], 1.0, '.3f')}; "
                         f"{_pm(st['solid_fraction_all'], 1.0, '.3f')} | "
                         f"{_pm(st['core_solid_fraction'], 1.0, '.3f')} | "
                         f"{_pm(st['radius'], 1e3, '.3f')} | "
                         f"{_pm(st['sand_outer_radius'], 1e3, '.3f')} |")
        lines.append("")
    return "\n".join(lines)
