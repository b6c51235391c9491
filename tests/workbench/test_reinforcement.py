"""workbench.reinforcement (issue 30's study): the cases pair each wire run with the sand run
of its seed, preparation and confinement; the summary's Δq/q and two standard errors are
those of the per-seed ratios; q at a strain is read within the loading's last step."""
from __future__ import annotations

import math

import numpy as np
import pytest

from workbench.reinforcement import BASELINE, FACTORS, STRAINS, _q_at, cases, summarize


def test_every_wire_case_has_its_sand_run_first_and_names_are_unique():
    todo = cases([0, 1], scale=0.05)
    names = [c["name"] for c in todo]
    assert len(names) == len(set(names))
    seen_sand = set()
    for c in todo:
        key = (c["seed"], c["preparation"], c["confinement"])
        if c["wire"] == "none":
            seen_sand.add(key)
        else:
            assert key in seen_sand, c["name"]
    # one sand run per seed, preparation and confinement, shared by every factor
    assert len(seen_sand) == sum(1 for c in todo if c["wire"] == "none") == 2 * 3


def _rows(q_sand, q_wire, level=("law, paper preparation", "k = 0.2 N")):
    change = dict(FACTORS[level[0]])[level[1]]
    rows = []
    for seed, (qs, qw) in enumerate(zip(q_sand, q_wire)):
        base = dict(BASELINE, seed=seed, scale=1.0, axial_strain=0.1)
        sand = dict(base, wire="none", k=None, name=f"sand{seed}")
        wire = dict(base, **change, name=f"wire{seed}")
        rs = {f"q_{round(100 * e)}": qs for e in STRAINS}
        rw = {f"q_{round(100 * e)}": qw for e in STRAINS}
        rw.update({f"q_wire_{round(100 * e)}": 0.01 * qw for e in STRAINS})
        rows += [(sand, rs), (wire, rw)]
    return rows


def test_summary_is_the_mean_and_two_standard_errors_of_the_per_seed_ratios():
    q_sand = [20e3, 21e3, 22e3]
    q_wire = [18e3, 19.95e3, 20.9e3]
    lv = summarize(_rows(q_sand, q_wire))["factors"]["law, paper preparation"]["k = 0.2 N"]
    ratios = np.array(q_wire) / np.array(q_sand) - 1
    st = lv["dq_2"]
    assert st["n"] == 3 and lv["seeds"] == [0, 1, 2]
    assert st["mean"] == pytest.approx(ratios.mean(), rel=1e-12)
    assert st["two_se"] == pytest.approx(2 * ratios.std(ddof=1) / math.sqrt(3), rel=1e-12)
    assert lv["q_wire_share_10"]["mean"] == pytest.approx(0.01, rel=1e-12)
    # a level with no run is left out; the baseline's rows do not count as this level's
    assert "rigid" not in summarize(_rows(q_sand, q_wire))["factors"]["law, paper preparation"]


def test_q_at_a_strain_is_read_within_the_last_step_and_nan_beyond():
    eps = np.linspace(0.0, 0.09998, 11)              # the loading ends one step short
    q = 1e4 * (1 + eps)
    zero = np.zeros((eps.size, 3, 3))
    out = _q_at(eps, q, zero, zero)
    assert out["q_10"] == pytest.approx(1e4 * 1.09998, rel=1e-12)
    assert out["q_2"] == pytest.approx(1e4 * 1.02, rel=1e-12)
    short = _q_at(eps[:6], q[:6], zero[:6], zero[:6])  # stopped one step short of 5 %
    assert math.isnan(short["q_10"]) and short["q_5"] == pytest.approx(q[5], rel=1e-12)


def test_the_chain_pairs_each_step_with_the_one_before_by_seed():
    """Each step of the chain against the one before it, paired by seed: the Δq/q and its
    two standard errors are those of the per-seed ratios; the cases of one seed share
    everything but their step's change; a seed one step lacks is left out of its pairs."""
    from workbench.reinforcement import CHAIN, SIDE, chain_cases, summarize_chain

    todo = chain_cases([0, 1, 2], scale=0.3, pressures=(15e3, 2e3))
    assert len(todo) == 3 * 2 * (len(CHAIN) + len(SIDE))
    assert len({c["name"] for c in todo}) == len(todo)
    by = {(c["seed"], c["pressure"], c["step"]): c for c in todo}
    assert by[(0, 15e3, "matched sand")]["remove_beads"] == "after_deposit"
    assert by[(0, 15e3, "loose beads")]["wire"] == "loose"
    assert by[(0, 15e3, "sand")]["wire"] == "none"
    assert by[(1, 2e3, "TexSol")]["wire"] == "elastic" and by[(1, 2e3, "TexSol")]["k"] == 1.0
    assert "overlap_tol" not in by[(0, 15e3, "sand")]       # the tables run before it
    # with and without the position correction: never one row, never one history
    for tol, tag in ((0.005, "_ov0.005"), (None, "_ovnone")):
        c = chain_cases([0], scale=0.3, overlap_tol=tol)[0]
        assert c["overlap_tol"] == tol and c["name"].endswith(tag)
    q = {"sand": [20e3, 21e3, 22e3], "matched sand": [19e3, 20e3, 21.5e3],
         "loose beads": [19e3, 19.5e3, 21e3], "TexSol": [20e3, 21e3, None]}
    rows = []
    for step, qs in q.items():
        for seed, v in enumerate(qs):
            if v is None:
                continue
            p = by[(seed, 15e3, step)]
            rows.append((p, {**{f"q_{t}": v for t in ("2", "5", "10", "peak")},
                             "solid_fraction": 0.65}))
    out = summarize_chain(rows)["paper preparation, p = 15 kPa"]
    e = out["pairs"]["matched sand / sand"]["dq_5"]
    r = np.array(q["matched sand"]) / np.array(q["sand"]) - 1
    assert e["n"] == 3 and e["mean"] == pytest.approx(r.mean(), rel=1e-12)
    assert e["two_se"] == pytest.approx(2 * r.std(ddof=1) / math.sqrt(3), rel=1e-12)
    t = out["pairs"]["TexSol / loose beads"]
    assert t["seeds"] == [0, 1] and t["dq_peak"]["per_seed"] == pytest.approx(
        [20 / 19 - 1, 21 / 19.5 - 1], rel=1e-12)
    assert "packing without beads / sand" not in out["pairs"]      # no such run
