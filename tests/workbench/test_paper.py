"""`nscd paper --scale tiny`: the smoke-scale report has every claim (each with a verdict,
ours and the paper's numbers), every figure file, the runs, the series and the sweep table;
a second build reuses the runs."""
from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("distributed")

from workbench.paper import SCALES, cases_for  # noqa: E402

CLAIMS = ["fig7", "fig8-9", "fig10a", "fig10b", "fig11a", "fig11b", "fig11c", "fig12a", "fig12b",
          "fig13a", "fig13b", "fig13c", "fig14-k0.2", "fig14-rigid", "fig14-order",
          "fig14-links-k0.2", "fig14-links-rigid", "fig15", "fig16a", "fig16b"]
FIGURES = ["fig07_tortuosity", "fig07_before", "fig07_after", "fig08_09_directions", "fig09_beads", "fig09_wire",
           "fig10_slope", "fig11_wire_stress", "fig11_forces", "fig11_wire", "fig12_strains",
           "fig13_cylinder", "fig13_beads", "fig13_wire", "fig13_torus", "fig14_stress_strain",
           "fig14_parts", "fig15_wire_equivalent", "fig16_H_vs_k"]
RESULTS = Path(__file__).resolve().parents[2] / "bench" / "results"   # committed reports


def test_cases_cover_the_figures():
    for s in SCALES.values():
        names = [c["name"] for c in cases_for(s)]
        assert len(names) == len(set(names))
        for need in ("slope_sand_seed0", "slope_w400_seed0", "slope_w800_seed0",
                     "box_rw1_seed0", "box_rw3_seed0", "box_rw4_seed0", "cylinder_k1_seed0",
                     "cylinder_rigid_seed0", "cylinder_k0.2_seed0"):
            assert need in names, (s.name, need)
        for seed in s.fig14_seeds:
            assert f"cylinder_sand_seed{seed}" in names
            assert f"cylinder_k1_seed{seed}" in names   # Fig. 13c on every seed
            for div in (1, 3, 4):                       # Fig. 11 and 12 on every seed
                assert f"box_rw{div}_seed{seed}" in names
        from workbench.paper import fig10_seeds
        assert len(fig10_seeds(s)) >= 2
        for seed in fig10_seeds(s):                     # Fig. 7 and 10 on several seeds
            for tag in ("sand", "w400", "w800"):
                assert f"slope_{tag}_seed{seed}" in names
            assert f"deposit_w400_seed{seed}" in names
        assert len(s.fig14_seeds) >= 2                  # a spread for the +7 % claim
    assert SCALES["default"].k_list == (0.1, 0.2, 0.5, 1, 2, 5, 10, 20, 50, 100)


def test_only_selects_claims_and_the_runs_they_read():
    """``only`` expands figure prefixes to claim ids, refuses unknown names with the list of
    ids, and keeps exactly the runs the chosen claims read; every run of a full report is
    read by some claim (so a selection never drops a run a claim needs)."""
    from workbench.paper import claim_runs, select_claims

    for s in SCALES.values():
        runs = claim_runs(s)
        assert list(runs) == CLAIMS
        full = {c["name"] for c in cases_for(s)}
        assert {r for v in runs.values() for r in v} == full, s.name
        for cid in CLAIMS:
            assert {c["name"] for c in cases_for(s, only=cid)} == set(runs[cid]), (s.name, cid)
    s = SCALES["paper"]
    assert select_claims(None, s) is None
    assert select_claims("fig14", s) == ["fig14-k0.2", "fig14-rigid", "fig14-order",
                                         "fig14-links-k0.2", "fig14-links-rigid"]
    assert select_claims("FIG10, fig8", s) == ["fig8-9", "fig10a", "fig10b"]   # report order
    assert select_claims(["fig16b", "fig13c"], s) == ["fig13c", "fig16b"]
    assert [c["name"] for c in cases_for(s, only="fig14")] == [
        f"cylinder_{t}_seed{sd}" for sd in (0, 1, 2) for t in ("sand", "k0.2", "rigid")] + [
        f"cylinder_{t}_seed{sd}" for sd in (0, 1, 2) for t in ("matched", "loose")]
    parts = {c["name"]: c for c in cases_for(s, only="fig14-links-rigid")}
    assert parts["cylinder_matched_seed1"]["remove_beads"] == "after_deposit"
    assert parts["cylinder_loose_seed1"]["wire"] == "loose"
    assert "cylinder_k0.2_seed0" not in parts
    assert len(cases_for(s, only="fig15")) == len(s.k_list) + 1
    for bad in ("fig1", "fig17", "table"):                 # fig1 is not a prefix of fig10a
        with pytest.raises(ValueError, match="unknown claim .*fig14-order"):
            select_claims(bad, s)
    with pytest.raises(ValueError, match="at least one claim"):
        select_claims(" , ", s)
    from workbench.cli import main
    assert main(["paper", "--only", "fig99", "--out", "/nonexistent/never"]) == 2


