"""``nscd view`` in a real browser: Debian's Chromium driven by Playwright for Python.

The server is the ``nscd view`` command itself (a subprocess on 127.0.0.1 with a free
port); the page is checked as a user sees it: the text it shows and the pixels of its 3D
view.  Chromium comes from ``make sysdeps`` (apt); without it these tests are skipped with
a message, never silently passed.
"""
from __future__ import annotations

import io as _io
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from engine import io

ROOT = Path(__file__).resolve().parents[2]
CHROMIUM = "/usr/bin/chromium"
NSCD = str(Path(sys.executable).with_name("nscd"))
RUN = str(ROOT / "tests" / "workbench" / "follow_run.py")
ARGS = ["--no-sandbox", "--enable-unsafe-swiftshader", "--use-angle=swiftshader",
        "--disable-gpu", "--disable-background-networking", "--disable-component-update",
        "--disable-sync", "--no-first-run"]

needs_browser = pytest.mark.skipif(not os.path.exists(CHROMIUM),
                                   reason="Debian's chromium is missing (make sysdeps installs it)")


def _child():
    signal.signal(signal.SIGINT, signal.SIG_DFL)   # a background shell ignores SIGINT


def start_view(path, *extra, env=None):
    """``nscd view PATH`` in a subprocess; returns (process, url) once it listens."""
    p = subprocess.Popen([NSCD, "view", str(path), *extra], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, cwd=ROOT, preexec_fn=_child,
                         env=env)
    line = p.stdout.readline()
    m = re.search(r"(http://\S+)", line)
    if not m:
        p.kill()
        raise AssertionError(f"nscd view printed no URL: {line!r} {p.stderr.read()[-2000:]}")
    return p, m.group(1)


def stop(p):
    p.send_signal(signal.SIGTERM)
    try:
        return p.wait(timeout=30)
    except subprocess.TimeoutExpired:
        p.kill()
        raise


