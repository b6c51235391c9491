"""The report: :func:`build_report` runs (or reuses) the cases of the claims, scores them,
draws their figures and writes ``report.md`` and ``claims.json``."""
from __future__ import annotations

import datetime as _dt
import json
import os
import platform
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path

from .drawing import make_figures, series, snapshots
from .registry import cases_for, claims_of, evaluate, figures_of, select_claims
from .runner import check_cases, paper_case, read_curves
from .scales import PAPER_VALUES, _fmt_k, fig10_seeds, scale_named
from .stats import _g, _H_of, h_fit


# ---------------------------------------------------------------- the report

@dataclass
class Report:
    path: Path
    claims: list
    figures: dict
    table: object
    wall_time: float
    problems: list


def _git_commit():
    try:
        here = Path(__file__).resolve().parents[2]      # the repository
        r = subprocess.run(["git", "-C", str(here), "rev-parse", "--short", "HEAD"],
                           capture_output=True, text=True, timeout=10)
        dirty = subprocess.run(["git", "-C", str(here), "status", "--porcelain", "--",
                                "engine", "workbench"], capture_output=True, text=True,
                               timeout=10).stdout.strip()
        return r.stdout.strip() + (" (with uncommitted changes)" if dirty else "")
    except Exception:  # noqa: BLE001
        return "unknown"


def build_report(out="out/paper", scale="default", *, scheduler=None, progress=True,
                 render=True, only=None, threads=None, reuse_only=False, runs=None) -> Report:
    """Run (or reuse) every case of ``scale`` and write ``out/report.md`` with the figures,
    the runs, the series and the sweep table.

    ``scheduler``: None (a LocalCluster of 2 workers), "serial", a scheduler address, or a
    :class:`workbench.campaign.ClusterSpec` (``nscd paper --cluster``), handed to :func:`workbench.campaign.sweep`.
    ``only``: some claims (ids or figure prefixes, :func:`select_claims`), e.g. "fig14":
    the report then runs, scores and draws those claims alone (the way to take one figure
    to the paper's scale on a small machine).
    ``reuse_only``: start no run; score and draw the runs already done in ``out`` (its
    sweep table), and list the others as not run: how a paper-scale report that takes
    several sessions is read between them.  The claims missing a run say so and are not
    comparable; a claim on several seeds uses the seeds whose runs are done.
    ``runs``: names of runs of these claims (a list, or "a,b"): only those are started (if
    not done already); the report scores them with the other runs already done in ``out``
    and lists the rest as not run.  How a session of limited length takes on the runs
    of a paper-scale report a few at a time (``cases_for`` gives the names).
    ``threads``: NLGS threads of each run (None: the tests' default, 1).  It is not part of
    a run's identity: runs made with another count are reused.  Two threads pay on the
    paper-scale slope (1.79× in docs/experiments.md) when one run at a time goes
    (``scheduler="serial"``); with two workers on two cores, keep 1.
    """
    scale = scale_named(scale)
    _check_threads(threads)
    chosen = select_claims(only, scale)
    t0 = time.perf_counter()
    commit = _git_commit()            # the code the runs import now, not at the end
    out = Path(out)
    runs_dir, fig_dir, series_dir = out / "runs", out / "figures", out / "series"
    for d in (runs_dir, fig_dir, series_dir):
        d.mkdir(parents=True, exist_ok=True)
    fixed = {"runs_dir": str(runs_dir.resolve())}
    if threads is not None:
        fixed["threads"] = threads
    cases = cases_for(scale, only=chosen)
    check_cases(cases, fixed)        # each through its test's config, before any runs
    names = _run_names(runs, cases, reuse_only)
    if reuse_only or names is not None:
        table, not_run = _run_some(cases, names, out, scheduler, fixed, progress)
    else:
        from workbench.campaign import sweep

        table, not_run = sweep(paper_case, cases, scheduler, out=out / "sweep.json",
                               fixed=fixed, progress=progress), []
    rows = {r["params"]["name"]: r for r in table.rows}
    curves = _curves(rows, runs_dir)
    claims = evaluate(curves, rows, scale)
    drawn = None if chosen is None and not not_run else set(rows)   # the runs to draw
    if chosen is not None:
        claims = [c for c in claims if c.id in chosen]
    figs = make_figures(curves, scale, fig_dir, chosen)
    problems = []
    if render:
        snaps, pr = snapshots(runs_dir, fig_dir, drawn)
        figs.update(snaps)
        problems += pr
    pvds, pr = series(runs_dir, series_dir, drawn)
    problems += pr
    wall = time.perf_counter() - t0
    path = out / "report.md"
    end_commit = _git_commit()
    if end_commit != commit:
        commit += f"; {end_commit} when the report was written (the runs used the first)"
    from engine.files import write_text

    write_text(path, _markdown(scale, claims, figs, pvds, table, rows, curves, out, wall,
                              table.wall_time, problems, scheduler, chosen, threads, commit,
                              not_run, reuse_only, names))
    write_text(out / "claims.json", json.dumps([c.__dict__ for c in claims], indent=1,
                                               ensure_ascii=False))
    return Report(path, claims, figs, table, wall, problems)