def test_threads_are_checked_before_anything_runs(tmp_path, capsys):
    """--threads is a build option (not part of a run's identity), checked up front."""
    from workbench.cli import main, parser
    from workbench.paper import build_report

    for bad in (0, 65, 1.5, True):
        with pytest.raises(ValueError, match=r"threads must be an integer in \[1, 64\]"):
            build_report(tmp_path / "p", "tiny", threads=bad, scheduler="serial")
    assert not (tmp_path / "p").exists()
    assert main(["paper", "--scale", "tiny", "--threads", "0", "--out", str(tmp_path / "q")]) == 2
    assert "threads must be" in capsys.readouterr().err
    a = parser().parse_args(["paper", "--threads", "2", "--only", "fig8-9"])
    assert (a.threads, a.only) == (2, "fig8-9")


def test_a_negative_effect_beyond_the_spread_is_called_opposite():
    """Fig. 14's text tells a decrease beyond 2 standard errors from one within the spread
    (the numbers of the paper-scale and default-scale reports)."""
    from workbench.paper import _against, _significant

    assert _significant(-0.093, 0.051, 3) is False
    assert _against(-0.093, 0.051, 3).endswith("the opposite effect")   # 2 SE = 0.059
    assert _against(-0.036, 0.087, 5) == "within the seed spread"       # 2 SE = 0.078
    assert _against(-0.05, 0.051, 3) == "within the seed spread"


def test_fig7_needs_every_seed_up_and_the_mean_beyond_the_spread():
    """Fig. 7: ξ after the deposit in the mould above ξ before on every seed, and the mean
    relative change > 0 beyond 2 standard errors; one seed gives no verdict."""
    from workbench.paper import _fig7

    def run(b, a, at_rest=True):
        return dict(tortuosity_before=b, tortuosity_after=a, settlement=1e-5, at_rest=at_rest)

    ok, text = _fig7([run(1600, 2500), run(1550, 2400), run(1500, 2300)], (0, 1, 2))
    assert ok is True
    assert text.startswith("+55% ± 1% (mean ± std over 3 seeds)")
    assert "seed 1: 1550 → 2400 m⁻¹ (+55%, settlement 10 µm)" in text
    # a mean beyond 2 standard errors but one seed going down: not reproduced
    assert _fig7([run(1000, 1500), run(1000, 1600), run(1000, 990), run(1000, 1550)],
                 (0, 1, 2, 3))[0] is False
    # within the spread: not reproduced
    assert _fig7([run(1000, 1010), run(1000, 1300), run(1000, 1005)], (0, 1, 2))[0] is False
    assert _fig7([run(1000, 1500)], (0,)) == (None, "+50% (one seed); seed 0: 1000 → 1500 m⁻¹ "
                                                  "(+50%, settlement 10 µm)")
    assert _fig7([None, dict()], (0, 1)) == (None, "runs missing")
    # a deposit stopped by its step limit before rest: no verdict, and the text says why
    ok, text = _fig7([run(1600, 2500), run(1550, 2400, at_rest=False), run(1500, 2300)],
                     (0, 1, 2))
    assert ok is None and text.endswith("; not comparable: seed(s) 1 not at rest")
    assert "settlement 10 µm, NOT at rest)" in text
    # the wire's length and slack links, when the run has them
    r = dict(run(1000, 1500), wire_length_before=0.1, wire_length_after=0.096,
             slack_share=0.17)
    assert "wire length -4.0%, 17% of the links slack)" in _fig7([r], (0,))[1]


R_BINS = (np.arange(12) + 0.5) * 1e-3                 # 12 bin centres [m], as slope_deposit


def _cone(theta_deg):
    """The curves of a conical heap: h(r) a straight line, so every fit gives theta."""
    return dict(r=R_BINS, height=6e-3 - np.tan(np.radians(theta_deg)) * R_BINS)


