"""Workbench output benchmark: cost of one ParaView frame (VTU parts + PVD) and of one
off-screen picture per render preset, for a ~30 000-bead TexSol scene, against the cost
of one engine step of the same scene.

Run:  .venv/bin/python bench/bench_render.py            (about 1 min on 2 shared cores)
      .venv/bin/python bench/bench_render.py --quick    (2 000 beads, a smoke run)

Writes bench/results/render-<YYYYmmdd-HHMM>.json and bench/results/render-latest.json
(``-quick`` in the names for --quick).

Scene: ``tests/workbench/scenes.texsol_cylinder`` scaled up: N sand spheres (r = 0.25 mm
± 10 %) on a lattice with 2 % gaps in a cylinder, a closed elastic wire ring; run
``--settle`` steps (dt = 1e-4 s) so that contacts exist, then:

1. ``step``: wall time of each of ``--steps`` engine steps (median and mean), contacts,
   NLGS sweeps per step;
2. ``frame``: wall time of ``SeriesWriter.write`` (all parts: beads, contacts, wire,
   walls; meshio, uncompressed and zlib), its split into building the parts (numpy) and
   writing them, file sizes, and for comparison VTK's own XML writer on the same beads +
   contacts (``vtkXMLUnstructuredGridWriter``, appended raw binary);
   the ratio ``frame / (every × step)`` is the share of run time spent on ParaView output
   at the default writing interval (``SeriesWriter(every=100)``); the target is < 5 %;
3. ``render``: wall time of ``workbench.render.snapshot`` per preset at 800 x 600 px
   (scene building, GL render on Mesa's llvmpipe through EGL, PNG encoding), the best of
   ``--repeat`` runs; the first picture of the process also pays the GL context set-up
   (reported as ``first_s``).

Timings on a machine shared with other jobs are noisy: the JSON records the load average
at the start and the end.
"""
from __future__ import annotations

import argparse
import datetime as _dt
import json
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

sys.path.insert(0, str(ROOT / "bench"))
import record  # noqa: E402
from engine import step  # noqa: E402
from tests.workbench.scenes import texsol_cylinder  # noqa: E402
from workbench.series import SeriesWriter  # noqa: E402

EVERY = 100  # SeriesWriter's default writing interval [steps]


def _dir_size(path: Path) -> int:
    return sum(p.stat().st_size for p in path.iterdir() if p.is_file())


def bench_frame(model, state, out: Path, repeat: int) -> dict:
    res = {}
    for comp in (None, "zlib"):
        times = []
        for r in range(repeat):
            d = out / f"series-{comp}-{r}"
            w = SeriesWriter(d, every=EVERY, name="f", compression=comp)
            t0 = time.perf_counter()
            w.write(model, state)
            times.append(time.perf_counter() - t0)
        res[f"write_{comp or 'raw'}_s"] = min(times)
        res[f"write_{comp or 'raw'}_median_s"] = float(np.median(times))
        res[f"bytes_{comp or 'raw'}"] = _dir_size(out / f"series-{comp}-0")
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        w.frame_parts(model, state)
        times.append(time.perf_counter() - t0)
    res["build_parts_s"] = min(times)
    parts = w.frame_parts(model, state)
    res["parts"] = {k: dict(points=p.n_points, cells=p.n_cells) for k, p in parts.items()}
    # VTK's XML writer on the same beads + contacts parts, for the meshio-or-VTK choice
    try:
        import pyvista as pv  # noqa: F401
        from vtkmodules.vtkIOXML import vtkXMLUnstructuredGridWriter

        grids = {k: parts[k].to_polydata().cast_to_unstructured_grid() for k in ("beads", "contacts")}
        times = []
        for r in range(repeat):
            t0 = time.perf_counter()
            for k, g in grids.items():
                wr = vtkXMLUnstructuredGridWriter()
                wr.SetFileName(str(out / f"vtk-{k}-{r}.vtu"))
                wr.SetInputData(g)
                wr.SetDataModeToAppended()
                wr.EncodeAppendedDataOff()
                wr.SetCompressorTypeToNone()
                wr.Write()
            times.append(time.perf_counter() - t0)
        res["vtk_xml_beads_contacts_s"] = min(times)
        times = []
        for r in range(repeat):
            t0 = time.perf_counter()
            import meshio

            for k in ("beads", "contacts"):
                meshio.write(out / f"mio-{k}-{r}.vtu", parts[k].to_meshio(), file_format="vtu",
                             compression=None)
            times.append(time.perf_counter() - t0)
        res["meshio_beads_contacts_s"] = min(times)
    except ImportError as e:  # pragma: no cover
        res["vtk_xml_error"] = str(e)
    return res