def _check_threads(threads):
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, int)
                                or not 1 <= threads <= 64):
        raise ValueError(f"threads must be an integer in [1, 64] (NLGS threads per run), "
                         f"got {threads!r}")


def _run_some(cases, names, out, scheduler, fixed, progress):
    """(table, names not run) of a build that reuses the runs done in ``out``: with
    ``names``, those runs are made first; without (reuse_only), none, and nothing is
    written to the table (a build may be running in the same folder)."""
    from workbench.campaign import SweepTable, case_key, expand_grid, load_table, sweep

    ran = {}
    t_ran = 0.0
    if names is not None:
        part = sweep(paper_case, [c for c in cases if c["name"] in names], scheduler,
                     out=out / "sweep.json", fixed=fixed, progress=progress)
        ran = {r["key"]: r for r in part.rows}
        t_ran = part.wall_time
    done = {r["key"]: r for r in load_table(out / "sweep.json").rows
            if r["status"] == "done"}
    done.update({k: r for k, r in ran.items() if r["status"] == "failed"})
    keys = [case_key(paper_case, c) for c in expand_grid(cases)]
    not_run = [c["name"] for c, k in zip(cases, keys) if k not in done]
    table = SweepTable(rows=[ran.get(k, dict(done[k], skipped=True)) for k in keys
                             if k in done], path=str(out / "sweep.json"), wall_time=t_ran)
    if not table.rows:
        import warnings
        warnings.warn(f"--reuse-only: no run of these claims is done in {out}",
                      RuntimeWarning, stacklevel=3)
    return table, not_run


def _curves(rows, runs_dir) -> dict:
    """{name: curves} of the runs done whose curves file is there."""
    curves = {}
    for name, r in rows.items():
        p = runs_dir / f"{name}.curves.h5"
        if r["status"] == "done" and p.exists():
            curves[name] = read_curves(p)
    return curves


def _run_names(runs, cases, reuse_only) -> list | None:
    """``runs`` ("a,b" or a list of names) checked against the runs of ``cases``."""
    if runs is None:
        return None
    if reuse_only:
        raise ValueError("runs and reuse_only exclude each other: --reuse-only starts no run")
    names = [n.strip() for n in runs.split(",")] if isinstance(runs, str) else list(runs)
    names = [n for n in names if n]
    known = [c["name"] for c in cases]
    unknown = [n for n in names if n not in known]
    if unknown or not names:
        raise ValueError(f"runs: {', '.join(map(repr, unknown)) or 'none given'} not among the "
                         f"runs of these claims ({', '.join(known)})")
    return names




def _rel(p, out):
    try:
        return os.path.relpath(p, out)
    except ValueError:
        return str(p)


def _markdown(scale, claims, figs, pvds, table, rows, curves, out, wall, t_sim, problems,
              scheduler, chosen=None, threads=None, commit=None, not_run=(),
              reuse_only=False, run_names=None) -> str:
    L = _header_lines(scale, table, wall, t_sim, scheduler, chosen, threads, commit,
                      reuse_only, run_names)
    L += _note_lines(scale, chosen, not_run, reuse_only)
    L += _claim_lines(scale, claims)
    L += ["", "## Figures", ""]
    for f in figures_of(chosen):
        if f.key in figs:
            L += [f"### {f.title}", "", f"![{f.key}]({_rel(figs[f.key], out)})", ""]
        else:
            L += [f"### {f.title}", "", "*(not drawn; see Problems)*", ""]
    if any(cl.table2 for cl in claims_of(chosen)):
        L += _table2_lines(curves, rows)
    L += _run_lines(scale, rows, pvds, out)
    if problems:
        L += ["## Problems", ""] + [f"- {p}" for p in problems] + [""]
    if table.failed:
        L += ["## Failed runs", ""]
        for r in table.failed:
            L += [f"- {r['params']['name']} ({r['attempts']} attempts):", "", "```",
                  r["errors"][-1], "```", ""]
    return "\n".join(L) + "\n"