def test_fig10_pairs_the_heaps_by_seed():
    """10a: each TexSol heap steeper than the sand heap of the same seed beyond 2 standard
    errors; 10b: 800 km·m⁻³ steeper than 400 the same way; one seed gives no verdict."""
    from workbench.paper import _fig10

    def seed(sand, w400, w800):
        return dict(sand=_cone(sand), w400=_cone(w400), w800=_cone(w800))

    a, b = _fig10([seed(10, 13, 15), seed(11, 13.5, 16), seed(9, 12.8, 14.5)], (0, 1, 2))
    assert a[0] is True and b[0] is True
    assert "400 +3.1° ± 0.7°" in a[1] and "seed 2: 9.0°, 12.8°, 14.5°" in a[1]
    a, b = _fig10([seed(10, 13, 13), seed(11, 13.5, 13.4), seed(9, 12.8, 12.9)], (0, 1, 2))
    assert a[0] is True and b[0] is False                  # 800 - 400: +0.0 ± 0.1
    assert "one cubic +0.0° ± 0.1°; per seed with one cubic +0.0°, -0.1°, +0.1°" in b[1]
    assert "seed 0:" not in b[1]
    a, b = _fig10([seed(10, 13, 9), seed(11, 13.5, 14), seed(9, 12.8, 8)], (0, 1, 2))
    assert a[0] is False                                   # 800 - sand: +0.3 ± 2.3
    a, b = _fig10([seed(10, 13, 15), dict(sand=None, w400=None, w800=None)], (0, 1))
    assert a[0] is None and b[0] is None and "(one seed)" in a[1]
    assert "over 1 seeds" not in a[1] + b[1] and "mean of 1" not in a[1]
    assert _fig10([dict(sand=None, w400=None, w800=None)], (0,))[0] == (None, "runs missing")


def test_fig10_needs_more_than_the_papers_choice_of_fits():
    """A sand heap whose top is flat and whose foot is steep: its straight line (the paper's
    fit for sand) is gentler than the conical TexSol heaps, its cubic steeper.  The paper's
    fits alone would say reproduced; with one cubic for every heap it is not."""
    from engine.analysis import max_slope
    from workbench.paper import _fig10, heap_slopes

    x = R_BINS / R_BINS[-1]
    sand = dict(r=R_BINS, height=1.5e-3 * (1 - x ** 4))
    line, cubic = max_slope(R_BINS, sand["height"], 1)[1], max_slope(R_BINS, sand["height"], 3)[1]
    assert line < 8 and cubic > 20                       # 6.7° with a line, 26° with a cubic
    runs = [dict(sand=sand, w400=_cone(12 + d), w800=_cone(12.5 + d)) for d in (0, 0.3, -0.2)]
    s = heap_slopes(sand, "sand")
    assert s["paper"] == s["line"] and s["common"] == pytest.approx(cubic)
    a, _ = _fig10(runs, (0, 1, 2))
    assert a[0] is False
    assert "paper's fits: 400 +" in a[1] and "one cubic: 400 -" in a[1]
    # a TexSol(2) heap over 8 bins cannot take the paper's 8th degree: its seed is left out
    short = dict(r=R_BINS, height=np.where(R_BINS < 8e-3, _cone(13)["height"], np.nan))
    runs[2]["w800"] = short
    a, b = _fig10(runs, (0, 1, 2))
    assert "seed 2 left out: its w800 heap: 8 occupied bins, need more than degree=8" in a[1]
    assert "mean ± std over 2 seeds" in a[1] and "seed 2 left out" in b[1]
    a, b = _fig10(runs[2:], (2,))
    assert a[0] is None and b[0] is None and a[1].startswith("seed 2 left out")


def test_fig11_reads_every_seed():
    """11a: the worst seed decides; 11b: each seed's upper-half σ_zz / max horizontal must
    be below 1/3 beyond 2 standard errors; 11c: the upper/lower ratio paired by seed must
    exceed 1 beyond 2 standard errors."""
    from workbench.paper import _fig11

    def run(up, lo, smallest=0.0):
        ws = np.array([np.diag([1.0, 1.0, smallest]), np.diag([2.0, 1.0, 0.5])])
        return dict(wire_stress=ws, wire_stress_upper=np.array([np.diag(up)]),
                    wire_stress_lower=np.array([np.diag(lo)]))

    runs = [run([2.0, 1.0, 0.2], [1.0, 0.5, 0.1]), run([2.2, 1.0, 0.3], [1.0, 0.5, 0.1]),
            run([1.8, 1.2, 0.2], [0.9, 0.5, 0.1], smallest=-0.5)]
    (a, ta), (b, tb), (c, tc) = _fig11(runs, (0, 1, 2))
    assert a is False and "seed 2" in ta                      # one seed compresses its wire
    assert b is True and "σ_zz / max horizontal = 0.12" in tb   # mean (2, 1.07, 0.23)
    assert "ratios 0.12 ± 0.02" in tb                          # 0.10, 0.14, 0.11
    assert c is True and "over 3 seeds" in tc
    runs[1] = run([0.5, 0.4, 0.1], [1.0, 0.5, 0.1])             # one seed the other way
    (_, _), (_, _), (c, _) = _fig11(runs, (0, 1, 2))
    assert c is False
    # the seeds' ratios 0.20, 0.45, 0.25 (mean 0.30 < 1/3, but not beyond their spread)
    near = [run([2.0, 1.0, 0.4], [1, 1, 1]), run([2.0, 1.0, 0.9], [1, 1, 1]),
            run([2.0, 1.0, 0.5], [1, 1, 1])]
    (_, _), (b, tb), (_, _) = _fig11(near, (0, 1, 2))
    assert b is False and "σ_zz / max horizontal = 0.30" in tb
    assert _fig11(near[:1], (0,))[1][0] is None                # one seed: no spread
    assert _fig11([None, None], (0, 1))[2] == (None, "runs missing")


