"""The scoring of each claim: what our numbers give for it, as a :class:`Verdict` per row
(a claim's rows are in :mod:`.registry`).  ``score_figN(curves, scale)`` reads the curves of
the runs by name; the ``_figN`` helpers take the runs of several seeds."""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .cases import TAGS10, TAGS14, TAGS14_PARTS, boxes, deposits, tags15
from .scales import fig10_seeds
from .stats import (_against, _seed_stats, _significant, _spearman, _H_list, _H_of, h_fit,
                    heap_slopes)


class Verdict(NamedTuple):
    """One row's outcome: ``ok`` (True / False / None: not comparable), our numbers in
    words, and a caveat on these numbers that the report puts before the row's note."""

    ok: bool | None
    ours: str
    caveat: str = ""


# ---------------------------------------------------------------- several seeds

def _fig7(runs, seeds):
    """Fig. 7 on the deposits under gravity of several seeds (``runs``: curves or None):
    (verdict, text).  ξ after > ξ before on every seed and the mean of (after / before − 1)
    above 0 beyond 2 standard errors; not comparable when a seed's deposit did not come to
    rest (its ξ is not the relaxed sample's).  The text gives each seed's settlement, the
    change of the wire's length and its slack links, what the rise of ξ comes with."""
    got = [(sd, r) for sd, r in zip(seeds, runs) if r is not None and "tortuosity_before" in r]
    if not got:
        return None, "runs missing"
    rel = [float(r["tortuosity_after"]) / float(r["tortuosity_before"]) - 1 for _, r in got]
    m, sd_, n = _seed_stats(rel)
    sig = _significant(m, sd_, n)
    moving = [sd for sd, r in got if not bool(r.get("at_rest", True))]
    ok = None if sig is None or moving else (sig and all(x > 0 for x in rel))

    def one(sd, r):
        b, a = float(r["tortuosity_before"]), float(r["tortuosity_after"])
        t = f"seed {sd}: {b:.0f} → {a:.0f} m⁻¹ ({a / b - 1:+.0%}, settlement " \
            f"{float(r['settlement']) * 1e6:.0f} µm"
        if "wire_length_before" in r:
            dl = float(r["wire_length_after"]) / float(r["wire_length_before"]) - 1
            t += f", wire length {dl:+.1%}, {float(r['slack_share']):.0%} of the links slack"
        return t + (", NOT at rest" if sd in moving else "") + ")"

    spread = f"{m:+.0%} ± {sd_:.0%} (mean ± std over {n} seeds)" if n > 1 else \
        f"{m:+.0%} (one seed)"
    text = f"{spread}; " + "; ".join(one(sd, r) for sd, r in got)
    if moving:
        text += f"; not comparable: seed(s) {', '.join(map(str, moving))} not at rest"
    return ok, text


