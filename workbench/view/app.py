"""The trame application of ``nscd view`` (browser) and :func:`workbench.view.show`
(Jupyter).

The UI state is a small set of named values (``frame``, ``color_by``, ``clip_axis`` ...);
each change is handled by one callback that redraws the scene and updates the view
(DESIGN §6, trame).  The 3D view is either rendered in the browser by vtk.js
(``mode="client"``, the default: the faster at the paper's scale, docs/view.md; the beads
and links are sent as glyphs, :mod:`workbench.view.glyphs`) or on the server
(``mode="server"``: the very VTK pipeline of :mod:`workbench.render`, images streamed to
the browser).  The browser never sends a path: it picks a run by its index in the list
the server was given.
"""
from __future__ import annotations

import asyncio
from glob import escape as glob_escape
import os
import time
from pathlib import Path

import numpy as np

from .. import render
from ..units import reading_unit
from . import DEFAULT_MODE, MODES
from . import curves as _curves
from . import glyphs
from .scene import LAYERS, ViewOptions, ViewScene
from .source import FIELDS, RunSource, ViewInputError, curves_of, run_status

__all__ = ["Viewer", "MODES", "DEFAULT_MODE", "SPEEDS"]

#: The page's own scripts (the curves panel).
STATIC = Path(__file__).resolve().parent / "static"
#: Seconds between two tries to push a rendered image still being encoded (trame-vtk: 0.5).
STALE_RETRY_S = 0.02
#: ... and at most this many tries (2 s).
STALE_RETRIES = 100
#: A change first sends an image of this fraction of the view's size, at this JPEG quality,
LOD_RATIO, LOD_QUALITY = 0.6, 70
#: ... then the full one (this quality) this long after the last change [s], when a
#: full-size image takes more than LOD_ABOVE_S [s] to push (the paper's scale: about 0.2 s;
#: the demo's run: 0.05 s).
STILL_AFTER_S, STILL_QUALITY = 0.25, 92
LOD_ABOVE_S = 0.1
#: the ref of the client-side view in the page (trame.refs)
VIEW_REF = "nscd_view"
#: Frame states kept in memory (about 20 MB each at the paper's scale with contacts).
CACHED_FRAMES = 8
#: Play speeds [frames per second].
SPEEDS = (1, 2, 5, 10, 20)


def _fmt(v, unit):
    f, u = reading_unit(unit, v)
    return f"{v * f:.4g} {u}"


def _pretty(info: dict | None) -> list[str]:
    """The picked item as lines ``name: value`` with units chosen for reading."""
    if not info:
        return []
    out = [f"{info['what']} {info['id']}"]
    for k, v in info.items():
        if k in ("what", "id"):
            continue
        unit = k[k.find("[") + 1:-1] if k.endswith("]") else None
        name = k.split(" [")[0]
        if isinstance(v, list) and unit:
            f, u = reading_unit(unit, max(abs(float(x)) for x in v) if v else 0.0)
            out.append(f"{name}: (" + ", ".join(f"{x * f:.4g}" for x in v) + f") {u}")
        elif isinstance(v, float) and unit:
            out.append(f"{name}: {_fmt(v, unit)}")
        else:
            out.append(f"{name}: {v}")
    return out