def test_fig12_pairs_the_bead_sizes_by_seed():
    """12a: the r_min gap below 0.25 beyond 2 standard errors; 12b: the thinner wires' gaps
    above the r_min gap of the same seed, beyond 2 standard errors; no run, no verdict."""
    from workbench.paper import _fig12

    def box(gap):                     # sand strains (1, 0, 0), wire strains (1 + gap, 0, 0)
        return dict(strain_sand_principal=np.array([1.0, 0.0, 0.0]),
                    strain_wire_principal=np.array([1.0 + gap, 0.0, 0.0]))

    seeds = (0, 1, 2)
    runs = [{1: box(g1), 3: box(g3), 4: box(g4)}
            for g1, g3, g4 in ((0.10, 0.30, 0.40), (0.12, 0.35, 0.50), (0.08, 0.28, 0.45))]
    (a, b), text = _fig12(runs, seeds)
    assert a is True and b is True
    assert "r_min 0.10 ± 0.02, r_min/3 0.31 ± 0.04, r_min/4 0.45 ± 0.05" in text
    assert "seed 1: 0.12, 0.35, 0.50" in text
    # one seed where the thin wire follows the sand better: b is not beyond the spread;
    # an r_min gap of 0.30 on one seed (mean 0.16 ± 0.12): a is not either
    runs[1] = {1: box(0.30), 3: box(0.10), 4: box(0.60)}
    (a, b), _ = _fig12(runs, seeds)
    assert a is False and b is False
    assert _fig12([{1: None, 3: box(0.3), 4: box(0.4)}], (0,)) == ((None, None), "runs missing")
    assert _fig12(runs[:1], (0,))[0] == (None, None)             # one seed: no spread


def test_fig14_links_are_scored_against_the_loose_twin_of_each_seed():
    """Beside Fig. 14: each step of the decomposition is Δq/q paired by seed (mean and two
    standard errors); the links' row passes when TexSol beats its loose twin beyond two
    standard errors, whatever the sand does, and says so when it does not."""
    from types import SimpleNamespace

    from workbench.paper.scoring import fig14_parts, score_fig14

    # the packing -20 %, the beads +10 % on every seed; the links: k = 0.2 N about +10 %
    # (spread over the seeds), rigid exactly 0
    q = {"sand": (10.0, 12.0, 11.0), "matched": (8.0, 9.6, 8.8), "loose": (8.8, 10.56, 9.68),
         "k0.2": (9.5, 11.7, 10.7), "rigid": (8.8, 10.56, 9.68)}
    curves = {f"cylinder_{t}_seed{s}": {"deviator": np.array([0.0, v])}
              for t, vals in q.items() for s, v in enumerate(vals)}
    scale = SimpleNamespace(fig14_seeds=(0, 1, 2))
    parts = fig14_parts(curves, scale)
    m, two_se, n = parts["k0.2"]["packing"]
    assert n == 3 and m == pytest.approx(-0.2) and two_se == pytest.approx(0, abs=1e-12)
    assert parts["k0.2"]["beads"][0] == pytest.approx(0.1)
    rel = np.array([9.5 / 8.8, 11.7 / 10.56, 10.7 / 9.68]) - 1
    assert parts["k0.2"]["links"][0] == pytest.approx(rel.mean())
    assert parts["k0.2"]["links"][1] == pytest.approx(2 * rel.std(ddof=1) / np.sqrt(3))
    assert parts["rigid"]["links"][0] == pytest.approx(0, abs=1e-12)
    assert parts["rigid"]["total"][0] == pytest.approx(-0.12)
    *_, k02, rigid = score_fig14(curves, scale)
    assert k02.ok is True and "TexSol / loose beads (the links' tension) +" in k02.ours
    assert rigid.ok is False and "matched sand / sand (the packing) -20.0% ± 0.0%" in rigid.ours
    del curves["cylinder_loose_seed1"], curves["cylinder_loose_seed2"]
    assert score_fig14(curves, scale)[-1].ok is None                 # one seed: no spread
    del curves["cylinder_loose_seed0"]
    assert score_fig14(curves, scale)[-1].ours == "runs missing"