def _fig10(runs, seeds):
    """Fig. 10 a-b on the slope deposits of several seeds (``runs``: per seed a dict sand /
    w400 / w800 of curves): two (verdict, text).  a: θ of each TexSol heap minus the sand's,
    paired by seed, > 0 beyond 2 standard errors for both contents; b: θ(800) − θ(400).
    θ is the maximum slope of the height regression; each difference must hold both with
    the paper's fits (:data:`PAPER_FIT_DEGREE`) and with one cubic for every heap, since
    the paper's fits alone favour the heap fitted with the higher degree."""
    tags = ("sand", "w400", "w800")
    th = {m: {t: [] for t in tags} for m in ("paper", "common", "line")}
    used, unfit = [], []
    for sd, r in zip(seeds, runs):
        if any(r[t] is None for t in tags):
            continue
        try:
            slopes = {t: heap_slopes(r[t], t) for t in tags}
        except ValueError as e:            # a small heap over fewer bins than a fit needs
            unfit.append(f"seed {sd} left out: {e}")
            continue
        used.append(sd)
        for t in tags:
            for m, v in slopes[t].items():
                th[m][t].append(v)
    if not used:
        why = "; ".join(unfit) if unfit else "runs missing"
        return (None, why), (None, why)
    n = len(used)
    over = f" (mean ± std over {n} seeds)" if n > 1 else ""

    def per_seed(m):
        return "; ".join(f"seed {sd}: " + ", ".join(f"{th[m][t][k]:.1f}°" for t in tags)
                         for k, sd in enumerate(used))

    def diff(m, a, b):
        return _seed_stats([x - y for x, y in zip(th[m][a], th[m][b])])

    def fmt(d):
        return f"{d[0]:+.1f}° ± {d[1]:.1f}°" if d[2] > 1 else f"{d[0]:+.1f}° (one seed)"

    def both(sig):
        return None if None in sig else all(sig)

    d = {m: {k: diff(m, *ab) for k, ab in (("400", ("w400", "sand")), ("800", ("w800", "sand")),
                                          ("84", ("w800", "w400")))} for m in th}
    ok_a = both([_significant(*d[m][k]) for m in ("paper", "common") for k in ("400", "800")])
    ok_b = both([_significant(*d[m]["84"]) for m in ("paper", "common")])
    base = (f"max slope, sand / 400 / 800 km·m⁻³, with the paper's fits (line, cubic, 8th "
            f"degree), per seed: {per_seed('paper')}; with a cubic for every heap: "
            f"{per_seed('common')}; straight lines"
            + (f", mean of {n} seeds" if n > 1 else "") + ": "
            + " / ".join(f"{np.mean(th['line'][t]):.1f}°" for t in tags))
    left = "".join(f"; {u}" for u in unfit)
    a = (ok_a, f"{base}; TexSol − sand{over}, paper's fits: 400 {fmt(d['paper']['400'])}, "
               f"800 {fmt(d['paper']['800'])}; one cubic: 400 {fmt(d['common']['400'])}, "
               f"800 {fmt(d['common']['800'])}{left}")
    b = (ok_b, f"max slope at 800 minus at 400 km·m⁻³, paired by seed{over}: paper's fits "
               f"(8th degree against cubic) {fmt(d['paper']['84'])}, one cubic "
               f"{fmt(d['common']['84'])}; per seed with one cubic "
               + ", ".join(f"{x:+.1f}°" for x in np.subtract(th["common"]["w800"],
                                                              th["common"]["w400"]))
               + f" (each heap's slope in fig10a){left}")
    return a, b


def _fig11(runs, seeds):
    """Fig. 11 a-c on the box runs (r_w = r_min) of several seeds: three (verdict, text).
    a: every record of every seed; b: per seed, the upper-half ratio σ_zz / max(σ_xx, σ_yy)
    at the end, below 1/3 beyond 2 standard errors (:func:`_significant` on 1/3 − ratio),
    with both horizontal stresses of the seeds' mean tensor > 0; c: the upper/lower ratio
    of ‖σ_w‖ at the end, paired by seed (:func:`_significant` on its logarithm)."""
    mins, ups, logs, per_b, ratios = [], [], [], [], []
    for sd, t in zip(seeds, runs):
        if t is None or "wire_stress_upper" not in t:
            continue
        eig = np.linalg.eigvalsh(np.asarray(t["wire_stress"]))
        mins.append((float(eig.min() / max(float(np.abs(eig).max()), 1e-300)), sd))
        up = np.asarray(t["wire_stress_upper"])[-1]
        lo = np.asarray(t["wire_stress_lower"])[-1]
        if np.all(np.isfinite(up)):
            ups.append(up)
            h = max(up[0, 0], up[1, 1])
            per_b.append(f"seed {sd}: {up[2, 2] / h:.2f}" if h > 0 else f"seed {sd}: n/a")
            if h > 0:
                ratios.append(float(up[2, 2] / h))
        nu, nl = float(np.linalg.norm(up)), float(np.linalg.norm(lo))
        if np.isfinite(nu) and np.isfinite(nl) and nu > 0 and nl > 0:
            logs.append(math.log(nu / nl))
    if not mins:
        return ((None, "runs missing"),) * 3
    worst, wsd = min(mins)
    a = (worst > -1e-6, f"smallest principal wire stress / largest over the loading, worst "
                        f"of {len(mins)} seeds: {worst:.2e} (seed {wsd})")
    b = (None, "no upper-half stress")
    if ups:
        up = np.mean(ups, axis=0)
        h = max(up[0, 0], up[1, 1])
        ratio = float(up[2, 2] / h) if h > 0 else float("nan")
        rm, rsd, rn = _seed_stats(ratios)
        below = _significant(1 / 3 - rm, rsd, rn)
        b = (None if below is None or not h > 0 else
             bool(below and min(up[0, 0], up[1, 1]) > 0),
             f"upper half at the end, mean of {len(ups)} seeds: σ_xx {up[0, 0]:.3g}, σ_yy "
             f"{up[1, 1]:.3g}, σ_zz {up[2, 2]:.3g} Pa (σ_zz / max horizontal = {ratio:.2f}); "
             f"the seeds' ratios {rm:.2f} ± {rsd:.2f} (per seed " + ", ".join(per_b) + ")")
    m, sd_, n = _seed_stats(logs)
    c_ = (_significant(m, sd_, n),
          f"‖σ_w‖ upper / lower at the end: geometric mean {math.exp(m):.2f} "
          f"(ln ratio {m:+.2f} ± {sd_:.2f} over {n} seeds; per seed "
          + ", ".join(f"{math.exp(x):.2f}" for x in logs) + ")" if n else "no ratio")
    return a, b, c_


