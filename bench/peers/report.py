"""Merge the per-engine JSON files of one `make bench-peers` run into
bench/results/peers-YYYYMMDD-HHMM.json and print the summary table.

    python bench/peers/report.py WORKDIR    (run.sh calls it with the project venv)
"""
from __future__ import annotations

import datetime as _dt
import json
import os
import platform
import subprocess
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
sys.path.insert(0, str(HERE))

TARGET = 20.0


def _load(work: Path, name: str):
    p = work / name
    if not p.exists():
        return None
    with open(p) as f:
        return json.load(f)


def _trace(rec: dict, window: int = 50) -> list:
    w = np.asarray(rec["wall_s"])
    c = np.asarray(rec["contacts"])
    it = np.asarray(rec["iterations"])
    out = []
    for a in range(0, len(w), window):
        b = min(len(w), a + window)
        out.append(dict(steps=[a + 1, b], step_ms=float(w[a:b].mean() * 1e3),
                        contacts_mean=float(c[a:b].mean()), sweeps_mean=float(it[a:b].mean())))
    return out


def _finite_max(x):
    a = np.asarray(x, float)
    a = a[np.isfinite(a)]
    return float(a.max()) if a.size else None


def _clean(obj):
    """Strict JSON: non-finite floats (Siconos reports an infinite residual on steps with
    no contact) become null."""
    if isinstance(obj, float):
        return obj if np.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    return obj


def _compact(run: dict | None) -> dict | None:
    """A run without its per-step arrays (they become 50-step window means)."""
    if run is None:
        return None
    out = {k: v for k, v in run.items() if k not in ("per_step", "trace")}
    if "per_step" in run:
        rec = run["per_step"]
        w = np.asarray(rec["wall_s"])
        out["step_ms"] = dict(mean=float(w.mean() * 1e3), median=float(np.median(w) * 1e3),
                              max=float(w.max() * 1e3)) if w.size else None
        out["sweeps"] = dict(mean=float(np.mean(rec["iterations"])),
                             max=int(np.max(rec["iterations"])),
                             steps_at_max_iter=int(np.sum(np.asarray(rec["iterations"]) >= 1000)),
                             residual_max=_finite_max(rec["residual"]),
                             steps_with_nonfinite_residual=int(np.sum(~np.isfinite(
                                 np.asarray(rec["residual"], float)))))
        out["trace_50_steps"] = _trace(rec)
    if "trace" in run:
        out["trace"] = run["trace"]
    return out


def _window(ours, peer, sel_fn, label):
    """Mean step time of both engines on the same step indices."""
    if ours is None or peer is None:
        return None
    wo = np.asarray(ours["per_step"]["wall_s"])
    wp = np.asarray(peer["per_step"]["wall_s"])
    n = min(len(wo), len(wp))
    if n == 0:
        return None
    idx = sel_fn(ours, peer, n)
    if idx.size == 0:
        return dict(label=label, reached=False)
    o = float(wo[idx].mean())
    p = float(wp[idx].mean())
    co = np.asarray(ours["per_step"]["contacts"])[idx]
    cp = np.asarray(peer["per_step"]["contacts"])[idx]
    return dict(label=label, reached=True, steps=[int(idx[0]) + 1, int(idx[-1]) + 1],
                n_steps=int(idx.size), ours_ms=o * 1e3, peer_ms=p * 1e3,
                ratio=p / o if o > 0 else None,
                ours_contacts_mean=float(co.mean()), peer_contacts_mean=float(cp.mean()),
                ours_sweeps_mean=float(np.mean(np.asarray(ours["per_step"]["iterations"])[idx])),
                peer_sweeps_mean=float(np.mean(np.asarray(peer["per_step"]["iterations"])[idx])))


def _early(ours, peer, n):
    # step 1 is excluded: Siconos's runner writes its HDF5 output there
    return np.arange(1, min(n, 101))


def _dense_window(c):
    def sel(ours, peer, n):
        co = np.asarray(ours["per_step"]["contacts"])[:n]
        return np.flatnonzero(co >= c)
    return sel