def test_fig13c_needs_a_mid_height_excess_beyond_the_seed_spread():
    """Fig. 13c: per seed the contrast (m - o)/(m + o) of the middle third's slabs (m)
    against the rest (o); reproduced only when its mean is > 0 beyond 2 standard errors.
    A profile whose maximum wanders from seed to seed is not a result; no run, no verdict."""
    from workbench.paper import _fig13c

    ze = np.linspace(0.0, 6e-3, 7)           # slab centres at z/H = 1/12, 3/12, ... 11/12
    run = lambda prof: dict(torus_z_edges=ze, torus_slab_equivalent=np.asarray(prof, float),
                            torus_equivalent=np.ones((2, 6)), torus_strain=0.1)
    # middle third = slabs 2 and 3; seed contrasts (5 - 1)/(5 + 1) = 2/3 and (6 - 2)/8 = 1/2
    ok, text = _fig13c([run([1, 1, 5, 5, 1, 1]), run([2, 2, 6, 6, 2, 2]),
                        run([1, 1, 5, 5, 1, 1])], (0, 1, 2))
    assert ok is True
    assert "+0.61 ± 0.10 over 3 seeds" in text and "+0.67, +0.50, +0.67" in text
    assert "z/H = 0.42" in text and "seed 1: 0.42" in text
    # each seed has its own maximum (floor, mid-height, top): the mean profile peaks in the
    # middle (2.3, 1, 3.7, 3.7, 1, 2.3), but the contrasts (-1/3, +0.8, -1/3) do not say so
    # beyond their spread
    floor, middle, top = run([5, 1, 1, 1, 1, 1]), run([1, 1, 9, 9, 1, 1]), run([1, 1, 1, 1, 1, 5])
    ok, text = _fig13c([floor, middle, top], (0, 1, 2))
    assert ok is False and "-0.33, +0.80, -0.33" in text
    assert "mean profile at z/H = 0.42" in text
    assert "seed 0: 0.08" in text and "seed 2: 0.92" in text
    # one seed: no spread, no verdict
    assert _fig13c([middle], (0,))[0] is None
    assert _fig13c([None, dict(torus_strain=0.1)], (0, 1)) == (None, "runs missing")


@pytest.mark.slow
@pytest.mark.timeout(600)
def test_nscd_paper_tiny(tmp_path, monkeypatch):
    out = tmp_path / "paper"
    cmd = [sys.executable, "-m", "workbench.cli", "paper", "--scale", "tiny", "--out", str(out)]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=540)
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-3000:]
    report = (out / "report.md").read_text()
    # every claim, with a verdict; at the smoke scale every verdict is "not comparable" and
    # the report says why
    rows = {m.group(1): m.group(0) for m in re.finditer(r"^\| (fig[\w.-]+) \|.*$", report, re.M)}
    for cid in CLAIMS:
        assert cid in rows, cid
        assert "**not comparable**" in rows[cid], rows[cid]
    assert "Smoke scale" in report and "| verdict | criterion here |" in report
    claims = json.loads((out / "claims.json").read_text())
    assert [c["id"] for c in claims] == CLAIMS
    for c in claims:
        assert c["paper"] and c["ours"] and c["criterion"]
        assert c["outcome"] in ("reproduced", "not reproduced", "not comparable")
    # every figure file, linked from the report
    for f in FIGURES:
        png = out / "figures" / f"{f}.png"
        assert png.exists() and png.stat().st_size > 5000, f
        assert f"figures/{f}.png" in report, f
    # the HDF5 runs, the curves, the series and the sweep table
    for c in cases_for(SCALES["tiny"]):
        assert (out / "runs" / f"{c['name']}.h5").exists(), c["name"]
        assert (out / "runs" / f"{c['name']}.curves.h5").exists(), c["name"]
        assert f"| {c['name']} | done" in report
    for run in ("deposit_w400_seed0", "slope_w400_seed0", "box_rw1_seed0", "cylinder_k1_seed0"):
        assert (out / "series" / run / f"{run}.pvd").exists()
    table = json.loads((out / "sweep.json").read_text())
    assert len(table["cases"]) == len(cases_for(SCALES["tiny"]))
    assert (out / "sweep.h5").exists()
    # a second build (serial, no pictures) reuses every run
    p2 = subprocess.run(cmd + ["--scheduler", "serial", "--no-render"], capture_output=True,
                        text=True, timeout=300)
    assert p2.returncode == 0, p2.stderr[-3000:]
    n = len(cases_for(SCALES["tiny"]))
    assert f"{n} cases, {n} already done, 0 to run" in p2.stdout
    # --only fig14: its 10 runs reused, its claims and figure alone; the other figure files
    # of the full build are left as they are
    fig07 = (out / "figures" / "fig07_tortuosity.png").stat().st_mtime_ns
    p3 = subprocess.run(cmd + ["--scheduler", "serial", "--no-render", "--only", "fig14"],
                        capture_output=True, text=True, timeout=300)
    assert p3.returncode == 0, p3.stderr[-3000:]
    assert "10 cases, 10 already done, 0 to run" in p3.stdout
    report = (out / "report.md").read_text()
    assert ("--only fig14-k0.2,fig14-rigid,fig14-order,fig14-links-k0.2,fig14-links-rigid"
            in report)
    ids = [c["id"] for c in json.loads((out / "claims.json").read_text())]
    assert ids == ["fig14-k0.2", "fig14-rigid", "fig14-order", "fig14-links-k0.2",
                   "fig14-links-rigid"]
    assert re.findall(r"figures/(\w+)\.png", report) == ["fig14_stress_strain", "fig14_parts"]
    assert "## Table 2" not in report and "series/" not in report
    assert (out / "figures" / "fig07_tortuosity.png").stat().st_mtime_ns == fig07
    assert len(re.findall(r"^\| cylinder_\w+\.?\w* \| done", report, re.M)) == 10
    # the commit is read when the build starts (the code the runs import); a change of
    # HEAD during the build is reported beside it
    import workbench.paper as wp
    heads = iter(["aaaa111", "bbbb222"])
    monkeypatch.setattr(wp.report, "_git_commit", lambda: next(heads))   # build_report's
    wp.build_report(out, "tiny", scheduler="serial", render=False, only="fig14", progress=False)
    assert ("commit aaaa111; bbbb222 when the report was written (the runs used the first)"
            in (out / "report.md").read_text())