def _fig12(runs, seeds):
    """Fig. 12 a-b on the box runs of r_w = r_min, r_min/3, r_min/4 of several seeds
    (``runs``: per seed a dict 1 / 3 / 4 of curves): ((verdict a, verdict b), text).
    Per run, the gap ‖ε_wire − ε_sand‖ / ‖ε_sand‖ of the best-fit principal strains (Eq. 19)
    over the loading.  a: the r_min gap below 0.25 beyond 2 standard errors; b: the r_min/3
    and r_min/4 gaps minus the r_min gap of the same seed, both above 0 beyond 2 standard
    errors."""
    gaps, used = {1: [], 3: [], 4: []}, []
    for sd, r in zip(seeds, runs):
        g = {}
        for d, t in r.items():
            if t is not None and "strain_wire_principal" in t and "strain_sand_principal" in t:
                ew = np.asarray(t["strain_wire_principal"])
                es = np.asarray(t["strain_sand_principal"])
                g[d] = float(np.linalg.norm(ew - es) / max(np.linalg.norm(es), 1e-300))
        if len(g) == 3:
            used.append(sd)
            for d in g:
                gaps[d].append(g[d])
    if not used:
        return (None, None), "runs missing"
    stats = {d: _seed_stats(gaps[d]) for d in gaps}
    m1, s1, n = stats[1]
    a = _significant(0.25 - m1, s1, n)
    diffs = {d: _seed_stats(np.subtract(gaps[d], gaps[1])) for d in (3, 4)}
    sig = [_significant(*diffs[d]) for d in (3, 4)]
    b = None if None in sig else all(sig)
    text = ("‖ε_wire − ε_sand‖ / ‖ε_sand‖ (principal strains at the end), mean ± std over "
            f"{n} seeds: r_min {m1:.2f} ± {s1:.2f}, r_min/3 "
            + ", r_min/4 ".join(f"{stats[d][0]:.2f} ± {stats[d][1]:.2f}" for d in (3, 4))
            + "; minus the r_min gap of the same seed: r_min/3 "
            + ", r_min/4 ".join(f"{diffs[d][0]:+.2f} ± {diffs[d][1]:.2f}" for d in (3, 4))
            + "; per seed (r_min, r_min/3, r_min/4) "
            + "; ".join(f"seed {sd}: {gaps[1][i]:.2f}, {gaps[3][i]:.2f}, {gaps[4][i]:.2f}"
                        for i, sd in enumerate(used)))
    return (a, b), text


