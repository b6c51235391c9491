"""The report's matplotlib figures, one function per figure: ``draw(curves, scale, path)``
draws what there is of its runs' curves and returns ``path`` (a figure whose runs are
missing is drawn empty, or with a panel that says so).  Which claim each figure belongs to,
its file name and its title are in :mod:`.registry`."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from .cases import TAGS10, tags15
from .scales import PAPER_FIT_DEGREE, PAPER_VALUES, fig10_seeds
from .stats import _H_list, _H_of, h_fit


def _fig(nrows=1, ncols=1, size=(6.4, 4.4)):
    from ..figures import _axes
    return _axes(nrows, ncols, size=size)


def _save(fig, path):
    from ..figures import _save as save
    return save(fig, path)


def _empty(path, text):
    fig, ax = _fig()
    ax[0, 0].text(0.5, 0.5, text, ha="center", va="center")
    ax[0, 0].set_axis_off()
    return _save(fig, path)


def _res(t, label):
    return SimpleNamespace(axial_strain=t["axial_strain"], deviator=t["deviator"],
                           volumetric_strain=t["volumetric_strain"],
                           wire_equivalent=t["wire_equivalent"], params={}, name=label)


def tortuosity(curves, scale, path):
    """Fig. 7: ξ before / after the deposit in the mould, the paper's and each seed's."""
    from .. import figures

    labels, before, after = ["paper"], [PAPER_VALUES["tortuosity"][0]], \
        [PAPER_VALUES["tortuosity"][1]]
    for sd in fig10_seeds(scale):
        t = curves.get(f"deposit_w400_seed{sd}")
        if t is not None and "tortuosity_before" in t:
            labels.append(f"ours, seed {sd}")
            before.append(float(t["tortuosity_before"]))
            after.append(float(t["tortuosity_after"]))
    return figures.tortuosity_figure(labels, before, after, path)


def directions(curves, scale, path):
    """Fig. 8-9: the wire elements' directions before / after the slope deposit."""
    from .. import figures

    t = curves.get("slope_w400_seed0")
    hb, ha = {}, {}
    for pl in ("xy", "xz", "yz"):
        for h, when in ((hb, "before"), (ha, "after")):
            if t is not None and f"hist_{when}_{pl}_edges" in t:
                h[pl] = (t[f"hist_{when}_{pl}_edges"], t[f"hist_{when}_{pl}_weights"])
            else:
                h[pl] = (np.linspace(0, np.pi, 19), np.zeros(18))
    return figures.directions_figure(hb, ha, path)


def slope(curves, scale, path):
    """Fig. 10: the heaps of seed 0, each with the paper's fit."""
    from engine.analysis import max_slope

    from .. import figures

    profs, labs = [], []
    for tag, lab in zip(TAGS10, ("sand, line", "TexSol(1) 400 km/m³, cubic",
                                 "TexSol(2) 800 km/m³, 8th degree")):
        t = curves.get(f"slope_{tag}_seed0")
        if t is None:
            continue
        try:                                # the paper's fit of each heap
            fit, th = max_slope(t["r"], t["height"], PAPER_FIT_DEGREE[tag])
        except ValueError:                  # too few bins: the run's own fit
            fit, th = np.poly1d(t["height_fit"]), float(t["max_slope_deg"])
            lab = lab.split(",")[0] + f", degree {fit.order} (too few bins)"
        profs.append(SimpleNamespace(r=t["r"], height=t["height"], pressure=t["pressure"],
                                     height_fit=fit, pressure_fit=np.poly1d(t["pressure_fit"]),
                                     max_slope_deg=th))
        labs.append(lab)
    if not profs:
        return _empty(path, "Fig. 10: slope runs missing")
    return figures.slope_figure(profs, path, labels=labs)