def test_sweep_grid_parsing():
    from workbench.cli import parse_grid, parser

    assert parse_grid(["k=0.1,1,10", "seed=0,1", "wire=rigid", "scale=0.05"]) == {
        "k": [0.1, 1, 10], "seed": [0, 1], "wire": ["rigid"], "scale": [0.05]}
    with pytest.raises(ValueError, match="NAME=V1"):
        parse_grid(["k"])
    with pytest.raises(ValueError, match="no value"):
        parse_grid(["k="])
    with pytest.raises(ValueError, match="seed is given twice"):      # (kept the last)
        parse_grid(["seed=1", "k=1", "seed=2"])
    a = parser().parse_args(["sweep", "cylinder_triaxial", "--grid", "k=1,2",
                             "--scheduler", "serial"])
    assert a.test == "cylinder_triaxial" and a.scheduler == "serial" and a.retries == 1
    a = parser().parse_args(["paper", "--scale", "tiny", "--out", "x"])
    assert (a.scale, a.out, a.scheduler) == ("tiny", "x", None)


@pytest.mark.slow
def test_reuse_only_scores_the_runs_done_and_starts_none(tmp_path):
    """``reuse_only``: the report of the runs already done in OUT (here one of the two
    Fig. 7 seeds), the others listed as not run, nothing started."""
    import workbench.paper as wp
    from workbench.campaign import sweep

    out = tmp_path / "p"
    s = SCALES["tiny"]
    cases = cases_for(s, only="fig7")
    assert [c["name"] for c in cases] == ["deposit_w400_seed0", "deposit_w400_seed1"]
    sweep(wp.paper_case, cases[:1], "serial", out=out / "sweep.json",
          fixed={"runs_dir": str((out / "runs").resolve())}, progress=False)
    table = (out / "sweep.json").read_bytes()
    rep = wp.build_report(out, "tiny", only="fig7", reuse_only=True, render=False,
                          progress=False)
    assert not (out / "runs" / "deposit_w400_seed1.h5").exists()       # not started
    assert (out / "sweep.json").read_bytes() == table                  # nor written to
    text = rep.path.read_text()
    assert "--only fig7 --reuse-only`" in text
    assert "**Runs not done yet** (`--reuse-only`: this build started none): " \
           "deposit_w400_seed1." in text
    (c,) = rep.claims
    assert c.status == "not comparable" and "(one seed); seed 0: " in c.ours
    assert [r["params"]["name"] for r in rep.table.rows] == ["deposit_w400_seed0"]
    with pytest.warns(RuntimeWarning, match="no run of these claims is done"):
        wp.build_report(tmp_path / "empty", "tiny", only="fig7", reuse_only=True,
                        render=False, progress=False)
    assert not (tmp_path / "empty" / "sweep.json").exists()