def _all_but_first(ours, peer, n):
    return np.arange(1 if n > 1 else 0, n)


def _agree(ours_s: dict, peer_s: dict) -> dict:
    """Final-state agreement of two summaries (common.summary)."""
    g = "gap<=1%rmin"
    return dict(
        mean_height_ours_m=ours_s["mean_height_m"], mean_height_peer_m=peer_s["mean_height_m"],
        mean_height_rel_diff=(peer_s["mean_height_m"] - ours_s["mean_height_m"])
        / ours_s["mean_height_m"],
        contacts_geometric_ours=ours_s["contacts_geometric"][g]["total"],
        contacts_geometric_peer=peer_s["contacts_geometric"][g]["total"],
        contacts_geometric_rule=f"{g} (sphere-sphere + sphere-wall), from positions alone",
        contacts_engine_ours=ours_s.get("contacts_engine"),
        contacts_engine_peer=peer_s.get("contacts_engine"),
        max_overlap_ours_m=ours_s["contacts_geometric"][g]["max_overlap_m"],
        max_overlap_peer_m=peer_s["contacts_geometric"][g]["max_overlap_m"],
        kinetic_energy_ours_J=ours_s["kinetic_energy_J"],
        kinetic_energy_peer_J=peer_s["kinetic_energy_J"])


def _machine(work: Path) -> dict:
    def sh(*a):
        try:
            return subprocess.run(a, capture_output=True, text=True, timeout=20,
                                  cwd=str(ROOT)).stdout.strip()
        except Exception:
            return None
    cpu = None
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    la0 = (work / "loadavg_start").read_text().split()[:3] if (work / "loadavg_start").exists() else None
    la1 = Path("/proc/loadavg").read_text().split()[:3]
    import numba
    return dict(nproc=os.cpu_count(), cpu=cpu, platform=platform.platform(),
                python_ours=platform.python_version(), numpy=np.__version__,
                numba=numba.__version__,
                loadavg_start=[float(x) for x in la0] if la0 else None,
                loadavg_end=[float(x) for x in la1],
                packages={p: sh("dpkg-query", "-W", "-f=${Version}", p)
                          for p in ("python3-siconos", "yade", "python3-h5py", "python3-scipy")},
                git_head=sh("git", "rev-parse", "HEAD"),
                git_dirty_engine=sh("git", "status", "--porcelain", "engine"))