def _header_lines(scale, table, wall, t_sim, scheduler, chosen, threads, commit, reuse_only,
                  run_names) -> list:
    """The title, the command and the machine, the times and the scale."""
    now = _dt.datetime.now().strftime("%Y-%m-%d %H:%M")
    return [f"# Reproduction of Laniel, Alart & Pagano §2.4 and §3 (Fig. 7-16, Table 2) — "
            f"scale `{scale.name}`",
            "",
            f"Built {now} by `nscd paper --scale {scale.name}"
            f"{' --only ' + ','.join(chosen) if chosen is not None else ''}"
            f"{f' --threads {threads}' if threads is not None else ''}"
            f"{' --reuse-only' if reuse_only else ''}"
            f"{' --runs ' + ','.join(run_names) if run_names is not None else ''}` "
            f"(nscd-workbench commit "
            f"{commit or _git_commit()}), Python {platform.python_version()} on "
            f"{os.cpu_count()} cores; "
            f"cluster: {scheduler or 'LocalCluster, 2 workers'}; NLGS threads per run: "
            f"{threads or 1} in this build (runs reused from earlier builds keep theirs).",
            f"Wall time {wall:.0f} s, of which simulations {t_sim:.0f} s "
            f"({len(table.rows)} runs, {sum(1 for r in table.rows if r.get('skipped'))} reused "
            f"from an earlier build, {len(table.failed)} failed).",
            "",
            f"**Scale `{scale.name}`**: {scale.description}.", ""]


def _note_lines(scale, chosen, not_run, reuse_only) -> list:
    """The notes on what the report leaves out: claims, runs not done, the smoke scale."""
    L = []
    if chosen is not None:
        L += [f"> **Some claims only** (`--only`): {', '.join(chosen)}. The other claims, "
              "their runs and their figures are not part of this report.", ""]
    if not_run:
        how = ("`--reuse-only`: this build started none" if reuse_only else
               "`--runs`: this build started only those")
        L += [f"> **Runs not done yet** ({how}): "
              f"{', '.join(not_run)}. The claims reading them use the runs that are done "
              "(the seeds whose runs are all done) or say \"run missing\"; run the same "
              f"command without `{'--reuse-only' if reuse_only else '--runs'}` to do them.",
              ""]
    if scale.smoke:
        L += ["> **Smoke scale.** The samples are far too small and the strains too short for "
              "any claim to be judged: every claim below is marked *not comparable*. The "
              "column \"criterion here\" shows what the criterion gives on these numbers, as a "
              "check that the pipeline works, not as a result. Run `nscd paper` (default scale) "
              "or `--scale paper` for verdicts.", ""]
    return L


def _claim_lines(scale, claims) -> list:
    """The verdict counts, the claims table and the criteria."""
    counts = {s: sum(c.status == s for c in claims)
              for s in ("reproduced", "not reproduced", "not comparable")}
    L = [f"Verdicts: {counts['reproduced']} reproduced, {counts['not reproduced']} not "
         f"reproduced, {counts['not comparable']} not comparable (of {len(claims)} claims).", "",
         "## Claims", "",
         "| # | figure | claim | paper | ours | verdict |"
         + (" criterion here |" if scale.smoke else ""),
         "|---|---|---|---|---|---|" + ("---|" if scale.smoke else "")]
    # the criterion's own outcome differs from the verdict at the smoke scale only
    for c in claims:
        L.append(f"| {c.id} | {c.figure} | {c.claim} | {c.paper} | {c.ours} | "
                 f"**{c.status}** |" + (f" {c.outcome} |" if scale.smoke else ""))
    L += ["", "Criteria (in `workbench/paper/registry.py`; a criterion revised after seeing "
          "results says so in its note):", ""]
    for c in claims:
        L.append(f"- **{c.id}**: {c.criterion}." + (f" *Note:* {c.note}." if c.note else ""))
    return L