def make_history(path, steps=120, frames=20):
    r = subprocess.run([sys.executable, RUN, str(path), "--steps", str(steps), "--frames",
                        str(frames)], capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert r.returncode == 0, r.stderr[-2000:]
    return path


@pytest.fixture(scope="module")
def history(tmp_path_factory):
    return make_history(tmp_path_factory.mktemp("view") / "run.h5")


@pytest.fixture(scope="module")
def browser():
    if not os.path.exists(CHROMIUM):
        pytest.skip("Debian's chromium is missing (make sysdeps installs it)")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        b = pw.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        yield b
        b.close()


@pytest.fixture(scope="module", params=[pytest.param("server", marks=pytest.mark.slow), "client"])
def served(request, history):
    """The viewer of ``history`` in each rendering mode (the page's tests run in both)."""
    p, url = start_view(history, "--mode", request.param,
                        "--shots", str(Path(history).parent / f"shots-{request.param}"))
    yield url, request.param
    assert stop(p) == 130


@pytest.fixture
def page(browser, served):
    pg = browser.new_page(viewport={"width": 1400, "height": 900})
    pg.goto(served[0])
    pg.nscd_mode = served[1]
    pg.wait_for_selector("#view3d canvas", timeout=60000)
    wait_until(lambda: "step" in text(pg, "#frame-info"), what="the frame's info")
    yield pg
    pg.close()


# ---------------------------------------------------------------- helpers
def wait_until(fn, timeout=30.0, what="the condition"):
    t0 = time.time()
    while time.time() - t0 < timeout:
        try:
            v = fn()
        except Exception:           # an element not yet there
            v = None
        if v:
            return v
        time.sleep(0.1)
    raise AssertionError(f"timed out after {timeout:.0f} s waiting for {what}")


def text(pg, sel) -> str:
    return pg.locator(sel).inner_text()


def pixels(pg) -> np.ndarray:
    """The 3D view as an (h, w, 3) uint8 array."""
    from PIL import Image

    png = pg.locator("#view3d canvas").screenshot()
    return np.asarray(Image.open(_io.BytesIO(png)).convert("RGB"))


def settled(pg, before=None, timeout=30.0) -> np.ndarray:
    """The view's pixels once two shots 0.4 s apart agree (and differ from ``before``)."""
    t0 = time.time()
    last = pixels(pg)
    while time.time() - t0 < timeout:
        time.sleep(0.4)
        now = pixels(pg)
        if np.array_equal(now, last) and (before is None or not np.array_equal(now, before)):
            return now
        last = now
    if before is not None:
        raise AssertionError("the 3D view did not change")
    return last


def shown(pg) -> np.ndarray:
    """The view's pixels once the scene is drawn (not blank) and settled (client mode
    draws a moment after the page loads)."""
    wait_until(lambda: (~np.all(pixels(pg) > 245, axis=2)).mean() > 0.02, what="a picture")
    return settled(pg)


def after(pg, action) -> np.ndarray:
    """The view's pixels once ``action()`` has changed them (a button's camera reaches a
    client-side view a moment after the click)."""
    before = shown(pg)
    action()
    return settled(pg, before)


def screenshot_pixels(pg) -> np.ndarray:
    """The pixels of the PNG the screenshot button writes (the message names it; the same
    frame gives the same name, so the file must be newer than the click)."""
    from PIL import Image

    t0 = time.time()
    pg.locator("#screenshot").click()

    def written():
        msg = text(pg, "#message")
        if "wrote " not in msg:
            return None
        path = Path(msg.split("wrote ", 1)[1].strip())
        path = path if path.is_absolute() else ROOT / path
        return path if path.exists() and path.stat().st_mtime >= t0 - 0.01 else None

    path = wait_until(written, what="the screenshot")
    time.sleep(0.2)                                    # written in full
    return np.asarray(Image.open(path).convert("RGB"))


def frame_of(pg) -> tuple[int, int, int]:
    """(frame index from 0, frames, step) shown beside the slider."""
    m = re.search(r"frame (\d+) / (\d+) · step (\d+)", text(pg, "#frame-info"))
    return int(m.group(1)) - 1, int(m.group(2)), int(m.group(3))


def set_check(pg, id_, value: bool):
    box = pg.locator(f"#{id_}")
    if box.is_checked() != value:
        box.click()


def choose(pg, id_, title):
    """Pick ``title`` in the select ``id_`` (its menu opens on a click on the field)."""
    pg.locator(f"#{id_}").locator("xpath=ancestor::div[contains(@class, 'v-field ')][1]").click()
    item = pg.locator(".v-overlay-container .v-list-item-title").get_by_text(
        re.compile(rf"^{re.escape(title)}( \[|$)"))
    item.first.click()
    pg.keyboard.press("Escape")


def slider_key(pg, id_, key, times=1):
    thumb = pg.locator(f"#{id_}").locator(
        "xpath=ancestor::div[contains(@class, 'v-slider ')][1]").locator(".v-slider-thumb")
    thumb.focus()
    for _ in range(times):
        thumb.press(key)


def sandy(img) -> np.ndarray:
    """Pixels of the sand's colour (render.SAND_COLOR, tan, lit or not): red well above
    blue."""
    rgb = img.astype(int)
    return rgb[..., 0] - rgb[..., 2] > 40


def bluish(img) -> np.ndarray:
    """Pixels of the wire's colour (render.WIRE_COLOR, #1f4e9c, lit or not): blue well
    above red; the sand (tan), the walls (grey) and the background (white) are not."""
    rgb = img.astype(int)
    return rgb[..., 2] - rgb[..., 0] > 40


# ---------------------------------------------------------------- tests
@needs_browser
def test_page_shows_the_sample_and_the_time_slider_moves_it(page, history):
    img = settled(page)
    bg = np.all(img > 245, axis=2)
    assert (~bg).mean() > 0.05, "the 3D view is blank"
    k, n, step = frame_of(page)
    steps, _ = io.frame_index(history)
    assert (k, n, step) == (len(steps) - 1, len(steps), int(steps[-1]))   # the last frame
    slider_key(page, "frame-slider", "Home")
    wait_until(lambda: frame_of(page)[0] == 0, what="frame 1")
    assert frame_of(page)[2] == int(steps[0])
    img0 = settled(page, img)
    moved = np.abs(img0.astype(int) - img.astype(int)).sum(axis=2) > 30
    assert moved.mean() > 0.005, "the pixels did not change with the frame"
    page.locator("#next").click()
    wait_until(lambda: frame_of(page)[0] == 1, what="frame 2 after 'next'")


@pytest.mark.slow
@needs_browser
def test_the_mouse_turns_the_view_and_play_runs_the_frames(page):
    slider_key(page, "frame-slider", "End")          # (the server keeps the last test's)
    wait_until(lambda: frame_of(page)[0] == frame_of(page)[1] - 1, what="the last frame")
    after(page, page.locator("#camera-top").click)
    before = after(page, page.locator("#camera-iso").click)
    shot_before = screenshot_pixels(page)
    box = page.locator("#view3d canvas").bounding_box()
    x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    page.mouse.move(x, y)
    page.mouse.down()
    for k in range(1, 11):
        page.mouse.move(x + 12 * k, y + 3 * k)
    page.mouse.up()
    turned = settled(page, before)
    assert not text(page, "#picked").strip(), "the drag that turned the view picked"
    assert np.abs(turned.astype(int) - before.astype(int)).sum(axis=2).__gt__(30).mean() > 0.01
    # the screenshot button writes the turned view (client mode: the browser's camera
    # reaches the server once the mouse lets go)
    shot_turned = screenshot_pixels(page)
    assert np.abs(shot_turned.astype(int) - shot_before.astype(int)).sum(axis=2).__gt__(
        30).mean() > 0.01, "the screenshot did not follow the mouse's turn"
    slider_key(page, "frame-slider", "Home")
    wait_until(lambda: frame_of(page)[0] == 0)
    page.locator("#play").click()
    wait_until(lambda: frame_of(page)[0] >= 2, what="play to move the frames")
    page.locator("#play").click()                     # pause
    # a frame change the server made before the pause reached it may still land after it
    # (under load the page runs a second or more behind: 4 -> 5 was seen 1 s after the
    # click); so wait for the frames to stop, within 15 s, then check they stay stopped.
    # Still playing, at 5 frames/s, they never stop for 1.5 s
    deadline = time.monotonic() + 15.0
    k = frame_of(page)[0]
    while True:
        time.sleep(1.5)
        now = frame_of(page)[0]
        if now == k:
            break
        assert time.monotonic() < deadline, "pause did not stop the frames"
        k = now
    time.sleep(1.5)
    assert frame_of(page)[0] == k, "pause did not stop the frames"
    slider_key(page, "frame-slider", "End")          # back to the frame of `before`
    n = frame_of(page)[1]
    wait_until(lambda: frame_of(page)[0] == n - 1)
    played = settled(page)
    page.locator("#camera-reset").click()
    reset = settled(page, played)
    assert np.abs(reset.astype(int) - before.astype(int)).sum(axis=2).__gt__(30).mean() < 0.01


@needs_browser
def test_wire_layer_and_clip_change_the_expected_pixels(page):
    choose(page, "color-by", "kind")                  # the wire in its own colour
    page.locator("#camera-front").click()
    set_check(page, "layer-sand", False)
    img = settled(page)
    wire = bluish(img)
    assert wire.sum() > 50, "the wire beads are not in the picture"
    set_check(page, "layer-wire_beads", False)
    set_check(page, "layer-wire", False)
    img2 = settled(page, img)
    assert bluish(img2)[wire].mean() < 0.05, "the wire's pixels are still wire-coloured"
    changed = np.abs(img2.astype(int) - img.astype(int)).sum(axis=2) > 30
    assert changed[wire].mean() > 0.8
    # clip: keep x <= middle; in the front view +x is to the right, so only the right
    # part of the sample changes
    set_check(page, "layer-sand", True)
    full = settled(page, img2)
    choose(page, "clip-axis", "x")
    cut = settled(page, full)
    changed = np.abs(cut.astype(int) - full.astype(int)).sum(axis=2) > 30
    cols = np.flatnonzero(~np.all(full > 245, axis=2).all(axis=0))   # the sample's columns
    mid = 0.5 * (cols.min() + cols.max())
    xs = np.nonzero(changed)[1]
    assert xs.size > 100 and (xs > mid - 3).mean() > 0.95, "the clip changed the wrong side"
    slider_key(page, "clip-offset", "PageDown", 3)    # the plane moves to -x: more is cut
    cut2 = settled(page, cut)
    assert sandy(cut2).sum() < 0.9 * sandy(cut).sum()
    choose(page, "clip-axis", "none")


@needs_browser
def test_colour_limits_are_those_of_the_whole_run(page, history):
    choose(page, "color-by", "speed")
    page.get_by_role("radio", name="whole run").check()
    v = np.array([np.linalg.norm(s["velocity"][io.load_model(history).sphere_ids], axis=1).max()
                  for s in io.frame_arrays(history, ["velocity"])])
    shown = []
    for key in ("Home", "End"):
        slider_key(page, "frame-slider", key)
        wait_until(lambda: frame_of(page)[0] == (0 if key == "Home" else frame_of(page)[1] - 1))
        time.sleep(0.5)
        shown.append(text(page, "#clim-shown"))
    assert shown[0] == shown[1], shown
    m = re.search(r"speed \[(\S+)\] ([-\d.e]+) – ([-\d.e]+)", shown[0])
    assert m, shown[0]
    factor = {"m/s": 1.0, "mm/s": 1e3, "µm/s": 1e6}[m.group(1)]
    assert float(m.group(2)) == 0.0
    assert float(m.group(3)) == pytest.approx(v.max() * factor, rel=1e-3)
    page.get_by_role("radio", name="frame", exact=True).check()
    wait_until(lambda: "this frame" in text(page, "#clim-shown"), what="frame limits")


@needs_browser
def test_picking_a_bead_shows_its_id_and_values(page, history):
    set_check(page, "layer-sand", True)
    after(page, page.locator("#camera-top").click)   # (the last test's view may be front)
    after(page, page.locator("#camera-front").click)
    stale = text(page, "#picked").strip()
    box = page.locator("#view3d canvas").bounding_box()
    page.mouse.click(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
    lines = wait_until(lambda: text(page, "#picked").strip() not in ("", stale) and
                       text(page, "#picked").strip(), what="a pick")
    m = re.search(r"bead (\d+)", lines)
    assert m, lines
    b = int(m.group(1))
    model = io.load_model(history)
    k = frame_of(page)[0]
    st = io.read_frame(history, k, model)
    r = re.search(r"radius: ([\d.]+) (\S+)", lines)
    factor = {"m": 1.0, "mm": 1e3, "µm": 1e6}[r.group(2)]
    assert float(r.group(1)) == pytest.approx(model.body_radius[b] * factor, rel=1e-3)
    # the bead is the one under the pointer: in the front view (looking along +y), its
    # centre is near the middle of the sample's x-z extent
    lo, hi = st.position[model.sphere_ids].min(0), st.position[model.sphere_ids].max(0)
    c = st.position[b]
    assert abs(c[0] - 0.5 * (lo[0] + hi[0])) < 0.35 * (hi[0] - lo[0])


@needs_browser
def test_a_click_on_a_curve_moves_the_frame(page):
    slider_key(page, "frame-slider", "End")
    n = frame_of(page)[1]
    wait_until(lambda: frame_of(page)[0] == n - 1)
    plot = page.locator("#curves .js-plotly-plot .nsewdrag").first
    box = plot.bounding_box()
    page.mouse.move(box["x"] + box["width"] * 0.3, box["y"] + box["height"] * 0.5)
    page.mouse.click(box["x"] + box["width"] * 0.3, box["y"] + box["height"] * 0.5)
    k, = wait_until(lambda: (frame_of(page)[0],) if frame_of(page)[0] < n - 1 else None,
                    what="the frame to move after a click on a curve")
    assert 0 <= k < n - 1


@needs_browser
def test_screenshot_writes_the_view(page, history):
    """Each click writes a new file named by the frame the page shows (from 1): two views of
    one frame are two files (the second replaced the first)."""
    paths = []
    for _ in range(2):
        before = text(page, "#message")
        page.locator("#screenshot").click()
        msg = wait_until(lambda: text(page, "#message") if "wrote" in text(page, "#message")
                         and text(page, "#message") != before else None,
                         what="the screenshot")
        path = Path(msg.split("wrote ", 1)[1].strip())
        paths.append(path if path.is_absolute() else ROOT / path)
    shown = int(re.search(r"frame (\d+) / ", text(page, "#frame-info")).group(1))
    stem = Path(history).stem
    assert paths[0] != paths[1]
    for n, path in enumerate(paths):
        assert path.exists() and path.stat().st_size > 1000
        assert path.parent.parent == Path(history).parent
        assert path.parent.name.startswith("shots")
        m = re.fullmatch(rf"{re.escape(stem)}_f(\d{{4}})_(\d+)\.png", path.name)
        assert m and int(m.group(1)) == shown, (path.name, shown)
    assert int(re.search(r"_(\d+)\.png$", paths[1].name).group(1)) == \
        int(re.search(r"_(\d+)\.png$", paths[0].name).group(1)) + 1


@pytest.mark.slow
@needs_browser
def test_follow_shows_frames_of_a_run_being_written(browser, tmp_path):
    out = tmp_path / "live.h5"
    sim = subprocess.Popen([sys.executable, RUN, str(out), "--steps", "200", "--frames", "10",
                            "--pause", "0.6"], stdout=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        assert "frame" in sim.stdout.readline()          # the first frame is flushed
        p, url = start_view(out, "--follow")
        try:
            pg = browser.new_page(viewport={"width": 1400, "height": 900})
            pg.goto(url)
            pg.wait_for_selector("#view3d canvas", timeout=60000)
            wait_until(lambda: "step" in text(pg, "#frame-info"))
            n0 = frame_of(pg)[1]
            n1 = wait_until(lambda: frame_of(pg)[1] if frame_of(pg)[1] >= n0 + 2 else None,
                            timeout=60, what="frames appended by the run")
            assert frame_of(pg)[0] == n1 - 1 or frame_of(pg)[0] >= n0   # it follows the end
            assert "steps/s" in text(pg, "#progress") or "step" in text(pg, "#progress")
            sim.wait(timeout=120)                          # the run ends: it says so
            wait_until(lambda: "the run is over" in text(pg, "#progress"), timeout=60,
                       what="the progress saying the run is over")
            assert "steps/s" not in text(pg, "#progress")    # (it read "0 steps/s")
            pg.close()
        finally:
            assert stop(p) == 130
    finally:
        sim.kill()
        sim.wait()


# ---------------------------------------------------------------- bad input (no browser)
def test_bad_inputs_give_one_line_and_exit_2(tmp_path, history):
    (tmp_path / "empty").mkdir()
    (tmp_path / "notours.h5").write_text("hello")
    (tmp_path / "trunc.h5").write_bytes(Path(history).read_bytes()[:4000])
    import h5py

    with h5py.File(tmp_path / "foreign.h5", "w") as f:
        f["x"] = 1
    cases = {tmp_path / "missing.h5": "no such file",
             tmp_path / "empty": "no nscd-workbench run",
             tmp_path / "notours.h5": "not a readable HDF5 file",
             tmp_path / "trunc.h5": "truncated",
             tmp_path / "foreign.h5": "not an nscd-workbench file"}
    before = {p: p.read_bytes() for p in cases if p.is_file()}
    for path, words in cases.items():
        r = subprocess.run([NSCD, "view", str(path)], capture_output=True, text=True,
                           timeout=120, cwd=tmp_path)
        assert r.returncode == 2, (path, r.stderr)
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and words in lines[0], (path, r.stderr)
        assert "Traceback" not in r.stderr
    assert {p: p.read_bytes() for p in before} == before   # nothing changed in the input
    assert not list(tmp_path.glob("**/*.png"))


def test_port_in_use_and_non_loopback_host(tmp_path, history):
    import socket

    with socket.socket() as sk:
        sk.bind(("127.0.0.1", 0))
        sk.listen()
        port = sk.getsockname()[1]
        r = subprocess.run([NSCD, "view", str(history), "--port", str(port)],
                           capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert r.returncode == 2 and "in use" in r.stderr and len(r.stderr.splitlines()) == 1
    p, url = start_view(history, "--host", "0.0.0.0")
    try:
        time.sleep(0.5)
    finally:
        rc = stop(p)
    err = p.stderr.read()
    assert rc == 130 and "not a loopback address" in err


def test_a_folder_of_runs_is_listed(tmp_path, history):
    from workbench.view.source import find_runs

    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "one.h5").write_bytes(Path(history).read_bytes())
    (tmp_path / "two.h5").write_bytes(Path(history).read_bytes())
    (tmp_path / "junk.h5").write_text("not ours")
    runs = find_runs(tmp_path)
    assert [r.name for r in runs] == ["a/one.h5", "two.h5"]
    assert all(r.test == "follow_run" and r.status == "complete" for r in runs)
    assert runs[0].params == {"n_sand": 300}


@pytest.mark.slow
def test_notebook_viewer_cell_shows_the_app(tmp_path):
    """notebooks/explore.ipynb under nbclient: the viewer cell's output is the app (an iframe
    to its server), and that server answers while the kernel runs."""
    import urllib.request

    import nbclient
    import nbformat

    book = nbformat.read(ROOT / "notebooks" / "explore.ipynb", as_version=4)
    client = nbclient.NotebookClient(book, timeout=600, kernel_name="python3",
                                     resources={"metadata": {"path": str(tmp_path)}})
    served = []
    with client.setup_kernel():
        for i, cell in enumerate(book.cells):
            if cell.cell_type != "code":
                continue
            client.execute_cell(cell, i)
            for o in cell.get("outputs", []):
                html = o.get("data", {}).get("text/html", "")
                m = re.search(r'<iframe src="(http://127\.0\.0\.1:\d+/)"', html)
                if m:   # the server task starts listening once the cell has returned
                    def get(url=m.group(1)):
                        with urllib.request.urlopen(url, timeout=30) as r:
                            return r.status, b"<html" in r.read(2000).lower()
                    served.append(wait_until(get, timeout=60, what="the notebook's server"))
    errors = [o for c in book.cells if c.cell_type == "code" for o in c.get("outputs", [])
              if o.get("output_type") == "error"]
    assert not errors, errors
    assert served == [(200, True)]
    pngs = [o for c in book.cells for o in c.get("outputs", [])
            if "image/png" in o.get("data", {})]
    assert pngs, "the screenshot cell shows no picture"


@pytest.mark.slow
@needs_browser
def test_a_folder_lists_its_runs_and_names_stay_text(browser, tmp_path, history):
    import shutil

    (tmp_path / "a").mkdir()
    shutil.copy(history, tmp_path / "a" / "first.h5")
    odd = '<img id="x" src="q"> & <b>bold.h5'
    shutil.copy(history, tmp_path / odd)
    (tmp_path / "notes.h5").write_text("not a run")
    p, url = start_view(tmp_path)
    try:
        pg = browser.new_page(viewport={"width": 1400, "height": 900})
        pg.goto(url)
        pg.wait_for_selector("#view3d canvas", timeout=60000)
        wait_until(lambda: "step" in text(pg, "#frame-info"))
        bar = pg.locator("header")
        assert odd in bar.inner_text()                 # the first run, its name as text
        assert pg.locator("#x").count() == 0            # no element made from a name
        pg.locator("#run-select").locator(
            "xpath=ancestor::div[contains(@class, 'v-field ')][1]").click()
        items = pg.locator(".v-overlay-container .v-list-item-title")
        labels = [items.nth(i).inner_text() for i in range(items.count())]
        assert len(labels) == 2 and "follow_run" in labels[0] and "complete" in labels[0]
        items.filter(has_text="a/first.h5").first.click()
        wait_until(lambda: "first.h5" in bar.inner_text(), what="the second run")
        pg.close()
    finally:
        assert stop(p) == 130