def wire_stress(curves, scale, path):
    """Fig. 11: the wire stress of the box's upper and lower halves over the loading."""
    t = curves.get("box_rw1_seed0")
    fig, ax = _fig(1, 2, size=(9.0, 4.0))
    if t is not None and "wire_stress_upper" in t:
        e = 100 * np.asarray(t["axial_strain"])
        for a, half in zip(ax[0], ("upper", "lower")):
            s = np.asarray(t[f"wire_stress_{half}"])
            for i, comp in enumerate(("xx", "yy", "zz")):
                a.plot(e, s[:, i, i], label=f"σ_{comp}")
            w = np.linalg.eigvalsh(np.where(np.isfinite(s), s, 0.0))
            a.plot(e, w[:, 0], "k:", lw=0.8, label="min principal")
            a.set_title(f"wire stress, {half} half (R_{half[0]})", fontsize=9)
            a.set_xlabel("axial strain [%]")
            a.grid(alpha=0.3)
        ax[0, 0].set_ylabel("wire Weber stress [Pa] (tension > 0)")
        ax[0, 0].legend(fontsize=8)
    return _save(fig, path)


def strains(curves, scale, path):
    """Fig. 12: the principal strains of sand, wire and all, for the three bead sizes."""
    fig, ax = _fig(1, 3, size=(10.0, 3.8))
    for a, div in zip(ax[0], (1, 3, 4)):
        t = curves.get(f"box_rw{div}_seed0")
        a.set_title(f"r_w = r_min{'' if div == 1 else f'/{div}'}", fontsize=9)
        if t is None:
            continue
        x = np.arange(3)
        for j, part in enumerate(("sand", "wire", "all")):
            key = f"strain_{part}_principal"
            if key in t:
                a.bar(x + (j - 1) * 0.27, 100 * np.asarray(t[key]), 0.27, label=part)
        a.set_xticks(x, ["ε₁", "ε₂", "ε₃"])
        a.grid(alpha=0.3, axis="y")
    ax[0, 0].set_ylabel("principal strain [%] (extension > 0)")
    if ax[0, 0].get_legend_handles_labels()[0]:
        ax[0, 0].legend(fontsize=8)
    return _save(fig, path)


def cylinder(curves, scale, path):
    """Fig. 13 (the matplotlib part): the barrel profile and the toroidal map."""
    t = curves.get("cylinder_k1_seed0")
    fig, ax = _fig(1, 2, size=(9.0, 4.2))
    if t is not None and "barrel_r_last" in t:
        _barrel_panel(ax[0, 0], t)
    if t is not None and "torus_equivalent" in t:
        _torus_panel(fig, ax[0, 1], t)
    return _save(fig, path)


def _barrel_panel(a, t):
    a.plot(1e3 * t["barrel_r_first"], 1e3 * t["barrel_z_first"], "o-", label="start")
    a.plot(1e3 * t["barrel_r_last"], 1e3 * t["barrel_z_last"], "o-", label="end")
    a.set_xlabel("outer radius [mm]")
    a.set_ylabel("height [mm]")
    a.legend(fontsize=8)
    a.set_title("barrel shape", fontsize=9)


def _torus_panel(fig, a, t):
    re_, ze = 1e3 * t["torus_r_edges"], 1e3 * t["torus_z_edges"]
    im = a.pcolormesh(re_, ze, np.ma.masked_invalid(t["torus_equivalent"]).T, cmap="viridis")
    fig.colorbar(im, ax=a, label="σ_w^eq [Pa]")
    a.set_xlabel("r [mm]")
    a.set_ylabel("z [mm]")
    a.set_title(f"toroidal map at ε = {float(t['torus_strain']):.0%}", fontsize=9)


def stress_strain(curves, scale, path):
    """Fig. 14: deviator and volumetric strain of the sand, k = 0.2 N and rigid cylinders."""
    from .. import figures

    res, labs, refs, ref_labs = [], [], [], []
    # legends in words (figures.law_label's wording); the sand runs as the reference
    for tag, lab in (("sand", figures.SAND_ONLY), ("k0.2", "elastic wire, k = 0.2 N"),
                     ("rigid", "rigid wire")):
        for s in scale.fig14_seeds:
            t = curves.get(f"cylinder_{tag}_seed{s}")
            if t is not None:
                (refs if tag == "sand" else res).append(_res(t, lab))
                (ref_labs if tag == "sand" else labs).append(f"{lab}, seed {s}")
    if not (res or refs):
        return _empty(path, "Fig. 14: runs missing")
    return figures.stress_strain_figure(res, path, labels=labs,
                                        title="Fig. 14: cylinder triaxial", reference=refs,
                                        reference_label=ref_labs)


