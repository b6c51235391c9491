"""The viewer's speed, seen from a real browser: time to the first picture, time per frame
change, the server's memory, for server-side rendering (``--mode server``, VTK + Mesa's
llvmpipe, images streamed) against client-side rendering (``--mode client``, vtk.js in
Chromium's software WebGL); and how much a viewer following a run slows the run's writer.

Run:  .venv/bin/python bench/bench_view.py              (about 5 min; the paper-scale
                                                        history is made first if missing:
                                                        about 15 min more)
      .venv/bin/python bench/bench_view.py --quick      (the demo's run only, 2 changes)

Histories:
* ``demo``: ``out/demo/run.h5`` (``make demo``: 729 spheres, 108 wire links);
* ``paper``: ``out/bench_view/paper_deposit.h5``, the paper-scale mould deposit
  (``gravity_deposit(1.0, sample="slope")``, 26 000 grains + 2 900 wire beads, 300 steps,
  a frame every 40 steps).

Per history and mode, ``nscd view PATH --mode M`` runs as a subprocess and Chromium
(Debian's, driven by Playwright) opens its URL at 1400 x 900 px:

1. ``first_picture_s``: from starting the command to the first picture in the page (the
   3D view's canvas no longer blank); ``url_s``: to the URL printed (the server read the
   run and drew its first frame); ``page_s``: from opening the page to the picture;
2. ``frame_change_s``: after a key press on the time slider (Home / End: from the last
   frame to the first and back, a change that surely shows), until the view shows the
   new frame (median and max over the changes).  The view is read by JPEG screenshots of
   its box: ``screenshot_s`` is the cost of one, so the figure is an upper bound by about
   that much;
3. ``server_rss_mb``, ``server_peak_mb``: the server's resident memory at the end, and its
   peak (``VmHWM``).

Writer slowdown: ``tests/workbench/follow_run.py`` (3 000 grains, 300 steps, a frame every
10) alone, then with ``nscd view --follow`` and a page following it, ``--repeat`` times
alternately; the ratio of the medians of the run's own wall time.

Targets (issue 28): first picture <= 3 s and frame change <= 0.3 s at 30 000 beads on this
machine; the fastest mode is the default.  Writes bench/results/view-<YYYYmmdd-HHMM>.json.
"""
from __future__ import annotations

import argparse
import io as _io
import re
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

import numpy as np  # noqa: E402

import record  # noqa: E402

NSCD = str(Path(sys.executable).with_name("nscd"))
CHROMIUM = "/usr/bin/chromium"
ARGS = ["--no-sandbox", "--enable-unsafe-swiftshader", "--use-angle=swiftshader",
        "--disable-background-networking", "--disable-component-update", "--disable-sync",
        "--no-first-run"]
PAPER = ROOT / "out" / "bench_view" / "paper_deposit.h5"
DEMO = ROOT / "out" / "demo" / "run.h5"


def make_paper_history(path: Path) -> None:
    from engine.experiments import gravity_deposit

    print(f"making {path} (the paper-scale mould deposit, 300 steps: ~15 min)", flush=True)
    gravity_deposit(1.0, sample="slope", steps=300, frames=30, tol=2e-4, history=str(path),
                    progress=True)


def _child():
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _mem(pid) -> tuple[float, float]:
    rss = peak = float("nan")
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                rss = int(line.split()[1]) / 1024
            elif line.startswith("VmHWM:"):
                peak = int(line.split()[1]) / 1024
    return rss, peak


def _pixels(pg, box=None):
    """The 3D view's pixels (``box``: that clip of the page, as a JPEG: cheaper to take)."""
    from PIL import Image

    png = (pg.screenshot(clip=box, type="jpeg", quality=60) if box
           else pg.locator("#view3d canvas").screenshot())
    return np.asarray(Image.open(_io.BytesIO(png)).convert("RGB"))


def _frame(pg) -> int:
    m = re.search(r"frame (\d+) /", pg.locator("#frame-info").inner_text())
    return int(m.group(1)) - 1 if m else -1