def _table2_lines(curves, rows) -> list:
    L = ["## Table 2 — H vs k", "",
          "Ours: `h_fit` — the slope found by `engine.analysis.macro_stiffness` (a final range "
          "linear within 1 %) or, when there is none, the least-squares line from ε = 0.6 % "
          "(the method and r² are given).", "",
          "| k [N] | paper H | paper H/H∞ | ours H [Pa] | ours H/H∞ | r² | method | linear from "
          "(ε, σ_w^eq) |", "|---|---|---|---|---|---|---|---|"]
    pmap = dict(zip(PAPER_VALUES["table2_k"], PAPER_VALUES["table2_H"]))
    H_inf = _H_of(curves.get("cylinder_rigid_seed0"))
    for k in list(PAPER_VALUES["table2_k"]) + ["∞"]:
        pH = pmap.get(k, PAPER_VALUES["table2_H_inf"] if k == "∞" else None)
        name = "cylinder_rigid_seed0" if k == "∞" else f"cylinder_k{_fmt_k(k)}_seed0"
        t = curves.get(name)
        f = h_fit(t["axial_strain"], t["wire_equivalent"]) if t is not None else None
        if name not in rows:
            ours = "not run at this scale"
        elif f is None:
            ours = "run failed" if rows[name]["status"] != "done" else "too few records"
        else:
            ours = _g(f["H"])
        start = (f"({100 * float(t['axial_strain'][f['start']]):.2f} %, "
                 f"{float(t['wire_equivalent'][f['start']]):.3g} Pa)" if f else "")
        L.append(f"| {k} | {pH} | {pH / PAPER_VALUES['table2_H_inf']:.2f} | {ours} | "
                 f"{_g(f['H'] / H_inf, '.2f') if f and H_inf else 'n/a'} | "
                 f"{_g(f['r2'], '.2f') if f else ''} | {f['method'] if f else ''} | {start} |")
    return L + [""]


def _run_lines(scale, rows, pvds, out) -> list:
    L = ["## Runs", "",
          "Sweep table: `sweep.json` / `sweep.h5` (re-running `nscd paper` with the same "
          "`--out` skips the runs already done). Histories: `runs/<name>.h5` "
          "(`nscd info`, `nscd render`, `nscd export`); curves: `runs/<name>.curves.h5`.", "",
          "| run | status | seed | parameters | steps | not converged | time [s] |",
          "|---|---|---|---|---|---|---|"]
    for name, r in rows.items():
        p = {k: v for k, v in r["params"].items() if k not in ("name", "seed")}
        res = r.get("result") or {}
        if res.get("threads", 1) != 1:                 # a build's --threads (not a parameter)
            p["threads"] = res["threads"]
        share = res.get("non_converged_share")
        el = r.get("elapsed")
        status = r["status"] + (" (reused)" if r.get("skipped") else "")
        if res.get("resumed_from"):          # run in parts: the steps' time of all of them
            status += f" (resumed at step {res['resumed_from'].replace(',', ', ')}"
            if res.get("resumed_with_other_code"):
                status += (f"; at step {res['resumed_with_other_code'].replace(',', ', ')} "
                           f"with other engine code")
            status += ")"
            el = res.get("steps_wall_time", el)
        if r["status"] == "failed":
            status += ": " + (r["errors"][-1].splitlines()[0] if r["errors"] else "")
        L.append(f"| {name} | {status} | {r['params'].get('seed')} | "
                 f"{', '.join(f'{k}={v}' for k, v in p.items())} | {res.get('steps', '')} | "
                 f"{_g(share, '.1%') if share is not None else ''} | "
                 f"{_g(el, '.1f') if el is not None else ''} |")
    L += ["", "ParaView series (open the .pvd):", ""]
    for run, p in pvds.items():
        L.append(f"- {run}: `{_rel(p, out)}`")
    L += ["", "## Parameters common to the runs", "",
          "Paper defaults of `engine.experiments` unless listed per run above: confining "
          "pressure 15 kPa, inertial number I = 5e-4 (quasi-static), dt = 5e-5 s (deposits: the "
          "scale's dt), θ = 0.5, NLGS tol 3e-4 (triaxial) / 1e-4 (deposits), μ sand 0.5, μ wire "
          "0.3, μ of the mould 0.5 (Fig. 7); wire law ElasticWire(k = 1 N) unless the run says "
          "otherwise. Seeds: 0 for every "
          f"figure, {list(fig10_seeds(scale))} for Fig. 7 and 10, "
          f"{list(scale.fig14_seeds)} for Fig. "
          "11, Fig. 13c and Fig. 14 (small effects and sparse maps).", ""]
    return L