def bench_render(model, state, out: Path, repeat: int) -> dict:
    from workbench import render

    res = {"backend": render.headless_backend()}
    first = True
    for preset in render.PRESETS:
        times = []
        for r in range(repeat):
            t0 = time.perf_counter()
            render.snapshot(model, state, out / f"{preset}-{r}.png", preset=preset)
            times.append(time.perf_counter() - t0)
        res[preset] = dict(best_s=min(times), median_s=float(np.median(times)), runs=times)
        if first:
            res["first_s"] = times[0]
            first = False
    import pyvista as pv

    pl = pv.Plotter(off_screen=True)
    try:
        res["gl"] = pl.ren_win.ReportCapabilities().splitlines()[:6]
    finally:
        pl.close()
    return res


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=30000, help="sand spheres")
    ap.add_argument("--settle", type=int, default=200, help="steps before measuring")
    ap.add_argument("--steps", type=int, default=8, help="steps measured")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="2 000 beads, a smoke run")
    ap.add_argument("--out-dir", default=str(ROOT / "bench" / "results"))
    a = ap.parse_args(argv)
    if a.quick:
        a.n, a.settle, a.steps, a.repeat = 2000, 20, 3, 2
    started = _dt.datetime.now()
    busy = record.Busy()
    radius = 2.5e-3 * np.sqrt(a.n / 300.0) * 0.9
    t0 = time.perf_counter()
    model, state, _ = texsol_cylinder(n_sand=a.n, wire_beads=400, steps=0,
                                      container_radius=radius, max_iter=1000)
    build_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    for _ in range(a.settle):
        step(model, state)
    settle_s = time.perf_counter() - t0
    times, sweeps, contacts = [], [], []
    for _ in range(a.steps):
        t0 = time.perf_counter()
        st = step(model, state)
        times.append(time.perf_counter() - t0)
        sweeps.append(st.iterations)
        contacts.append(st.n_contacts)
    step_res = dict(median_s=float(np.median(times)), mean_s=float(np.mean(times)), runs=times,
                    sweeps=sweeps, contacts=contacts, settle_steps=a.settle, settle_s=settle_s,
                    build_s=build_s)
    print(f"{model.n_spheres} beads ({model.n_links} wire links), {contacts[-1]} contacts; "
          f"step {step_res['median_s'] * 1e3:.1f} ms (median of {a.steps}, "
          f"{int(np.median(sweeps))} sweeps)")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        frame = bench_frame(model, state, tmp, a.repeat)
        per = EVERY * step_res["median_s"]
        frame["share_of_run_at_every_100"] = frame["write_raw_s"] / (per + frame["write_raw_s"])
        frame["share_of_run_at_every_100_zlib"] = frame["write_zlib_s"] / (per + frame["write_zlib_s"])
        frame["frame_over_one_step"] = frame["write_raw_s"] / step_res["median_s"]
        print(f"frame (meshio, raw): {frame['write_raw_s'] * 1e3:.1f} ms "
              f"({frame['bytes_raw'] / 1e6:.1f} MB) = {frame['frame_over_one_step']:.2f} step; "
              f"{100 * frame['share_of_run_at_every_100']:.2f} % of the run at every={EVERY}")
        print(f"frame (meshio, zlib): {frame['write_zlib_s'] * 1e3:.1f} ms "
              f"({frame['bytes_zlib'] / 1e6:.1f} MB) = "
              f"{100 * frame['share_of_run_at_every_100_zlib']:.2f} % at every={EVERY}")
        print(f"building the parts (numpy): {frame['build_parts_s'] * 1e3:.1f} ms; beads+contacts: "
              f"meshio {frame.get('meshio_beads_contacts_s', float('nan')) * 1e3:.1f} ms, "
              f"VTK XML {frame.get('vtk_xml_beads_contacts_s', float('nan')) * 1e3:.1f} ms")
        # HDF5: one history record and one frame (engine.io.History)
        from engine.io import History
        h = History(tmp / "h.h5", trigger=1, frames=1, flush=1)
        frame_t = []
        for r in range(a.repeat + 1):
            t0 = time.perf_counter()
            h.write(model, state)          # record + frame (frames=1), flushed (flush=1)
            dt_ = time.perf_counter() - t0
            if r:                          # the first call creates the datasets
                frame_t.append(dt_)
            state.step += 1                # History wants increasing steps
        h.close()
        state.step -= a.repeat + 1
        frame["hdf5_record_and_frame_s"] = float(np.median(frame_t))
        frame["hdf5_share_of_run_at_every_100"] = frame["hdf5_record_and_frame_s"] / (
            per + frame["hdf5_record_and_frame_s"])
        print(f"HDF5 record + frame (engine.io.History, flushed): "
              f"{frame['hdf5_record_and_frame_s'] * 1e3:.1f} ms = "
              f"{100 * frame['hdf5_share_of_run_at_every_100']:.2f} % of the run at every={EVERY}")
        rend = bench_render(model, state, tmp, a.repeat)
        for p in ("beads", "wire", "forces", "torus"):
            print(f"render {p:6s}: {rend[p]['best_s']:.2f} s (best of {a.repeat}; median "
                  f"{rend[p]['median_s']:.2f} s)")
    out = dict(benchmark="render", started=started.isoformat(timespec="seconds"), quick=a.quick,
               machine=record.machine(), busy=busy.finish(),
               git=dict(commit=record.git_commit()),
               scene=dict(beads=model.n_spheres, links=model.n_links, walls=model.n_walls),
               step=step_res, frame=frame, render=rend, every=EVERY)
    od = Path(a.out_dir)
    od.mkdir(parents=True, exist_ok=True)
    suffix = "-quick" if a.quick else ""
    text = json.dumps(out, indent=1)
    (od / f"render-{started.strftime('%Y%m%d-%H%M')}{suffix}.json").write_text(text)
    (od / f"render-latest{suffix}.json").write_text(text)
    print(f"wrote {od / f'render-latest{suffix}.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
