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

1. ``first_picture_s``: from starting the command to the first picture in the page: the
   first image of the view's full size shown (server: the load event of the view's
   <img>) or the first WebGL draw (client), noted by a page script in the page's clock
   (``performance.timeOrigin``), then checked not blank by a screenshot (a screenshot
   of the view takes 0.3-1 s here: polling with screenshots, as this bench did until
   2026-12-02, added that much to the figure); ``url_s``: to the URL printed (the server
   read the run and drew its first frame); ``page_s``: from opening the page to the
   picture;
2. ``frame_change_s``: from a key press on the time slider (Home: from the last frame,
   where the page opens, to the first, then the right arrow: frame after frame, each a
   frame the page has not shown before, so that client mode gets new arrays at every
   change: alternating the first and last frames, as this bench did until 2026-12-03,
   let the page reuse the arrays it already had) to the last picture of the new frame in
   the page (median
   and max over the changes): a page script notes when each server image is shown
   (``--mode server``) or each WebGL draw call (``--mode client``), so nothing polls the
   page while it works.  In server mode a change first sends an image at 60 % of the
   view's size, then the full one 0.25 s after (``workbench.view.app.LOD_RATIO``):
   ``first_image_s`` is when the new frame first shows, ``frame_change_s`` when it shows
   at full size; ``server_ms``: the server's own split of each change (scene, curves, the
   first image's push) as the page shows it;
3. ``server_rss_mb``, ``server_peak_mb``: the server's resident memory at the end, and its
   peak (``VmHWM``).

Writer slowdown: ``tests/workbench/follow_run.py`` (3 000 grains, 1 200 steps, a frame
every 20) alone, then with ``nscd view --follow`` and a page following it, ``--repeat``
times alternately: the time per frame interval of the frames written once the page had
loaded (+ 1 s) against the same frames of the run alone (``slowdown``, the median ratio
− 1), and the whole run's wall time, the viewer's start-up and the page load included
(``slowdown_whole_run``).