@pytest.mark.slow
def test_runs_starts_only_the_runs_named(tmp_path):
    """``runs``: of the two Fig. 7 seeds only the one named is started; the report scores
    it, lists the other as not run, and a second build naming the other reuses the first."""
    import workbench.paper as wp

    out = tmp_path / "p"
    rep = wp.build_report(out, "tiny", only="fig7", runs="deposit_w400_seed1", render=False,
                          progress=False, scheduler="serial")
    assert (out / "runs" / "deposit_w400_seed1.h5").exists()
    assert not (out / "runs" / "deposit_w400_seed0.h5").exists()
    text = rep.path.read_text()
    assert "--only fig7 --runs deposit_w400_seed1`" in text
    assert "(`--runs`: this build started only those): deposit_w400_seed0." in text
    assert [r["params"]["name"] for r in rep.table.rows] == ["deposit_w400_seed1"]
    assert not rep.table.rows[0]["skipped"] and rep.table.wall_time > 0
    rep2 = wp.build_report(out, "tiny", only="fig7", runs=["deposit_w400_seed0"],
                           render=False, progress=False, scheduler="serial")
    assert [(r["params"]["name"], r["skipped"]) for r in rep2.table.rows] == \
        [("deposit_w400_seed0", False), ("deposit_w400_seed1", True)]
    assert "Runs not done yet" not in rep2.path.read_text()
    for runs, says in (("deposit_w400_seed7", "'deposit_w400_seed7' not among the runs"),
                       (",", "none given not among")):
        with pytest.raises(ValueError, match=says):
            wp.build_report(out, "tiny", only="fig7", runs=runs, render=False, progress=False)
    with pytest.raises(ValueError, match="runs and reuse_only exclude each other"):
        wp.build_report(out, "tiny", only="fig7", runs="deposit_w400_seed0", reuse_only=True,
                        render=False, progress=False)


@pytest.mark.slow
def test_an_interrupted_paper_run_is_not_recorded_as_done_and_resumes(tmp_path, monkeypatch):
    """``paper_case`` (what ``nscd paper`` runs) refuses to turn an interrupted run into
    table values (the sweep then leaves it pending), and the case run again resumes."""
    import workbench.paper as wp
    from workbench.campaign import CaseInterrupted
    from tests.helpers import stop_runs_at

    (case,) = [c for c in cases_for(SCALES["tiny"], only="fig7") if c["name"].endswith("0")]
    with monkeypatch.context() as mp:
        stop_runs_at(mp, 30)
        with pytest.raises(CaseInterrupted, match="interrupted after 30 steps"):
            wp.paper_case(**case, runs_dir=str(tmp_path / "a"))
    assert not (tmp_path / "a" / f"{case['name']}.curves.h5").exists()
    # the case run again goes on from the checkpoint the stop left, to the same numbers
    ck = tmp_path / "a" / f"{case['name']}.resume.h5"
    assert ck.exists()
    again = wp.paper_case(**case, runs_dir=str(tmp_path / "a"))
    ref = wp.paper_case(**case, runs_dir=str(tmp_path / "b"))
    assert not ck.exists() and again.pop("resumed_from") == "30"
    for row in (again, ref):             # in their own folders, in their own times
        row.pop("history"), row.pop("curves"), row.pop("steps_wall_time")
    assert again == ref


def test_the_runs_table_says_when_a_run_resumed_under_other_engine_code(tmp_path):
    """A run resumed from its checkpoint shows the step in its status; one resumed under
    other engine code (``resumed_with_other_code``) says so, with the step."""
    import workbench.paper as wp

    rows = {"a": dict(params={"name": "a", "seed": 0}, status="done",
                      result={"resumed_from": "900", "steps": 4000, "steps_wall_time": 9.0}),
            "b": dict(params={"name": "b", "seed": 1}, status="done",
                      result={"resumed_from": "30,60", "resumed_with_other_code": "60",
                              "steps": 100})}
    text = "\n".join(wp._run_lines(SCALES["tiny"], rows, {}, tmp_path))
    assert "| a | done (resumed at step 900) | 0 |" in text
    assert "| b | done (resumed at step 30, 60; at step 60 with other engine code) | 1 |" in text


def test_the_claim_registry_is_the_one_list():
    """Every claim of ``CLAIMS`` has rows with runs at every scale and figures; the ids,
    the runs, the selection, the verdicts, the figures and the series of a report are all
    derived from it: a claim added to the registry appears in each of them."""
    import dataclasses

    from workbench.paper import registry as reg

    assert [r.id for cl in reg.CLAIMS for r in cl.rows] == CLAIMS
    assert [f.file[:-4] for f in reg.figures_of(None)] == FIGURES
    for cl in reg.CLAIMS:
        assert cl.figures and all(r.id.startswith(cl.id) for r in cl.rows), cl.id
        assert reg.select_claims(cl.id, SCALES["paper"]) == [r.id for r in cl.rows]
        assert reg.figures_of([cl.rows[-1].id]) == list(cl.figures)
        for s in SCALES.values():
            assert all(r.runs(s) for r in cl.rows), (cl.id, s.name)
            assert len(cl.score({}, s)) == len(cl.rows)            # one verdict a row
    # a new claim on a run of Fig. 14 and a series: it is one more entry, nothing else
    new = reg.PaperClaim(
        "fig99", "Fig. 99",
        (reg.Row("fig99a", "a claim", "the paper's", "a criterion",
                 lambda s: ["cylinder_sand_seed1"], note="a note"),),
        lambda curves, scale: [reg.scoring.Verdict(not curves, "ours")],
        figures=(reg.Picture("fig99_beads", "cylinder_sand_seed1", "beads", "iso", -1,
                             "Fig. 99 — a picture"),),
        series=("cylinder_sand_seed1",))
    s = SCALES["tiny"]
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(reg, "CLAIMS", reg.CLAIMS + (new,))
        assert reg.claim_runs(s)["fig99a"] == ["cylinder_sand_seed1"]
        assert reg.select_claims("fig99", s) == ["fig99a"]
        assert [c["name"] for c in reg.cases_for(s, only="fig99")] == ["cylinder_sand_seed1"]
        (c,) = [c for c in reg.evaluate({}, {}, s) if c.id == "fig99a"]
        assert (c.figure, c.outcome, c.status, c.note) == ("Fig. 99", "reproduced",
                                                           "not comparable", "a note")
        assert [f.key for f in reg.figures_of(["fig99a"])] == ["fig99_beads"]
        assert reg.series_runs()[-1] == "cylinder_sand_seed1"
        mp.setattr(reg, "CLAIMS", reg.CLAIMS + (dataclasses.replace(
            new, id="fig98", rows=(dataclasses.replace(new.rows[0], id="fig98a",
                                                       runs=lambda s: ["no_such_run"]),)),))
        with pytest.raises(ValueError, match="runs that no case makes: no_such_run"):
            reg.cases_for(s)