def parts14(curves, scale, path):
    """Beside Fig. 14: each step of the decomposition (:func:`.scoring.fig14_parts`) for
    the elastic (k = 0.2 N) and the rigid wire, Δq/q [%] at the final strain with two
    standard errors."""
    from .scoring import FIG14_STEP_WORDS, fig14_parts

    parts = fig14_parts(curves, scale)
    if not any(v[2] for p in parts.values() for v in p.values()):
        return _empty(path, "beside Fig. 14: runs missing")
    fig, ax = _fig(size=(7.2, 4.4))
    a = ax[0, 0]
    steps = list(FIG14_STEP_WORDS)
    x = np.arange(len(steps))
    for j, (t, words) in enumerate((("k0.2", "elastic wire, k = 0.2 N"),
                                    ("rigid", "rigid wire"))):
        m = np.array([parts[t][k][0] for k in steps]) * 100
        e = np.array([parts[t][k][1] for k in steps]) * 100
        a.bar(x + (j - 0.5) * 0.38, m, 0.36, yerr=np.nan_to_num(e), capsize=3, label=words)
    a.axhline(0, color="0.3", lw=0.8)
    a.set_xticks(x)
    a.set_xticklabels([FIG14_STEP_WORDS[k].split(" (")[0].replace(" / ", "\n/ ")
                       for k in steps], fontsize=8)
    a.set_ylabel("Δq/q at the final strain [%]")
    n = max(v[2] for p in parts.values() for v in p.values())
    a.set_title(f"paired by seed ({n} seeds), error bars 2 standard errors", fontsize=9)
    a.grid(alpha=0.3, axis="y")
    a.legend(fontsize=8)
    return _save(fig, path)


def wire_equivalent(curves, scale, path):
    """Fig. 15: σ_w^eq against ε_zz for every k and the rigid wire, with the lines of H."""
    fig, ax = _fig()
    a = ax[0, 0]
    for tag in tags15(scale):
        t = curves.get(f"cylinder_{tag}_seed0")
        if t is None:
            continue
        e = np.asarray(t["axial_strain"])
        words = "rigid wire" if tag == "rigid" else f"elastic wire, k = {tag[1:]} N"
        line, = a.plot(100 * e, t["wire_equivalent"], lw=1, label=words)
        f = h_fit(e, t["wire_equivalent"])
        if f is not None:
            xs = e[f["start"]:]
            a.plot(100 * xs, f["H"] * xs + f["intercept"], "--", color=line.get_color(), lw=0.8)
    a.plot([], [], "--", color="0.3", lw=0.8, label="fitted line (H, Table 2)")
    a.set_xlabel("axial strain ε_zz [%]")
    a.set_ylabel("wire equivalent stress ‖dev σ_w‖ [Pa]")
    a.grid(alpha=0.3)
    a.legend(fontsize=8, ncol=2, loc="best")
    return _save(fig, path)


def h_vs_k(curves, scale, path):
    """Fig. 16: H against k (ours, with H∞), and H / H∞, ours and the paper's."""
    ks, Hs = _H_list(curves, scale)
    H_inf = _H_of(curves.get("cylinder_rigid_seed0"))
    fig, ax = _fig(1, 2, size=(9.5, 4.0))
    if ks:
        ax[0, 0].semilogx(ks, Hs, "o-", label="ours")
    if H_inf is not None:
        ax[0, 0].axhline(H_inf, color="k", ls="--", label="ours, rigid (H∞)")
    ax[0, 0].set_xlabel("wire stiffness k [N]")
    ax[0, 0].set_ylabel("H [Pa]")
    ax[0, 0].legend(fontsize=8)
    ax[0, 0].grid(alpha=0.3, which="both")
    pk, pH = PAPER_VALUES["table2_k"], np.asarray(PAPER_VALUES["table2_H"], float)
    ax[0, 1].semilogx(pk, pH / PAPER_VALUES["table2_H_inf"], "s-", color="0.4", label="paper")
    if ks and H_inf:
        ax[0, 1].semilogx(ks, np.asarray(Hs) / H_inf, "o-", label="ours")
    ax[0, 1].axhline(1.0, color="k", ls="--", lw=0.8)
    ax[0, 1].set_xlabel("wire stiffness k [N]")
    ax[0, 1].set_ylabel("H / H∞")
    ax[0, 1].legend(fontsize=8)
    ax[0, 1].grid(alpha=0.3, which="both")
    return _save(fig, path)