``--pictures`` also writes the screenshots of docs/view.md (the demo's run in the page).

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
#: Seconds given to a frame change before its pictures are counted.
SETTLE_S = 2.0
#: Page script timing each picture: the server's images arrive as blobs (an object URL
#: each) shown by an <img> of the view (its load event), vtk.js draws with WebGL (draw
#: calls).
HOOK = """
window.__draws = [];
window.__imgs = [];
for (const C of [window.WebGLRenderingContext, window.WebGL2RenderingContext]) {
  if (!C) continue;
  for (const m of ['drawArrays', 'drawElements', 'drawArraysInstanced',
                  'drawElementsInstanced']) {
    const f = C.prototype[m];
    if (!f) continue;
    C.prototype[m] = function(...a) { window.__draws.push(performance.now());
                                      return f.apply(this, a); };
  }
}
window.__shown = [];
document.addEventListener('load', (e) => {
  const t = e.target;
  if (t && t.tagName === 'IMG' && t.closest('#view3d'))
    window.__shown.push([performance.now(), t.naturalWidth, t.naturalHeight]);
}, true);
const objectURL = URL.createObjectURL;
URL.createObjectURL = function(...a) { window.__imgs.push(performance.now());
                                       return objectURL.apply(this, a); };
"""
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
    t0_epoch = time.time()
    p = subprocess.Popen([NSCD, "view", str(path), "--mode", mode, "--shots",
                          tempfile.mkdtemp()], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, preexec_fn=_child, cwd=ROOT)
    try:
        line = p.stdout.readline()
        url = re.search(r"(http://\S+)", line).group(1)
        t_url = time.perf_counter() - t0
        pg = browser.new_page(viewport={"width": 1400, "height": 900})
        pg.add_init_script(HOOK)
        t1 = time.perf_counter()
        t1_epoch = time.time()
        pg.goto(url)
        pg.wait_for_selector("#view3d canvas", timeout=120000)
        # the first picture: the first image of the view's size shown (server), the first
        # WebGL draw (client), in the page's clock; then checked not blank
        js = ("(() => { const v = document.querySelector('#view3d'); const w = v.clientWidth;"
              " const s = window.__shown.filter(x => Math.abs(x[1] - w) <= 2);"
              " const t = %s; return t === undefined ? null :"
              " [performance.timeOrigin, t]; })()"
              % ("s.length ? s[0][0] : undefined" if mode == "server"
                 else "window.__draws[0]"))
        while (got := pg.evaluate(js)) is None:
            if time.perf_counter() - t1 > 120:
                raise RuntimeError(f"{mode}: no picture after 120 s")
            time.sleep(0.02)
        origin_ms, shown_ms = got
        t_first = (origin_ms + shown_ms) / 1e3 - t0_epoch
        t_page = (origin_ms + shown_ms) / 1e3 - t1_epoch
        time.sleep(0.5)
        if (~np.all(_pixels(pg) > 245, axis=2)).mean() <= 0.01:
            raise RuntimeError(f"{mode}: the first picture is blank")
        time.sleep(2.0)
        thumb = pg.locator("#frame-slider").locator(
            "xpath=ancestor::div[contains(@class, 'v-slider ')][1]").locator(".v-slider-thumb")
        n = int(re.search(r"/ (\d+)", pg.locator("#frame-info").inner_text()).group(1))
        dts, firsts, server = [], [], []
        for i in range(changes):
            # the first frame, then frame after frame: each one new to the page
            k = _frame(pg)
            key, want = ("ArrowRight", k + 1) if 0 <= k < n - 1 and i else ("Home", 0)
            thumb.focus()
            t_press = pg.evaluate("performance.now()")
            thumb.press(key)
            time.sleep(SETTLE_S)
            if _frame(pg) != want:
                raise RuntimeError(f"{mode}: frame change {i} not shown after {SETTLE_S} s")
            marks = pg.evaluate("mode => mode === 'server' ? "
                                "(window.__shown || []).map(x => x[0]) : "
                                "(window.__draws || [])", mode)
            after = [m - t_press for m in marks if m > t_press]
            if not after:
                raise RuntimeError(f"{mode}: no new picture after frame change {i}")
            dts.append(after[-1] / 1e3)
            firsts.append(after[0] / 1e3)
            server.append([float(x) for x in
                           re.findall(r"[\d.]+", pg.locator("#redraw-ms").inner_text())])
        rss, peak = _mem(p.pid)
        pg.close()
        return dict(mode=mode, url_s=t_url, first_picture_s=t_first, page_s=t_page,
                    frame_change_s=dict(median=statistics.median(dts), max=max(dts),
                                        all=dts),
                    first_image_s=dict(median=statistics.median(firsts), max=max(firsts),
                                       all=firsts),
                    server_ms=server, server_rss_mb=rss, server_peak_mb=peak)
    finally:
        p.send_signal(signal.SIGTERM)
        try:
            p.wait(timeout=30)
        except subprocess.TimeoutExpired:
            p.kill()


def writer_slowdown(browser, repeat: int, n_sand: int = 3000, steps: int = 1200,
                    every: int = 20) -> dict:
    """The writer's speed alone and followed by a viewer with a page open: the time per
    frame interval over the frames written once the page had loaded (+ 1 s), against the
    same frames of a run alone."""
    run = str(ROOT / "tests" / "workbench" / "follow_run.py")
    alone, followed, whole = [], [], {False: [], True: []}
    last_alone = []
    for r in range(repeat):
        for watched in (False, True):
            out = Path(tempfile.mkdtemp()) / "live.h5"
            sim = subprocess.Popen([sys.executable, run, str(out), "--steps", str(steps),
                                    "--frames", str(every), "--n-sand", str(n_sand)],
                                   stdout=subprocess.PIPE, text=True, cwd=ROOT)
            viewer = pg = None
            marks, t_loaded = [], None
            try:
                sim.stdout.readline()                          # frame 0
                if watched:
                    viewer = subprocess.Popen([NSCD, "view", str(out), "--follow"],
                                              stdout=subprocess.PIPE, text=True,
                                              preexec_fn=_child, cwd=ROOT)
                    url = re.search(r"(http://\S+)", viewer.stdout.readline()).group(1)
                    pg = browser.new_page(viewport={"width": 1400, "height": 900})
                    pg.goto(url)
                    pg.wait_for_selector("#view3d canvas", timeout=120000)
                    t_loaded = time.time()
                for line in sim.stdout:
                    f = line.split()
                    if f[0] == "frame":
                        marks.append((int(f[1]), float(f[2])))
                    elif f[0] == "done":
                        whole[watched].append(float(f[1]))
                sim.wait()
            finally:
                if pg is not None:
                    pg.close()
                if viewer is not None:
                    viewer.send_signal(signal.SIGTERM)
                    viewer.wait(timeout=30)
            if watched:
                steady = [(k, t) for k, t in marks if t > t_loaded + 1.0]
                k0, k1 = steady[0][0], steady[-1][0]
                per = (steady[-1][1] - steady[0][1]) / (k1 - k0)
                ref = dict(last_alone)
                per_alone = (ref[k1] - ref[k0]) / (k1 - k0)
                alone.append(per_alone)
                followed.append(per)
                print(f"  frames {k0}-{k1}: {per * 1e3:.1f} ms per frame followed, "
                      f"{per_alone * 1e3:.1f} ms alone", flush=True)
            else:
                last_alone = marks
    ratios = [f / a for f, a in zip(followed, alone)]
    return dict(n_sand=n_sand, steps=steps, frames_every=every,
                per_frame_alone_s=alone, per_frame_followed_s=followed,
                whole_run_alone_s=whole[False], whole_run_followed_s=whole[True],
                slowdown=statistics.median(ratios) - 1.0,
                slowdown_whole_run=statistics.median(whole[True]) /
                statistics.median(whole[False]) - 1.0)


def pictures(browser, path: Path, outdir: Path) -> list[str]:
    """The screenshots of docs/view.md: the page as a user sees it, made here (not by
    hand) with the browser tests' helpers."""
    from tests.workbench.test_view import choose, set_check, settled, start_view, stop

    outdir.mkdir(parents=True, exist_ok=True)
    p, url = start_view(path)
    made = []
    try:
        pg = browser.new_page(viewport={"width": 1400, "height": 900})
        pg.goto(url)
        pg.wait_for_selector("#view3d canvas", timeout=120000)
        time.sleep(3)
        settled(pg)

        def shot(name):
            time.sleep(1.0)
            settled(pg)
            f = outdir / f"view-{name}.png"
            pg.screenshot(path=str(f))
            made.append(str(f.relative_to(ROOT)))

        shot("default")
        pg.locator("#camera-front").click()
        choose(pg, "clip-axis", "y")
        set_check(pg, "clip-flip", True)             # keep the far half: the cut shows
        set_check(pg, "ghost", True)
        choose(pg, "color-by", "normal force")
        shot("clip-ghost-forces")
        choose(pg, "clip-axis", "none")
        set_check(pg, "clip-flip", False)
        set_check(pg, "ghost", False)
        set_check(pg, "layer-forces", False)
        set_check(pg, "layer-sand", False)
        choose(pg, "color-by", "tension")
        set_check(pg, "layer-torus", True)
        pg.locator("#camera-iso").click()
        shot("wire-torus")
        pg.close()
    finally:
        stop(p)
    return made


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--changes", type=int, default=8)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--only", choices=("speed", "writer"), default=None,
                    help="only the speed figures, or only the writer's slowdown")
    ap.add_argument("--pictures", action="store_true",
                    help="also write docs/images/view-*.png (the screenshots of docs/view.md)")
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
        for name, path in (runs.items() if a.only != "writer" else ()):
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
                      f"{r['frame_change_s']['max']:.3f} s (its first image "
                      f"{r['first_image_s']['median']:.3f} s); server {r['server_rss_mb']:.0f} MB "
                      f"(peak {r['server_peak_mb']:.0f} MB)", flush=True)
        if a.pictures:
            out["pictures"] = pictures(browser, DEMO, ROOT / "docs" / "images")
            print("pictures: " + ", ".join(out["pictures"]), flush=True)
        if not a.quick and a.only != "speed":
            out["writer"] = writer_slowdown(browser, a.repeat)
            w = out["writer"]
            print(f"writer followed by a viewer: {100 * w['slowdown']:+.1f} % per frame once "
                  f"the page is loaded, {100 * w['slowdown_whole_run']:+.1f} % over the whole "
                  f"run (the viewer's start included)", flush=True)
        browser.close()
    out["busy"] = busy.finish()
    path = record.write("view", out, quick=a.quick)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