class _Reads(dict):
    """Curves that record the names asked for (and have none)."""

    def __init__(self):
        super().__init__()
        self.asked = set()

    def get(self, name, default=None):
        self.asked.add(name)
        return default


@pytest.mark.filterwarnings("ignore:No artists with labels found")   # (empty figures)
def test_each_claim_reads_only_the_runs_of_its_rows(tmp_path):
    """A claim's scoring and figures read no run its rows do not list (so ``--only`` and
    ``cases_for`` never leave out a run a claim reads)."""
    from workbench.paper import registry as reg

    for s in SCALES.values():
        for cl in reg.CLAIMS:
            curves = _Reads()
            cl.score(curves, s)
            if s.name != "paper":          # (the figures drawn at two scales: time)
                for f in cl.figures:
                    if isinstance(f, reg.Plot):
                        f.draw(curves, s, tmp_path / f.file)
            assert curves.asked <= set(cl.runs(s)), (s.name, cl.id, curves.asked)


def test_paper_case_keeps_the_name_the_committed_tables_key_runs_by(tmp_path):
    """The sweep table keys a case by its function's module and name: paper_case is still
    ``workbench.paper.paper_case`` for workbench.campaign.sweep, so the committed tables' runs are found
    (every case of the paper-scale Fig. 7-10 table is a case of ``cases_for``)."""
    from workbench.campaign import case_key, load_table
    from workbench.paper import paper_case

    table = RESULTS / "paper-scale-slope-20261202-0919-sweep.json"
    keys = {case_key(paper_case, c) for c in cases_for(SCALES["paper"], only="fig7,fig8-9,fig10")}
    rows = load_table(table).rows
    assert len(rows) == 12 and {r["key"] for r in rows} == keys


@pytest.mark.parametrize("stem, scale", [("paper-scale-slope-20261202-0919", "paper"),
                                         ("paper-scale-slope-20261202-0428-rescored", "paper"),
                                         ("default-fig10-20261202-0449", "default")])
def test_the_committed_runs_rescore_to_the_committed_claims(stem, scale):
    """``evaluate`` on the committed curves and table gives the committed claims.json, word
    for word (the criteria of these reports are today's)."""
    from workbench.campaign import load_table
    from workbench.paper import evaluate, read_curves

    committed = json.loads((RESULTS / f"{stem}-claims.json").read_text())
    runs = RESULTS / (stem.replace("-rescored", "") + "-runs")
    table = RESULTS / (stem.replace("-rescored", "") + "-sweep.json")
    rows = {r["params"]["name"]: r for r in load_table(table).rows}
    curves = {p.name[:-len(".curves.h5")]: read_curves(p) for p in runs.glob("*.curves.h5")}
    ids = [c["id"] for c in committed]
    claims = [c.__dict__ for c in evaluate(curves, rows, SCALES[scale]) if c.id in ids]
    assert claims == committed


def test_every_report_case_validates_through_its_tests_config():
    """``nscd paper`` checks its cases through the tests' configs before anything runs
    (issue 32 §1): every case of every scale is accepted, a bad one refused on one line."""
    from workbench.paper.registry import cases_for
    from workbench.paper.runner import check_cases
    from workbench.paper.scales import SCALES

    for scale in SCALES.values():
        check_cases(cases_for(scale), {"runs_dir": "runs", "threads": 2})
    bad = dict(cases_for(SCALES["tiny"])[0], dt=-1.0)
    with pytest.raises(ValueError) as e:
        check_cases([bad])
    assert "\n" not in str(e.value) and "dt = -1.0: must be a number in (0, 0.01]" in str(e.value)