class Viewer:
    """One viewer: a trame server showing a run (or a list of runs to choose from).

    Parameters
    ----------
    source : RunSource, optional
        The run shown first.
    runs : list of :class:`workbench.view.source.RunEntry`, optional
        A folder's runs, chosen in a list (the first is shown).
    follow : bool
        Poll the history every ``poll`` seconds for new frames and records (a run being
        written).
    mode : "client" (default, :data:`DEFAULT_MODE`) or "server"
    shots : folder of the screenshots (default ``out/view``)
    name : the trame server's name (several viewers in one process need their own)
    """

    def __init__(self, source: RunSource | None = None, runs=None, *, follow: bool = False,
                 mode: str = DEFAULT_MODE, shots="out/view", poll: float = 1.0,
                 name: str | None = None, window_size=(900, 600)):
        if mode not in MODES:
            raise ValueError(f"mode must be one of {', '.join(MODES)}, got {mode!r}")
        if source is None and not runs:
            raise ValueError("Viewer needs a source or a list of runs")
        from trame.app import get_server

        self.runs = list(runs or [])
        self.follow = bool(follow)
        self.mode = mode
        self.shots = Path(shots)
        self.poll = float(poll)
        self.window_size = tuple(int(v) for v in window_size)
        self.server = get_server(name or f"nscd_view_{id(self)}", client_type="vue3")
        self.state, self.ctrl = self.server.state, self.server.controller
        self.source = None
        self.scene = None
        self._states = {}                    # (frame, with contacts) -> State
        self._rate = []                      # (wall time, step) of the followed run
        self._tasks = []
        self._still = None                   # the pending full-size image (a timer handle)
        self._full_push_s = 0.0              # [s] the last full-size image push
        self._open(source if source is not None else self._source_of(0))
        self._build_ui()
        self.server.controller.on_server_ready.add(self._on_ready)

    # ---------------------------------------------------------------- the run shown
    def _source_of(self, k: int) -> RunSource:
        return RunSource(self.runs[k].path)

    def _open(self, source: RunSource) -> None:
        import pyvista as pv

        self.source = source
        if self.scene is None:
            render.headless_backend()
            pl = pv.Plotter(off_screen=True, window_size=list(self.window_size),
                            theme=render.theme())
            self.scene = ViewScene(source.model, plotter=pl,
                                   spheres="gaussian" if self.mode == "server" else "glyphs")
        else:
            self.scene.retire()
            self.scene.plotter.clear_actors()
            for title in list(self.scene.plotter.scalar_bars.keys()):
                self.scene.plotter.remove_scalar_bar(title, render=False)
            self.scene.model = source.model
            self.scene.bounds = None
        m = source.model
        test = source.meta.get("test", "")
        if (m.body_kind == 2).any():
            self.scene.cylinder = "wall"
        elif test == "cylinder_triaxial":
            self.scene.cylinder = "sample"
        else:
            self.scene.cylinder = None
        self.scene.history = (source.path if self.scene.cylinder == "sample"
                              and os.path.isfile(source.path) else None)
        self._states = {}
        self._curves = curves_of(source.records) if source.records is not None else None
        self._fig_sent = False                 # the curves panel has this run's curves
        self._rate = []

    def _needs_contacts(self) -> bool:
        s = self.state
        return bool(s.layer_forces) or FIELDS.get(s.color_by, ("",))[0] == "contacts"

    def _frame_state(self, k: int):
        """Frame ``k``'s State, read once (the last :data:`CACHED_FRAMES` are kept: going
        back and forth costs no reading); without its contacts unless a layer shows them."""
        key = (int(k), self._needs_contacts())
        cache = self._states
        if key not in cache and (int(k), True) in cache:
            key = (int(k), True)                       # a state with contacts serves too
        if key in cache:
            cache[key] = cache.pop(key)                # most recently used last
            return cache[key]
        cache[key] = self.source.state(k, contacts=key[1])
        while len(cache) > CACHED_FRAMES:
            cache.pop(next(iter(cache)))
        return cache[key]

    # ---------------------------------------------------------------- state -> scene
    def options(self) -> ViewOptions:
        s = self.state
        field = s.color_by if s.color_by in FIELDS else "kind"
        clim = None
        if field not in ("kind", "group"):
            if s.limits == "history":
                clim = self.source.field_range(field)
            elif s.limits == "manual":
                try:
                    f = float(s.clim_factor or 1.0)
                    lo, hi = float(s.clim_lo) / f, float(s.clim_hi) / f
                    clim = (lo, hi) if hi > lo else None
                except (TypeError, ValueError):
                    clim = None
        tmax = self.source.field_range("tension")[1] if s.limits != "frame" else None
        fmax = self.source.field_range("normal_force")[1] \
            if s.limits != "frame" and s.layer_forces else None
        return ViewOptions(
            layers={k: bool(s[f"layer_{k}"]) for k in LAYERS}, color_by=field, clim=clim,
            log=bool(s.log_scale), clip_axis=s.clip_axis, clip_offset=float(s.clip_offset),
            clip_flip=bool(s.clip_flip), clip_wire=bool(s.clip_wire), ghost=bool(s.ghost),
            strong=float(s.strong), weak=bool(s.weak), tension_max=tmax, force_max=fmax)

    def redraw(self, *, reset_camera: bool = False) -> None:
        """Draw the current frame with the current options and push the view."""
        t0 = time.perf_counter()
        s = self.state
        k = int(np.clip(int(s.frame or 0), 0, max(self.source.n_frames - 1, 0)))
        st = self._frame_state(k)
        opts = self.options()
        self.scene.update(st, opts, reset_camera=reset_camera)
        s.frame_info = self._frame_info(k, st)
        s.color_title = self.scene.bar[0] if self.scene.bar else ""
        if self.scene.bar and opts.clim is not None:
            f = self.scene.bar[1]
            s.clim_shown = f"{opts.clim[0] * f:.4g} – {opts.clim[1] * f:.4g}"
            s.clim_factor = f
        else:
            s.clim_shown = "this frame's" if self.scene.bar else ""
        s.shown_step = int(st.step)
        t1 = time.perf_counter()
        self._update_curves(k)
        t2 = time.perf_counter()
        self._push(fast=True)
        t3 = time.perf_counter()
        #: the last redraw's cost [ms]: scene, curves, image push (shown for benchmarks)
        s.redraw_ms = [round(1e3 * (t1 - t0), 1), round(1e3 * (t2 - t1), 1),
                       round(1e3 * (t3 - t2), 1)]

    def _frame_info(self, k, st) -> str:
        parts = [f"frame {k + 1} / {self.source.n_frames}", f"step {st.step}",
                 f"t = {st.time:.6g} s"]
        c = self._curves
        if c is not None and "_strain" in c and len(c["_step"]):
            j = int(np.argmin(np.abs(c["_step"] - st.step)))     # the record nearest
            if np.isfinite(c["_strain"][j]):
                parts += [f"axial strain {c['_strain'][j]:.4f}", f"q = {c['_q'][j]:.3g} kPa",
                          f"p = {c['_p'][j]:.3g} kPa"]
            else:
                parts.append("isotropic stage")
        return " · ".join(parts)

    def _update_curves(self, k) -> None:
        """The curves panel at frame ``k``: the figure when the curves changed since it was
        last sent (another run, new records of a followed run), else the frame's lines only
        (static/curves.js draws them)."""
        if self._curves is None or not self.state.show_curves:
            return
        args = (self._curves, self.source.frame_step, self.source.frame_time, k)
        if not self._fig_sent:
            self.state.curves_fig = _curves.figure(*args)
            self._fig_sent = True
        self.state.curves_marks = _curves.marks(*args)

    # ---------------------------------------------------------------- images
    def _push(self, fast: bool) -> None:
        """Send the view to the browser.  Server mode, once serving, when the last
        full-size image took more than :data:`LOD_ABOVE_S` to push: ``fast`` sends an
        image of :data:`LOD_RATIO` of the view's size at JPEG quality :data:`LOD_QUALITY`
        at once, then the full image :data:`STILL_AFTER_S` after the last change (as the
        view does while the mouse turns it): the image's cost follows its pixels, and it
        is most of a frame change at the paper's scale (docs/view.md).  Smaller scenes get
        the full image at once."""
        helper = getattr(getattr(self, "view", None), "_helper", None)
        live = self.mode == "server" and getattr(self.server, "protocol", None) is not None \
            and hasattr(helper, "set_image_quality")
        if not live:
            self.ctrl.view_update()
            return
        rw = self.scene.plotter.render_window
        if fast and self._full_push_s > LOD_ABOVE_S:
            helper.set_image_quality(rw, LOD_QUALITY, LOD_RATIO)
            self.ctrl.view_update()
            if self._still is not None:
                self._still.cancel()
            self._still = asyncio.get_event_loop().call_later(STILL_AFTER_S, self._push_still)
        else:
            if self._still is not None:
                self._still.cancel()
                self._still = None
            helper.set_image_quality(rw, STILL_QUALITY, 1.0)
            t0 = time.perf_counter()
            self.ctrl.view_update()
            self._full_push_s = time.perf_counter() - t0

    def _push_still(self) -> None:
        self._still = None
        self._push(fast=False)

    def _full_size(self) -> None:
        """The full image now, if a reduced one is on show (before a pick or a
        screenshot: both use the window's full size)."""
        if self._still is not None:
            self._still.cancel()
            self._push_still()

    # ---------------------------------------------------------------- actions
    def set_camera(self, name: str) -> None:
        self.scene.set_camera(name)
        js = getattr(self, "_camera_js", None)
        if self.mode == "client" and js is not None:
            # vtk.js applies a synchronised camera once only: a preset is set in the page
            # (the scene itself has not changed), and the lights follow it (static/view.js)
            c = self.scene.plotter.camera
            js.exec({"position": list(c.position), "focalPoint": list(c.focal_point),
                     "viewUp": list(c.up), "viewAngle": float(c.view_angle),
                     "parallelProjection": int(c.parallel_projection),
                     "parallelScale": float(c.parallel_scale)})
        else:
            self._push(fast=True)

    def client_camera(self, cam) -> None:
        """The browser's camera (``--mode client``, after a turn, pan or zoom with the
        mouse: vtk.js's ``getCamera()``) set on the server's, so that the screenshot
        button writes the view the user sees."""
        if not isinstance(cam, dict):
            return

        def vec(v):
            if isinstance(v, dict):                  # a typed array, as an object
                v = [v[k] for k in sorted(v, key=int)]
            out = [float(x) for x in v]
            if len(out) != 3 or not np.all(np.isfinite(out)):
                raise ValueError(f"not a finite 3-vector: {v!r}")
            return out

        try:
            c = self.scene.plotter.camera
            c.position, c.focal_point, c.up = (vec(cam[k]) for k in
                                               ("position", "focalPoint", "viewUp"))
            if "viewAngle" in cam:
                c.view_angle = float(cam["viewAngle"])
            if "parallelScale" in cam:
                c.parallel_scale = float(cam["parallelScale"])
            self.scene.plotter.renderer.ResetCameraClippingRange()
        except (KeyError, TypeError, ValueError):
            return

    def on_view_size(self, width, height) -> None:
        """The page's view size [px] (static/view.js): client mode renders its screenshots
        at it (server mode: the view sizes the server's window itself)."""
        if self.mode != "client":
            return
        try:
            w, h = int(width), int(height)
        except (TypeError, ValueError):
            return
        if 10 <= w <= 8192 and 10 <= h <= 8192:
            self.scene.plotter.window_size = [w, h]

    def screenshot(self) -> str:
        """The view to a new PNG in the shots folder, ``<run>_f<frame>_<n>.png``: the frame
        as the page numbers it (from 1), ``n`` the next free number for that frame, so a
        second view of one frame never replaces the first."""
        self._full_size()
        stem = f"{Path(self.source.path).stem}_f{int(self.state.frame) + 1:04d}_"
        taken = [p.stem[len(stem):] for p in self.shots.glob(f"{glob_escape(stem)}*.png")]
        n = 1 + max([int(t) for t in taken if t.isdigit()], default=0)
        out = self.scene.screenshot(self.shots / f"{stem}{n}.png")
        self.state.message = f"wrote {out}"
        return out

    def pick_ray(self, origin, direction) -> dict | None:
        info = self.scene.pick(origin, direction)
        self.state.picked = _pretty(info)
        self.state.picked_raw = info
        return info

    def on_click(self, event) -> None:
        """A click in the 3D view: a pick along the ray under the pointer."""
        if not isinstance(event, dict):
            return
        self._full_size()
        if event.get("ray"):                      # client view: two world points
            p0, p1 = event["ray"]
            self.pick_ray(*ViewScene.ray(p0, p1))
            return
        pos = event.get("position") or {}
        try:
            x, y = float(pos["x"]), float(pos["y"])
        except (KeyError, TypeError, ValueError):
            return
        self.pick_ray(*self.scene.ray_at(x, y))

    def on_curve_click(self, k) -> None:
        """A click on a curve: ``k`` is the clicked point's frame (its ``customdata``)."""
        try:
            k = int(k)
        except (TypeError, ValueError):
            return
        self.state.frame = int(np.clip(k, 0, self.source.n_frames - 1))

    def choose_run(self, k) -> None:
        try:
            k = int(k)
            src = self._source_of(k)
        except (ValueError, TypeError, IndexError, ViewInputError, OSError) as e:
            self.state.message = f"cannot show this run: {e}"
            return
        self._open(src)
        s = self.state
        s.n_frames = src.n_frames
        s.run_title = src.name
        s.has_curves = self._curves is not None
        s.frame = src.n_frames - 1
        self.redraw(reset_camera=True)

    # ---------------------------------------------------------------- time
    async def _play(self):
        while True:
            await asyncio.sleep(1.0 / max(float(self.state.speed or 5), 0.1))
            if not self.state.playing:
                continue
            with self.state:
                n = self.source.n_frames
                self.state.frame = (int(self.state.frame) + 1) % max(n, 1)

    async def _follow(self):
        while True:
            await asyncio.sleep(self.poll)
            try:
                self.follow_once()
            except Exception as e:           # a read between two writes: try again
                self.state.message = f"follow: {type(e).__name__}: {e}"

    def follow_once(self) -> bool:
        """Read the history again; new frames and curve points are shown (the view moves
        to the newest frame when it was showing the last one).  True when something was new."""
        src = self.source
        was_last = int(self.state.frame) >= src.n_frames - 1
        new = src.refresh()
        with self.state:
            self._progress()
            if not new:
                return False
            self._curves = curves_of(src.records)
            self._fig_sent = False
            self.state.n_frames = src.n_frames
            if was_last and int(self.state.frame) != src.n_frames - 1:
                self.state.frame = src.n_frames - 1   # redraws (curves included) on change
            else:
                self._update_curves(int(self.state.frame))
        return True

    def _progress(self) -> None:
        src = self.source
        if src.records is None or not src.records.n_records:
            return
        step = int(src.records.step[-1])
        now = time.time()
        self._rate = [(t, s) for t, s in self._rate if now - t < 30] + [(now, step)]
        total = src.meta.get("total_steps")
        rate = ((self._rate[-1][1] - self._rate[0][1]) / (self._rate[-1][0] - self._rate[0][0])
                if len(self._rate) > 1 and self._rate[-1][0] > self._rate[0][0] else None)
        txt = f"step {step}" + (f" of at most {total}" if total else "")
        if self.follow and run_status(src.path) == "complete":
            txt += " · the run is over"          # (its rate fell to "0 steps/s")
        elif rate:
            txt += f" · {rate:.3g} steps/s"
        self.state.progress = txt

    def _on_ready(self, **_):
        self._fast_images()
        loop = asyncio.get_event_loop()
        self._tasks.append(loop.create_task(self._play()))
        if self.follow:
            self._tasks.append(loop.create_task(self._follow()))

    def _fast_images(self) -> None:
        """VTK's web image delivery encodes JPEGs on a thread: a push that finds the new
        image still being encoded sends the previous one and tries again after
        ``delta_stale_time_before_render`` (0.5 s in trame-vtk 2.11), so every frame change
        showed the previous frame for half a second (measured: 0.8 s from the key press to
        the new picture for the demo's run, bench/bench_view.py).  Here the retry comes
        every :data:`STALE_RETRY_S` until the new image is out (at most
        :data:`STALE_RETRIES` times; trame-vtk's own chain of retries stops after one short
        retry).  Only attributes of trame-vtk's protocol are set; without them (another
        trame-vtk), its own behaviour stays."""
        proto = getattr(self.server, "protocol", None)
        links = getattr(proto, "getLinkProtocols", lambda: [])() if proto else []
        for p in links:
            if not all(hasattr(p, a) for a in ("delta_stale_time_before_render", "push_render",
                                                "stale_handler_count", "last_stale_time")):
                continue

            def retry(v_id, stale_count=0, p=p):
                if p.stale_handler_count.get(v_id, 0) > 0:
                    p.stale_handler_count[v_id] -= 1
                    if p.last_stale_time.get(v_id, 0) != 0 and stale_count < STALE_RETRIES:
                        p.push_render(v_id, False, stale_count + 1)

            p.delta_stale_time_before_render = STALE_RETRY_S
            p.render_stale_image = retry

    # ---------------------------------------------------------------- UI
    def _build_ui(self) -> None:
        from trame.ui.vuetify3 import SinglePageWithDrawerLayout
        from trame.widgets import client, html
        from trame.widgets import vtk as vtkw
        from trame.widgets import vuetify3 as v3

        s, ctrl = self.state, self.ctrl
        src = self.source
        s.update(dict(
            frame=src.n_frames - 1, n_frames=src.n_frames, playing=False, speed=5,
            frame_info="", shown_step=-1, color_by="tension" if src.model.n_links else "speed",
            limits="history", clim_lo=0.0, clim_hi=1.0, clim_factor=1.0, clim_shown="",
            color_title="", log_scale=False, clip_axis="none", clip_offset=0.5,
            clip_flip=False, clip_wire=False, ghost=False, strong=1.0, weak=False,
            picked=[], picked_raw=None, message="", progress="", run_index=0,
            redraw_ms=[0, 0, 0], curves_fig=None, curves_marks=[],
            run_title=src.name, show_curves=True, has_curves=self._curves is not None,
            follow=self.follow,
            runs=[{"title": r.label(), "value": i} for i, r in enumerate(self.runs)],
            fields=[{"title": FIELDS[k][2] + (f" [{FIELDS[k][1]}]" if FIELDS[k][1] != "-"
                                               else ""), "value": k} for k in FIELDS],
            speeds=[{"title": f"{v} frames/s", "value": v} for v in SPEEDS],
        ))
        for k in LAYERS:
            s[f"layer_{k}"] = k in ("sand", "wire_beads", "wire", "walls")
        s.trame__title = "nscd view"

        watched = ["frame", "color_by", "limits", "clim_lo", "clim_hi", "log_scale",
                   "clip_axis", "clip_offset", "clip_flip", "clip_wire", "ghost", "strong",
                   "weak", *[f"layer_{k}" for k in LAYERS]]

        @s.change("color_by")
        def _field(color_by, **_):
            # choosing a field shows the layer that carries it
            part = FIELDS.get(color_by, ("beads",))[0]
            if part == "beads" and not (s.layer_sand or s.layer_wire_beads):
                s.layer_sand = True
            elif part in ("wire", "contacts"):
                s[f"layer_{'wire' if part == 'wire' else 'forces'}"] = True

        @s.change(*watched)
        def _changed(**_):
            self.redraw()

        @s.change("show_curves")
        def _curves_shown(show_curves, **_):
            if show_curves:
                self._update_curves(int(s.frame))

        @s.change("run_index")
        def _run(run_index, **_):
            if self.runs and int(run_index) != getattr(self, "_shown_run", 0):
                self._shown_run = int(run_index)
                self.choose_run(run_index)

        ctrl.camera = self.set_camera
        ctrl.client_camera = self.client_camera
        ctrl.screenshot = self.screenshot
        ctrl.on_click = self.on_click
        self.server.trigger("curve_click")(self.on_curve_click)
        self.server.trigger("view_size")(self.on_view_size)
        # the curves panel's script, and plotly.js which it loads on demand (the plotly
        # package's own copy, found without importing the package)
        import importlib.util

        plotly_js = Path(importlib.util.find_spec("plotly").origin).parent / "package_data"
        self.server.enable_module({
            "serve": {"__nscd_view": str(STATIC), "__nscd_plotly": str(plotly_js)},
            "scripts": ["__nscd_view/curves.js", "__nscd_view/view.js"]})

        def step_by(d):
            s.frame = int(np.clip(int(s.frame) + d, 0, self.source.n_frames - 1))

        with SinglePageWithDrawerLayout(self.server, width=330) as layout:
            self.layout = layout
            layout.title.set_text("nscd view")
            with layout.toolbar:
                v3.VToolbarTitle("{{ run_title }}", classes="text-body-1 ml-2",
                                 style="max-width: 30%")
                if self.runs:
                    v3.VSelect(v_model=("run_index", 0), items=("runs",), density="compact",
                               hide_details=True, label="run", style="max-width: 40%",
                               id="run-select")
                v3.VSpacer()
                for name in render.CAMERAS:
                    v3.VBtn(name, click=(ctrl.camera, f"['{name}']"), variant="text",
                            size="small", id=f"camera-{name}")
                v3.VBtn("reset", click=(ctrl.camera, "['reset']"), variant="text",
                        size="small", id="camera-reset")
                v3.VBtn("screenshot", click=ctrl.screenshot, variant="tonal", size="small",
                        prepend_icon="mdi-camera", id="screenshot", classes="ml-2")
            with layout.drawer as drawer:
                drawer.width = 330
                with v3.VContainer(classes="pa-2", style="font-size: 13px"):
                    html.Div("Time", classes="text-subtitle-2")
                    v3.VSlider(v_model=("frame",), min=0, max=("n_frames - 1",), step=1,
                               hide_details=True, density="compact", id="frame-slider")
                    with html.Div(classes="d-flex align-center"):
                        v3.VBtn(icon="mdi-skip-previous", size="small", variant="text",
                                click=lambda: step_by(-1), id="prev")
                        v3.VBtn(icon=("playing ? 'mdi-pause' : 'mdi-play'",), size="small",
                                variant="text", click="playing = !playing", id="play")
                        v3.VBtn(icon="mdi-skip-next", size="small", variant="text",
                                click=lambda: step_by(1), id="next")
                        v3.VSelect(v_model=("speed",), items=("speeds",), density="compact",
                                   hide_details=True, style="max-width: 140px", id="speed")
                    html.Div("{{ frame_info }}", id="frame-info", classes="text-caption")
                    html.Div("{{ progress }}", v_show="follow", id="progress",
                             classes="text-caption text-primary")
                    v3.VDivider(classes="my-2")
                    html.Div("Layers", classes="text-subtitle-2")
                    for k, label in LAYERS.items():
                        v3.VCheckbox(v_model=(f"layer_{k}",), label=label, density="compact",
                                     hide_details=True, id=f"layer-{k}")
                    v3.VCheckbox(v_model=("show_curves",), label="curves panel",
                                 density="compact", hide_details=True, id="show-curves",
                                 v_show="has_curves")
                    v3.VDivider(classes="my-2")
                    html.Div("Colour", classes="text-subtitle-2")
                    v3.VSelect(v_model=("color_by",), items=("fields",), density="compact",
                               hide_details=True, label="colour by", id="color-by")
                    with v3.VRadioGroup(v_model=("limits",), inline=True, density="compact",
                                        hide_details=True, id="limits-group"):
                        v3.VRadio(label="whole run", value="history")
                        v3.VRadio(label="frame", value="frame")
                        v3.VRadio(label="manual", value="manual")
                    with html.Div(v_if="limits == 'manual'", classes="d-flex"):
                        v3.VTextField(v_model=("clim_lo",), label="min", density="compact",
                                      hide_details=True, type="number", id="clim-lo")
                        v3.VTextField(v_model=("clim_hi",), label="max", density="compact",
                                      hide_details=True, type="number", id="clim-hi")
                    html.Div("{{ color_title }} {{ clim_shown }}", id="clim-shown",
                             classes="text-caption")
                    v3.VCheckbox(v_model=("log_scale",), label="log scale", density="compact",
                                 hide_details=True, id="log-scale")
                    v3.VDivider(classes="my-2")
                    html.Div("Look inside", classes="text-subtitle-2")
                    v3.VSelect(v_model=("clip_axis",), items=("['none', 'x', 'y', 'z']",),
                               label="clip plane normal", density="compact", hide_details=True,
                               id="clip-axis")
                    v3.VSlider(v_model=("clip_offset",), min=0, max=1, step=0.01,
                               label="offset", hide_details=True, density="compact",
                               disabled=("clip_axis == 'none'",), id="clip-offset")
                    with html.Div(classes="d-flex"):
                        v3.VCheckbox(v_model=("clip_flip",), label="flip", density="compact",
                                     hide_details=True, id="clip-flip")
                        v3.VCheckbox(v_model=("clip_wire",), label="cut the wire too",
                                     density="compact", hide_details=True, id="clip-wire")
                    v3.VCheckbox(v_model=("ghost",), label="sand ghosted", density="compact",
                                 hide_details=True, id="ghost")
                    v3.VSlider(v_model=("strong",), min=0, max=3, step=0.05,
                               label="strong > × mean fn", hide_details=True,
                               density="compact", thumb_label=True, id="strong")
                    v3.VCheckbox(v_model=("weak",), label="weak network", density="compact",
                                 hide_details=True, id="weak")
                    v3.VDivider(classes="my-2")
                    html.Div("Picked", classes="text-subtitle-2")
                    with html.Div(id="picked", classes="text-caption"):
                        html.Div("{{ line }}", v_for="line in picked", key="line")
                    html.Div("{{ message }}", id="message", classes="text-caption text-grey")
                    html.Div("redraw {{ redraw_ms[0] }} + curves {{ redraw_ms[1] }} + image "
                             "{{ redraw_ms[2] }} ms", id="redraw-ms",
                             classes="text-caption text-grey", style="font-size: 10px")
            with layout.content:
                with html.Div(style="display: flex; flex-direction: column; height: "
                                    "calc(100vh - 64px);"):
                    with html.Div(style="flex: 1 1 65%; min-height: 200px; position: relative;",
                                  id="view3d"):
                        view_kw = dict(picking_modes=("['click']",),
                                       click=(ctrl.on_click, "[$event]"))
                        if self.mode == "server":
                            view = vtkw.VtkRemoteView(self.scene.plotter.render_window,
                                                      interactive_ratio=1, still_quality=92,
                                                      interactive_quality=70, **view_kw)
                        else:
                            # our serializers, put back before the view's first scene
                            # (trame-vtk sets its own when its protocol starts)
                            self.server.controller.on_server_ready.add(
                                lambda **_: glyphs.register())
                            # the browser's camera, once the mouse has let it go, becomes
                            # the server's (screenshots and presets start from it)
                            view = vtkw.VtkLocalView(
                                self.scene.plotter.render_window, ref=VIEW_REF,
                                interactor_events=("['EndAnimation']",),
                                EndAnimation=(ctrl.client_camera,
                                              f"[trame.refs['{VIEW_REF}'].getCamera()]"),
                                after_scene_loaded=f"window.nscdView.followLights('{VIEW_REF}')",
                                **view_kw)
                            self._camera_js = client.JSEval(
                                exec=f"window.nscdView.setCamera('{VIEW_REF}', $event)")
                        ctrl.view_update = view.update
                        self.view = view
                    with html.Div(v_show="has_curves && show_curves",
                                  style="flex: 0 0 300px; border-top: 1px solid #ddd;",
                                  id="curves"):
                        html.Div(id="curves-plot", style="width: 100%; height: 300px;")
                        client.ClientStateChange(
                            value="curves_fig", trigger_on_create=True,
                            change="window.nscdCurves.show('curves-plot', curves_fig, "
                                   "curves_marks, k => trigger('curve_click', [k]))")
                        client.ClientStateChange(
                            value="curves_marks",
                            change="window.nscdCurves.mark('curves-plot', curves_marks)")
                        client.ClientStateChange(
                            value="show_curves",
                            change="window.nscdCurves.resize('curves-plot')")
        # first picture
        self.redraw(reset_camera=True)

    # ---------------------------------------------------------------- serving
    def start(self, *, host: str = "127.0.0.1", port: int = 0, **kw):
        """Serve (blocking) until stopped."""
        return self.server.start(host=host, port=port, open_browser=False,
                                 show_connection_info=False, disable_logging=True, timeout=0,
                                 **kw)

    def stop(self) -> None:
        for t in self._tasks:
            t.cancel()
        try:
            self.scene.plotter.close()
        except Exception:
            pass


def free_port(host: str = "127.0.0.1") -> int:
    import socket

    with socket.socket() as sk:
        sk.bind((host, 0))
        return int(sk.getsockname()[1])


def port_free(host: str, port: int) -> bool:
    import socket

    with socket.socket() as sk:
        sk.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            sk.bind((host, port))
        except OSError:
            return False
    return True