def _fig13c(runs, seeds):
    """Fig. 13c on the cylinder runs (k = 1 N) of several seeds: (verdict or None, text).

    Each run's slab profile (``torus_slab_equivalent``, :meth:`ToroidalMap.slab_equivalent`)
    is one reading.  Per seed, the contrast c = (m − o) / (m + o) of the mean slab σ_w^eq
    in the middle third of the height (m: slab centres in [H/3, 2H/3]) against the other
    slabs (o); the claim needs the mean of c > 0 beyond 2 standard errors (the rule of
    Fig. 11c and 14), so that a maximum one seed shows and the next does not is not called a
    result.  The text also gives the largest slab of the mean profile and of each seed."""
    profs, where, zc, frac_cell, strain, contrast = [], [], None, None, None, []
    for sd, t in zip(seeds, runs):
        if t is None or "torus_slab_equivalent" not in t:
            continue
        strain = float(t["torus_strain"])
        ze = np.asarray(t["torus_z_edges"])
        zc = 0.5 * (ze[1:] + ze[:-1]) / ze[-1]
        prof = np.asarray(t["torus_slab_equivalent"], float)
        profs.append(prof)
        where.append(f"seed {sd}: {zc[int(np.argmax(prof))]:.2f}")
        mid = (zc >= 1 / 3) & (zc <= 2 / 3)
        m, o = float(prof[mid].mean()), float(prof[~mid].mean())
        if m + o > 0:
            contrast.append((m - o) / (m + o))
        if frac_cell is None:
            eq = np.asarray(t["torus_equivalent"], float)
            if np.any(np.isfinite(eq)):
                kz = int(np.argmax(np.nanmax(np.where(np.isfinite(eq), eq, -np.inf), axis=0)))
                frac_cell = (sd, float(zc[kz]))
    if not profs:
        return None, "runs missing"
    mean = np.mean(profs, axis=0)
    frac = float(zc[int(np.argmax(mean))])
    n = len(contrast)
    cm = float(np.mean(contrast)) if n else float("nan")
    csd = float(np.std(contrast, ddof=1)) if n > 1 else float("nan")
    text = (f"mid-height third against the rest, contrast (m − o)/(m + o) of the mean slab "
            f"σ_w^eq: {cm:+.2f} ± {csd:.2f} over {n} seeds (per seed "
            + ", ".join(f"{v:+.2f}" for v in contrast) + f"; ε = {strain:.0%}, "
            f"{mean.size} slabs); largest slab of the mean profile at z/H = {frac:.2f} "
            "(bottom to top " + ", ".join(f"{v:.0f}" for v in mean) + " Pa); each seed's "
            "largest slab at z/H " + "; ".join(where))
    if frac_cell is not None:
        text += f"; the largest single cell of seed {frac_cell[0]} at z/H = {frac_cell[1]:.2f}"
    return _significant(cm, csd, n), text



# ---------------------------------------------------------------- one claim each

def score_fig7(curves, scale):
    return [Verdict(*_fig7([curves.get(r) for r in deposits(scale)], fig10_seeds(scale)))]


def score_fig8_9(curves, scale):
    t = curves.get("slope_w400_seed0")
    if t is None or "orientation_before" not in t:
        return [Verdict(None, "run missing")]
    ob, oa = np.asarray(t["orientation_before"]), np.asarray(t["orientation_after"])
    zb, za = float(ob[2, 2]), float(oa[2, 2])
    ok = za < zb - 0.02 and za < min(oa[0, 0], oa[1, 1])
    ours = (f"vertical share ⟨n_z²⟩ {zb:.3f} → {za:.3f}; horizontal ⟨n_x²⟩, ⟨n_y²⟩ "
            f"{oa[0, 0]:.3f}, {oa[1, 1]:.3f} after")
    if "tortuosity_before" in t:     # not a claim of the paper: for the reader
        ours += (f"; tortuosity over the slope deposit (the paper gives none) "
                 f"{float(t['tortuosity_before']):.0f} → "
                 f"{float(t['tortuosity_after']):.0f} m⁻¹")
    return [Verdict(ok, ours)]


def score_fig10(curves, scale):
    seeds = fig10_seeds(scale)
    a, b = _fig10([{tag: curves.get(f"slope_{tag}_seed{sd}") for tag in TAGS10}
                   for sd in seeds], seeds)
    return [Verdict(*a), Verdict(*b)]


def score_fig11(curves, scale):
    seeds = scale.fig14_seeds
    return [Verdict(*v) for v in _fig11([curves.get(r) for r in boxes(scale, (1,))], seeds)]


def score_fig12(curves, scale):
    seeds = scale.fig14_seeds
    (ok_a, ok_b), ours = _fig12([{d: curves.get(f"box_rw{d}_seed{sd}") for d in (1, 3, 4)}
                                 for sd in seeds], seeds)
    return [Verdict(ok_a, ours), Verdict(ok_b, ours)]