def measure(path: Path, mode: str, browser, changes: int) -> dict:
    t0 = time.perf_counter()
    p = subprocess.Popen([NSCD, "view", str(path), "--mode", mode, "--shots",
                          tempfile.mkdtemp()], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, preexec_fn=_child, cwd=ROOT)
    try:
        line = p.stdout.readline()
        url = re.search(r"(http://\S+)", line).group(1)
        t_url = time.perf_counter() - t0
        pg = browser.new_page(viewport={"width": 1400, "height": 900})
        t1 = time.perf_counter()
        pg.goto(url)
        pg.wait_for_selector("#view3d canvas", timeout=120000)
        while True:
            img = _pixels(pg)
            if (~np.all(img > 245, axis=2)).mean() > 0.01:
                break
            if time.perf_counter() - t1 > 120:
                raise RuntimeError(f"{mode}: no picture after 120 s")
            time.sleep(0.02)
        t_first = time.perf_counter() - t0
        t_page = time.perf_counter() - t1
        time.sleep(1.0)
        box = pg.locator("#view3d canvas").bounding_box()
        shots = []
        for _ in range(5):
            ts = time.perf_counter()
            _pixels(pg, box)
            shots.append(time.perf_counter() - ts)
        thumb = pg.locator("#frame-slider").locator(
            "xpath=ancestor::div[contains(@class, 'v-slider ')][1]").locator(".v-slider-thumb")
        n = int(re.search(r"/ (\d+)", pg.locator("#frame-info").inner_text()).group(1))
        dts = []
        img = _pixels(pg, box)
        for i in range(changes):
            # between the first and the last frame: a change that surely shows
            key, want = ("Home", 0) if _frame(pg) != 0 else ("End", n - 1)
            thumb.focus()
            ts = time.perf_counter()
            thumb.press(key)
            while True:
                now = _pixels(pg, box)
                if _frame(pg) == want and np.abs(now.astype(int) - img).sum(axis=2).max() > 60:
                    break
                if time.perf_counter() - ts > 60:
                    raise RuntimeError(f"{mode}: frame change {i} not shown after 60 s")
            dts.append(time.perf_counter() - ts)
            time.sleep(1.0)                    # let the still image land before the next one
            img = _pixels(pg, box)
        rss, peak = _mem(p.pid)
        pg.close()
        return dict(mode=mode, url_s=t_url, first_picture_s=t_first, page_s=t_page,
                    frame_change_s=dict(median=statistics.median(dts), max=max(dts),
                                        all=dts),
                    screenshot_s=statistics.median(shots), server_rss_mb=rss,
                    server_peak_mb=peak)
    finally:
        p.send_signal(signal.SIGTERM)
        try:
            p.wait(timeout=30)
        except subprocess.TimeoutExpired:
            p.kill()


def writer_slowdown(browser, repeat: int, n_sand: int = 3000) -> dict:
    run = str(ROOT / "tests" / "workbench" / "follow_run.py")
    alone, followed = [], []
    for r in range(repeat):
        for watched in (False, True):
            out = Path(tempfile.mkdtemp()) / "live.h5"
            sim = subprocess.Popen([sys.executable, run, str(out), "--steps", "300",
                                    "--frames", "10", "--n-sand", str(n_sand)],
                                   stdout=subprocess.PIPE, text=True, cwd=ROOT)
            viewer = pg = None
            try:
                line = sim.stdout.readline()               # the first frame
                if watched:
                    viewer = subprocess.Popen([NSCD, "view", str(out), "--follow"],
                                              stdout=subprocess.PIPE, text=True,
                                              preexec_fn=_child, cwd=ROOT)
                    url = re.search(r"(http://\S+)", viewer.stdout.readline()).group(1)
                    pg = browser.new_page(viewport={"width": 1400, "height": 900})
                    pg.goto(url)
                for line in sim.stdout:
                    if line.startswith("done"):
                        wall = float(line.split()[1])
                sim.wait()
            finally:
                if pg is not None:
                    pg.close()
                if viewer is not None:
                    viewer.send_signal(signal.SIGTERM)
                    viewer.wait(timeout=30)
            (followed if watched else alone).append(wall)
            print(f"  writer {'followed' if watched else 'alone   '} {wall:.2f} s", flush=True)
    ma, mf = statistics.median(alone), statistics.median(followed)
    return dict(n_sand=n_sand, steps=300, frames_every=10, alone_s=alone, followed_s=followed,
                median_alone_s=ma, median_followed_s=mf, slowdown=mf / ma - 1.0)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--changes", type=int, default=8)
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args(argv)
    busy = record.Busy()
    if not DEMO.exists():
        subprocess.run([NSCD, "demo", "--out", str(DEMO.parent)], check=True, cwd=ROOT)
    runs = {"demo": DEMO}
    if not a.quick:
        if not PAPER.exists():
            PAPER.parent.mkdir(parents=True, exist_ok=True)
            make_paper_history(PAPER)
        runs["paper"] = PAPER
    from engine import io
    from playwright.sync_api import sync_playwright

    out = dict(machine=record.machine(), histories={}, results=[])
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        for name, path in runs.items():
            m = io.load_model(path)
            out["histories"][name] = dict(path=str(path.relative_to(ROOT)),
                                          spheres=int(m.n_spheres), links=int(m.n_links),
                                          frames=int(len(io.frame_index(path)[0])))
            for mode in ("server", "client"):
                r = measure(path, mode, browser, 2 if a.quick else a.changes)
                r["history"] = name
                out["results"].append(r)
                print(f"{name:5s} {mode:6s} first picture {r['first_picture_s']:.2f} s "
                      f"(URL {r['url_s']:.2f} s, page {r['page_s']:.2f} s); frame change "
                      f"median {r['frame_change_s']['median']:.3f} s, max "
                      f"{r['frame_change_s']['max']:.3f} s (one screenshot "
                      f"{r['screenshot_s']:.3f} s); server {r['server_rss_mb']:.0f} MB "
                      f"(peak {r['server_peak_mb']:.0f} MB)", flush=True)
        if not a.quick:
            out["writer"] = writer_slowdown(browser, a.repeat)
            w = out["writer"]
            print(f"writer: {w['median_alone_s']:.2f} s alone, {w['median_followed_s']:.2f} s "
                  f"followed by a viewer: {100 * w['slowdown']:+.1f} %", flush=True)
        browser.close()
    out["busy"] = busy.finish()
    path = record.write("view", out, quick=a.quick)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