def main():
    work = Path(sys.argv[1])
    cfg = json.loads((work / "config.json").read_text())
    proc = {}
    if (work / "process_times.tsv").exists():
        for line in (work / "process_times.tsv").read_text().splitlines():
            name, secs, rc = line.split("\t")
            proc[name] = dict(wall_s=float(secs), exit_code=int(rc))

    o_dep = _load(work, "ours_deposit.json")
    s_off = _load(work, "siconos_off_deposit.json")
    s_on = _load(work, "siconos_shipped_deposit.json")
    o_den = _load(work, "ours_dense.json")
    d_off = _load(work, "siconos_off_dense.json")
    d_on = _load(work, "siconos_shipped_dense.json")
    o_rest = _load(work, "ours_rest.json")
    o_rest_big = _load(work, "ours_rest_dt_large.json")
    o_rest_loose = _load(work, "ours_rest_loose_tol.json")
    o_rest_sor = _load(work, "ours_rest_sor.json")
    o_rest_soft = _load(work, "ours_rest_compliant.json")
    yade = _load(work, "yade_rest.json")
    dense_state = _load(work, "dense_state.json")
    shim = _load(work, "shim.json")

    C = cfg["dense_contacts"]
    sic = dict(shim=shim, deposit={}, dense={})
    for key, peer in (("asserts_off", s_off), ("shipped", s_on)):
        sic["deposit"][key] = dict(
            early=_window(o_dep, peer, _early, "steps 2-101 (loose lattice, few contacts)"),
            dense=_window(o_dep, peer, _dense_window(C),
                          f"common steps where our engine has >= {C} contacts"),
            all=_window(o_dep, peer, _all_but_first, "all common steps but the first"))
        if peer is not None and o_dep is not None:
            agree = {}
            for step, ps in peer.get("checkpoints", {}).items():
                if step in o_dep.get("checkpoints", {}):
                    agree[step] = _agree(o_dep["checkpoints"][step], ps)
            sic["deposit"][key]["agreement_at_step"] = agree
        sic["dense"][key] = dict(
            all=_window(o_den, d_off if key == "asserts_off" else d_on, _all_but_first,
                        "steps 2.. from the common dense state"),
            agreement_at_end=(_agree(o_den["final"], (d_off if key == "asserts_off" else d_on)["final"])
                              if o_den and (d_off if key == "asserts_off" else d_on) else None))
    if dense_state is not None:
        sic["dense"]["start_state"] = dict(origin=dense_state.get("origin"),
                                           our_step=dense_state.get("step"),
                                           our_contacts=dense_state.get("contacts_engine"))
    sic["runs"] = dict(ours_deposit=_compact(o_dep), siconos_asserts_off_deposit=_compact(s_off),
                       siconos_shipped_deposit=_compact(s_on), ours_dense=_compact(o_den),
                       siconos_asserts_off_dense=_compact(d_off),
                       siconos_shipped_dense=_compact(d_on))

    yd = dict(ours=_compact(o_rest), yade=_compact(yade))
    if o_rest and yade:
        # a ratio only when ours reached rest; a lower bound when Yade hit its cap
        r = yade["wall_s"] / o_rest["wall_s"] if o_rest["at_rest"] else None
        yd["ratio_wall_to_rest"] = r
        yd["ratio_is_lower_bound"] = bool(yade.get("cap_hit")) if r is not None else None
        yd["ours_at_rest"] = o_rest["at_rest"]
        yd["yade_at_rest"] = yade["at_rest"]
        yd["agreement_at_end"] = _agree(o_rest["final"], yade["final"])
    # the same deposit at NSCD's larger time step (PEERS_REST_DT_LARGE), at h = 5e-5 s
    # with a looser NLGS tolerance (PEERS_REST_TOL_LOOSE), and at h = 5e-5 s, tol 1e-4 with
    # over-relaxation (PEERS_REST_RELAX), and with compliant contacts
    # (PEERS_REST_COMPLIANCE); each also against our first run
    for tag, o in (("large_dt", o_rest_big), ("loose_tol", o_rest_loose), ("sor", o_rest_sor),
                   ("compliant", o_rest_soft)):
        if not (o and yade):
            continue
        yd[f"ours_{tag}"] = _compact(o)
        r = yade["wall_s"] / o["wall_s"] if o["at_rest"] else None
        yd[f"ratio_wall_to_rest_{tag}"] = r
        yd[f"ratio_{tag}_is_lower_bound"] = bool(yade.get("cap_hit")) if r is not None else None
        yd[f"agreement_at_end_{tag}"] = _agree(o["final"], yade["final"])
        if o_rest:
            yd[f"agreement_{tag}_with_ours_tol_1e-4"] = _agree(o_rest["final"], o["final"])

    started = cfg["started"]
    note = cfg.get("note") or ""
    m = _machine(work)
    la = m["loadavg_start"] or m["loadavg_end"]
    if la and la[0] > 0.5 * (m["nproc"] or 1):
        auto = (f"machine shared/loaded: load average {la[0]:.2f} at start on {m['nproc']} "
                f"cores; absolute times are inflated, ratios less so")
        note = (note + "; " if note else "") + auto
    if cfg.get("quick"):
        note = (note + "; " if note else "") + "QUICK smoke run (small step counts and caps): not a quoted figure"

    def ratio(w):
        return None if not w or not w.get("reached", True) else w.get("ratio")

    headline = dict(
        siconos_per_step_ratio_early_asserts_off=ratio(sic["deposit"]["asserts_off"]["early"]),
        siconos_per_step_ratio_early_shipped=ratio(sic["deposit"]["shipped"]["early"]),
        siconos_per_step_ratio_dense_asserts_off=ratio(sic["dense"]["asserts_off"]["all"]),
        siconos_per_step_ratio_dense_shipped=ratio(sic["dense"]["shipped"]["all"]),
        siconos_per_step_ratio_deposit_dense_window_asserts_off=ratio(
            sic["deposit"]["asserts_off"]["dense"]),
        yade_wall_to_rest_ratio=yd.get("ratio_wall_to_rest"),
        yade_wall_to_rest_ratio_large_dt=yd.get("ratio_wall_to_rest_large_dt"),
        yade_wall_to_rest_ratio_loose_tol=yd.get("ratio_wall_to_rest_loose_tol"),
        yade_wall_to_rest_ratio_sor=yd.get("ratio_wall_to_rest_sor"),
        ours_sor_relax=(o_rest_sor or {}).get("relax"),
        yade_wall_to_rest_ratio_compliant=yd.get("ratio_wall_to_rest_compliant"),
        ours_contact_compliance=(o_rest_soft or {}).get("contact_compliance"),
        ours_large_dt_s=(o_rest_big or {}).get("dt_s"),
        ours_loose_tol=(o_rest_loose or {}).get("tol"),
        ours_rest_anderson=(o_rest or {}).get("anderson"),
        ours_rest_hot_sweeps=(o_rest or {}).get("hot_sweeps", 0),
        yade_ratio_is_lower_bound=yd.get("ratio_is_lower_bound"),
        target=TARGET)
    headline["meets_target"] = {k: (v >= TARGET) for k, v in headline.items()
                                if k.endswith("ratio") or "_ratio_" in k
                                if isinstance(v, (int, float)) and not isinstance(v, bool)}
    out = dict(benchmark="peers", started=started,
               finished=_dt.datetime.now().isoformat(timespec="seconds"),
               note=note, quick=bool(cfg.get("quick")), headline=headline, config=cfg,
               machine=m, process_wall_s=proc, siconos=sic, yade=yd,
               reading="bench/peers/README.md")
    stamp = _dt.datetime.fromisoformat(started).strftime("%Y%m%d-%H%M")
    name = f"peers-{stamp}{'-quick' if cfg.get('quick') else ''}.json"
    dest = ROOT / "bench" / "results" / name
    out = _clean(out)
    dest.write_text(json.dumps(out, indent=1, allow_nan=False) + "\n")
    print_table(out)
    print(f"\nwritten: {dest.relative_to(ROOT)}")