def _barrel(t):
    """Fig. 13a on one cylinder's curves: (verdict, text)."""
    if t is None or "barrel_r_last" not in t:
        return None, "run missing"
    r1, r0 = np.asarray(t["barrel_r_last"]), np.asarray(t["barrel_r_first"])
    n = r1.size
    mid = float(np.nanmax(r1[n // 3: n - n // 3]))
    ends = float(np.nanmean([r1[0], r1[-1]]))
    return mid > ends, (f"outer radius (95th percentile) at mid-height {1e3 * mid:.3f} mm, at "
                        f"the ends {1e3 * ends:.3f} mm (start: {1e3 * np.nanmean(r0):.3f} mm); "
                        f"frame of step {int(t['barrel_step_last'])}")


def _unilateral(t):
    """Fig. 13b on one cylinder's curves: (verdict, text)."""
    ws = None if t is None else np.asarray(t["wire_stress"])
    if ws is None or not ws.size:
        return None, "run missing"
    eig = np.linalg.eigvalsh(ws)
    min_rel = float(eig.min() / max(float(np.abs(eig).max()), 1e-300))
    return min_rel > -1e-6, f"smallest principal wire stress / largest over the loading: " \
                            f"{min_rel:.2e}"


def score_fig13(curves, scale):
    t = curves.get("cylinder_k1_seed0")
    seeds = scale.fig14_seeds
    return [Verdict(*_barrel(t)), Verdict(*_unilateral(t)),
            Verdict(*_fig13c([curves.get(f"cylinder_k1_seed{sd}") for sd in seeds], seeds))]


def _final_q(t):
    """The deviator q at the final strain of a cylinder's curves (None: no run, no record)."""
    if t is None or not len(t["deviator"]):
        return None
    return float(np.asarray(t["deviator"])[-1])


def score_fig14(curves, scale):
    seeds = scale.fig14_seeds
    q = {tag: {s: _final_q(curves.get(f"cylinder_{tag}_seed{s}")) for s in seeds}
         for tag in TAGS14}
    seeds = [s for s in seeds if all(q[t][s] is not None for t in q)]
    inc = {t: [q[t][s] / q["sand"][s] - 1 for s in seeds] for t in ("k0.2", "rigid")}
    out = []
    for t in ("k0.2", "rigid"):
        m, sd, n = _seed_stats(inc[t])
        ok = _significant(m, sd, n)
        qs = ", ".join(f"{q['sand'][s] / 1e3:.2f} → {q[t][s] / 1e3:.2f} kPa" for s in seeds)
        ours = (f"{m:+.1%} ± {sd:.1%} (mean ± std over {n} seeds; per seed q sand → wire: {qs})"
                if n else "runs missing")
        if ok is False:
            ours += f"; {_against(m, sd, n)}"
        out.append(Verdict(ok, ours))
    dm, dsd, dn = _seed_stats([a - b for a, b in zip(inc["rigid"], inc["k0.2"])])
    out.append(Verdict(_significant(dm, dsd, dn),
                       f"rigid − elastic increase {dm:+.1%} ± {dsd:.1%} over {dn} seeds"
                       if dn else "runs missing"))
    parts = fig14_parts(curves, scale)
    for t in ("k0.2", "rigid"):
        steps = parts[t]
        m, two_se, n = steps["links"]
        if not n:
            out.append(Verdict(None, "runs missing"))
            continue
        words = "; ".join(f"{FIG14_STEP_WORDS[k]} {v[0]:+.1%} ± {v[1]:.1%}"
                          for k, v in steps.items() if v[2])
        ok = None if n < 2 else bool(m > two_se)
        out.append(Verdict(ok, f"{words} (Δq/q at the final strain, mean ± 2 standard errors "
                               f"over {n} seeds)"))
    return out


#: The steps of the decomposition beside Fig. 14, each against the one before it, and the
#: whole gap (:func:`fig14_parts`).
FIG14_STEP_WORDS = {"packing": "matched sand / sand (the packing)",
                    "beads": "loose beads / matched sand (the beads)",
                    "links": "TexSol / loose beads (the links' tension)",
                    "total": "TexSol / sand (the whole gap)"}


def fig14_parts(curves, scale) -> dict:
    """{wire tag: {step: (mean, 2 standard errors, seeds)}} of Δq/q at the final strain,
    paired by seed, for the steps of :data:`FIG14_STEP_WORDS`: sand → matched sand (the
    TexSol sample's sand laid around its beads, tested without them) → loose beads (the
    TexSol sample with no link force) → the TexSol sample (k = 0.2 N or rigid)."""
    tags = TAGS14 + TAGS14_PARTS
    q = {tag: {s: _final_q(curves.get(f"cylinder_{tag}_seed{s}")) for s in scale.fig14_seeds}
         for tag in tags}
    out = {}
    for t in ("k0.2", "rigid"):
        chain = {"packing": ("matched", "sand"), "beads": ("loose", "matched"),
                 "links": (t, "loose"), "total": (t, "sand")}
        out[t] = {}
        for step, (b, a) in chain.items():
            rel = [q[b][s] / q[a][s] - 1 for s in scale.fig14_seeds
                   if q[b][s] is not None and q[a][s] is not None]
            m, sd, n = _seed_stats(rel)
            out[t][step] = (m, 2 * sd / np.sqrt(n) if n > 1 else float("nan"), n)
    return out


def _fits15(curves, scale) -> dict:
    """{tag: :func:`h_fit` of its (ε_zz, σ_w^eq) curve} of the Fig. 15 cylinders run."""
    fits = {}
    for tag in tags15(scale):
        t = curves.get(f"cylinder_{tag}_seed0")
        if t is not None:
            fits[tag] = h_fit(t["axial_strain"], t["wire_equivalent"])
    return fits


def score_fig15(curves, scale):
    fits = _fits15(curves, scale)
    if not fits or any(f is None for f in fits.values()):
        return [Verdict(None, "runs missing or too short")]
    ok = all(f["H"] > 0 and f["r2"] >= 0.8 for f in fits.values())
    n_macro = sum(f["method"].startswith("macro") for f in fits.values())
    return [Verdict(ok, f"{n_macro} of {len(fits)} runs linear within 1 % (macro_stiffness); "
                        f"r² of the fitted lines: "
                        + ", ".join(f"{t} {f['r2']:.2f}" for t, f in fits.items()))]


def score_fig16(curves, scale):
    """Fig. 16a-b; H counts as defined when every Fig. 15 line has r² ≥ 0.8 (the caveat
    says so when not)."""
    ks, Hs = _H_list(curves, scale)
    H_inf = _H_of(curves.get("cylinder_rigid_seed0"))
    ok_a = ok_b = None
    r2s = [f["r2"] for f in _fits15(curves, scale).values() if f is not None]
    H_defined = bool(r2s) and min(r2s) >= 0.8
    if len(ks) >= 3:
        rho = _spearman(ks, Hs)
        ok_a = (rho >= 0.6 and Hs[-1] > Hs[0]) if H_defined else None
        ours_a = f"Spearman ρ(k, H) = {rho:.2f}; H from {Hs[0]:.3g} Pa (k = {ks[0]:g} N) to " \
                 f"{Hs[-1]:.3g} Pa (k = {ks[-1]:g} N); {len(ks)} of {len(scale.k_list)} k values"
    else:
        ours_a = f"H found for {len(ks)} of {len(scale.k_list)} k values"
    if H_inf is not None and ks:
        ratio = Hs[-1] / H_inf
        ok_b = (0.75 <= ratio <= 1.1) if H_defined else None
        ours_b = f"H(k = {ks[-1]:g} N) / H∞ = {ratio:.2f} (H∞ = {H_inf:.3g} Pa)"
    else:
        ours_b = "no H for the rigid wire or for the k values"
    caveat = ("" if H_defined or not r2s else
              "H is the slope of a linear (ε_zz, σ_w^eq) curve and ours are not linear "
              f"(lowest r² {min(r2s):.2f} < 0.8, see fig15): H is not defined, the numbers are "
              "shown for information")
    return [Verdict(ok_a, ours_a, caveat), Verdict(ok_b, ours_b, caveat)]