def _f(x, fmt="{:.3g}"):
    return "-" if x is None else fmt.format(x)


def print_table(out):
    print("\n=== peers: per-step wall time, same scene, same steps (ratio = peer / ours) ===")
    print(f"{'comparison':58s} {'ours ms':>9s} {'peer ms':>9s} {'ratio':>8s}  contacts ours/peer")
    sic = out["siconos"]
    for phase, label in (("deposit", "deposit"), ("dense", "dense start")):
        for key in ("asserts_off", "shipped"):
            for wname, w in sic[phase][key].items():
                if not isinstance(w, dict) or "label" not in w:
                    continue
                if not w.get("reached", True):
                    print(f"{'Siconos ' + key + ', ' + label + ': ' + wname:58s} (not reached)")
                    continue
                print(f"{'Siconos ' + key + ', ' + label + ': ' + wname + ' ' + str(w['steps']):58s} "
                      f"{w['ours_ms']:9.3f} {w['peer_ms']:9.1f} {w['ratio']:8.1f}  "
                      f"{w['ours_contacts_mean']:.0f}/{w['peer_contacts_mean']:.0f}")
    print("\n=== final-state agreement (Siconos asserts off vs ours) ===")
    for phase in ("deposit", "dense"):
        a = sic[phase]["asserts_off"]
        items = a.get("agreement_at_step", {}) if phase == "deposit" else (
            {"end": a["agreement_at_end"]} if a.get("agreement_at_end") else {})
        for step, g in items.items():
            print(f"{phase} step {step}: mean height ours {g['mean_height_ours_m'] * 1e3:.4f} mm, "
                  f"Siconos {g['mean_height_peer_m'] * 1e3:.4f} mm (rel {g['mean_height_rel_diff']:+.2e}); "
                  f"contacts (gap<=1% rmin) {g['contacts_geometric_ours']}/{g['contacts_geometric_peer']}, "
                  f"engine {g['contacts_engine_ours']}/{g['contacts_engine_peer']}")
    y = out["yade"]
    print("\n=== to rest (kinetic energy < 1e-4 of its peak) ===")
    if y.get("ours"):
        o = y["ours"]
        print(f"ours: {'at rest' if o['at_rest'] else 'NOT at rest'} after {o['steps_done']} steps "
              f"({o['simulated_time_s']:.4f} s simulated) in {o['wall_s']:.1f} s; walls carry "
              f"{o.get('walls_vertical_force_over_weight', float('nan')):.4f} of the weight")
    if y.get("yade"):
        d = y["yade"]
        print(f"Yade: {'at rest' if d['at_rest'] else 'NOT at rest, cap hit'} after "
              f"{d['iterations']} iterations ({d['simulated_time_s']:.4f} s simulated) in "
              f"{d['wall_s']:.1f} s (cap {d['cap_s']:g} s)")
    if y.get("agreement_at_end"):
        g = y["agreement_at_end"]
        print(f"final states: mean height ours {g['mean_height_ours_m'] * 1e3:.4f} mm, Yade "
              f"{g['mean_height_peer_m'] * 1e3:.4f} mm (rel {g['mean_height_rel_diff']:+.2e}); "
              f"contacts (gap<=1% rmin) {g['contacts_geometric_ours']}/{g['contacts_geometric_peer']}")
    if y.get("ours") and not y["ours"]["at_rest"]:
        print("ratio Yade/ours to rest: none (ours did not reach rest within its cap)")
    if y.get("ratio_wall_to_rest") is not None:
        print(f"ratio Yade/ours wall time to rest (h = {y['ours'].get('dt_s', 5e-5):g} s): "
              f"{'>= ' if y['ratio_is_lower_bound'] else ''}"
              f"{y['ratio_wall_to_rest']:.1f} (target >= {TARGET:g})")
    for tag in ("large_dt", "loose_tol", "sor", "compliant"):
        if not y.get(f"ours_{tag}"):
            continue
        o = y[f"ours_{tag}"]
        g = y[f"agreement_at_end_{tag}"]
        what = f"h = {o['dt_s']:g} s, tol {o['tol']:g}" + (
            f", relax {o['relax']:g}" if o.get("relax", 1.0) != 1.0 else "") + (
            f", contact_compliance {o['contact_compliance']:g}"
            if o.get("contact_compliance") else "")
        print(f"ours at {what}: {'at rest' if o['at_rest'] else 'NOT at rest'} after "
              f"{o['steps_done']} steps in {o['wall_s']:.1f} s; mean height "
              f"{g['mean_height_ours_m'] * 1e3:.4f} mm (Yade rel {g['mean_height_rel_diff']:+.2e}); "
              f"contacts (gap<=1% rmin) {g['contacts_geometric_ours']}/{g['contacts_geometric_peer']}; "
              f"max overlap {g['max_overlap_ours_m']:.2g} m; walls carry "
              f"{o.get('walls_vertical_force_over_weight', float('nan')):.4f} of the weight")
        s = y.get(f"agreement_{tag}_with_ours_tol_1e-4")
        if s:
            print(f"  against our first run: mean height rel {s['mean_height_rel_diff']:+.2e}")
        if y.get(f"ratio_wall_to_rest_{tag}") is not None:
            print(f"ratio Yade/ours wall time to rest ({what}): "
                  f"{'>= ' if y[f'ratio_{tag}_is_lower_bound'] else ''}"
                  f"{y[f'ratio_wall_to_rest_{tag}']:.1f} (target >= {TARGET:g})")
    if out["note"]:
        print(f"\nNOTE: {out['note']}")


if __name__ == "__main__":
    main()
