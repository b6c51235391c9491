"""The viewer's 3D scene: the layers of one frame in a PyVista plotter, and picking.

The layers are drawn from :mod:`workbench.meshes`' parts with the helpers, colours and
theme of :mod:`workbench.render` (so ``nscd view`` and ``nscd render`` show the same
beads, tubes and walls): sand beads and wire beads as point-Gaussian spheres at their true
radius (ghosted sand as translucent low-resolution spheres: VTK's point-Gaussian mapper
draws translucent impostors black), the wire's tension network and the strong force
network as tubes, the walls translucent, and, for a cylinder, the toroidal map of the wire
stress revolved about the axis (:func:`engine.analysis.toroidal_map`).

One field colours the scene at a time (:data:`workbench.view.source.FIELDS`): the layer
carrying it is drawn with a colour map and a colour bar in units chosen for reading
(:func:`workbench.units.reading_unit`), the others in their fixed colours.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import meshes, render
from ..units import reading_unit
from . import glyphs
from .source import FIELDS

__all__ = ["ViewOptions", "ViewScene", "LAYERS"]

#: Layers, in the order of the panel: name -> label.
LAYERS = {"sand": "sand beads", "wire_beads": "wire beads", "wire": "wire tension network",
          "forces": "force chains", "walls": "walls", "torus": "toroidal map (cylinder)"}

_FORCE_COLOR = "#4d4d4d"   # tubes of the strong network when another field colours the scene
_GHOST_OPACITY = 0.12


@dataclass
class ViewOptions:
    """What the scene shows (the viewer's state, in SI units)."""

    layers: dict = field(default_factory=lambda: {"sand": True, "wire_beads": True,
                                                  "wire": True, "forces": False,
                                                  "walls": True, "torus": False})
    color_by: str = "tension"
    clim: tuple | None = None           # (lo, hi) [SI] of the colour map; None: the frame's
    log: bool = False
    cmap: str = "plasma"
    clip_axis: str = "none"             # "none", "x", "y", "z"
    clip_offset: float = 0.5            # where the plane cuts, fraction of the box along the axis
    clip_flip: bool = False             # keep the other side
    clip_wire: bool = False             # cut the wire too (default: only sand and contacts)
    ghost: bool = False                 # sand translucent, so the wire shows
    strong: float = 1.0                 # strong network: fn > strong × mean fn
    weak: bool = False                  # the weak network as thin lines
    tension_max: float | None = None    # [N] tension of the thickest wire tube (None: frame's)
    force_max: float | None = None      # [N] normal force of the thickest contact tube


def _segment_ray(p0, p1, o, d):
    """For segments p0 -> p1 (k, 3) and the ray o + t d (|d| = 1): the distance of closest
    approach (k,) and the ray parameter t there (k,)."""
    u = p1 - p0
    w = p0 - o
    a = (u * u).sum(1)
    b = u @ d
    c = 1.0
    dd = w @ d
    e = (u * w).sum(1)
    den = a * c - b * b
    s = np.where(den > 1e-30, (b * dd - c * e) / np.where(den > 1e-30, den, 1.0), 0.0)
    s = np.clip(s, 0.0, 1.0)
    q = p0 + s[:, None] * u                    # closest point on each segment
    t = (q - o) @ d
    dist = np.linalg.norm(q - (o + t[:, None] * d), axis=1)
    return dist, t


class ViewScene:
    """The layers of a frame in an off-screen :class:`pyvista.Plotter` (``plotter``,
    whose render window the browser shows) with :func:`workbench.render.theme`."""

    def __init__(self, model, *, window_size=render.WINDOW_SIZE, plotter=None,
                 spheres: str = "gaussian"):
        render.headless_backend()
        import pyvista as pv

        if spheres == "points":                   # the name until 2026-12-03
            import warnings

            warnings.warn('ViewScene(spheres="points") is now spheres="glyphs" (spheres '
                          'of their radius in the browser)', DeprecationWarning, stacklevel=2)
            spheres = "glyphs"
        if spheres not in ("gaussian", "glyphs"):
            raise ValueError(f"spheres must be 'gaussian' or 'glyphs', got {spheres!r}")
        #: "gaussian": point-Gaussian impostors at the true radius (VTK); "glyphs": a
        #: sphere mesh glyphed at each bead, at its radius (what vtk.js can draw:
        #: ``--mode client``, :mod:`workbench.view.glyphs`)
        self.spheres = spheres
        self.model = model
        self.plotter = plotter if plotter is not None else pv.Plotter(
            off_screen=True, window_size=list(window_size), theme=render.theme())
        self.bounds = None
        self._drawn = {}          # what a pick can hit: layer -> arrays of the frame
        self.state = None
        self.bar = None           # (title, factor) of the colour bar shown
        #: the cylinder of the toroidal map: "wall" (the scene's cylinder), "sample" (a
        #: membrane test's sample: the cylinder its history recorded at the frame, as
        #: ``nscd render`` takes it, :func:`workbench.frames.frame_cylinder`, when
        #: ``history`` is set; else the vertical cylinder holding the spheres) or None
        self.cylinder = None
        #: the history file the frames come from (the run's recorded cylinder)
        self.history = None
        self._retired, self._on_show = set(), []          # (see retire)

    # ---------------------------------------------------------------- drawing
    def retire(self) -> None:
        """Keep every actor and colour bar on show alive after it leaves the scene, its
        data released (``spheres="glyphs"``, the browser's scene).  trame-vtk names the
        objects it sends to the page by their memory address: a frame's new actor, mapper
        or lookup table allocated where an old object of another type was made the page
        update the wrong kind of object (seen: "getLookupTable(...).setRange is not a
        function" during a followed run).  Kept, no address is reused; the cost is a few
        kB a frame change, until the layers are updated in place (docs/view.md)."""
        if self.spheres != "glyphs":
            return
        pl = self.plotter
        for obj in [*pl.renderer.actors.values(), *pl.scalar_bars.values()]:
            if obj not in self._retired:
                self._retired.add(obj)
                self._on_show.append(obj)
        shown = []
        for obj in self._on_show:               # released once out of the scene
            if pl.renderer.HasViewProp(obj):
                shown.append(obj)
            elif hasattr(obj, "GetMapper") and obj.GetMapper() is not None:
                obj.GetMapper().RemoveAllInputs()
        self._on_show = shown

    def _clear(self, *names):
        for n in names:
            self.plotter.remove_actor(n, render=False)

    def _bar(self, name, unit, lo, hi):
        factor, shown = reading_unit(unit, max(abs(lo), abs(hi)))
        title = f"{FIELDS[name][2]} [{shown}]" if shown != "-" else FIELDS[name][2]
        self.bar = (title, factor)
        return factor, render._bar(title, n_labels=5, fmt="%.3g")

    def _keep(self, points, opts: ViewOptions):
        """(n,) bool: points on the kept side of the clip plane (all without one)."""
        if opts.clip_axis not in ("x", "y", "z") or self.bounds is None:
            return np.ones(len(points), bool)
        a = "xyz".index(opts.clip_axis)
        lo, hi = self.bounds[0, a], self.bounds[1, a]
        cut = lo + float(opts.clip_offset) * (hi - lo)
        return points[:, a] >= cut if opts.clip_flip else points[:, a] <= cut

    def update(self, state, opts: ViewOptions, *, reset_camera: bool = False) -> None:
        """Draw ``state`` (a frame) with ``opts``; the camera is kept (set the first time,
        or with ``reset_camera``)."""
        pl = self.plotter
        model = self.model
        self.state = state
        first = self.bounds is None
        if first:
            self.bounds = meshes.scene_bounds(model, state, free_only=True)
        color_by = opts.color_by if opts.color_by in FIELDS else "kind"
        layer_of = FIELDS[color_by][0]
        self.bar = None
        self._drawn = {}
        self.retire()
        for title in list(pl.scalar_bars.keys()):
            pl.remove_scalar_bar(title, render=False)

        def limits(values):
            if opts.clim is not None:
                lo, hi = (float(x) for x in opts.clim)
            elif values.size:
                lo, hi = float(values.min()), float(values.max())
            else:
                lo, hi = 0.0, 1.0
            if not hi > lo:
                hi = lo + (abs(lo) or 1.0)
            if opts.log:
                hi = max(hi, 1e-300)
                lo = lo if lo > 0 else hi * 1e-3
            return lo, hi

        # -- beads
        bp = meshes.bead_part(model, state)
        kind = bp.point_data["kind"]
        keep = self._keep(bp.points, opts)
        self._clear("sand", "sand_ghost", "wire_beads")
        for name, mask in (("sand", kind != meshes.BEAD_WIRE),
                           ("wire_beads", kind == meshes.BEAD_WIRE)):
            if not opts.layers.get(name):
                continue
            sel = mask & (keep if (name == "sand" or opts.clip_wire) else True)
            part = render._select(bp, sel)
            if part.n_points == 0:
                continue
            self._drawn[name] = part
            kw = {}
            if layer_of == "beads" and color_by not in ("kind", "group"):
                v = part.point_data["speed"] if color_by == "speed" else \
                    np.linalg.norm(part.point_data["spin"], axis=1)
                lo, hi = limits(v)
                factor, bar = self._bar(color_by, FIELDS[color_by][1], lo, hi)
                part.point_data["value"] = v * factor
                kw = dict(scalars="value", cmap=opts.cmap, clim=(lo * factor, hi * factor),
                          log_scale=opts.log, show_scalar_bar=name == "sand" or
                          not opts.layers.get("sand"), scalar_bar_args=bar)
            elif color_by == "group":
                g = part.point_data["group"].astype(float)
                part.point_data["value"] = g
                ng = max(len(model.group_names), 2)
                kw = dict(scalars="value", cmap="tab10", clim=(-0.5, ng - 0.5), n_colors=ng,
                          show_scalar_bar=False)
            elif name == "sand":
                part.point_data["value"] = render.picture_kind(model, part).astype(float)
                kw = dict(scalars="value", cmap=[render.SAND_COLOR, render.WIRE_COLOR,
                                                 render.FIXED_COLOR],
                          clim=(-0.5, 2.5), n_colors=3, show_scalar_bar=False)
            else:
                kw = dict(color=render.WIRE_COLOR, show_scalar_bar=False)
            if name == "sand" and opts.ghost:
                self._ghost(part, kw)
            elif self.spheres == "glyphs":
                glyphs.sphere_actor(pl, part, name, **kw)
            else:
                render._spheres(pl, part, name, **kw)

        # -- wire network
        self._clear("wire_taut", "wire_slack", "wire_broken")
        wp = meshes.wire_part(model, state) if opts.layers.get("wire") else None
        if wp is not None:
            t = wp.cell_data["tension"]
            broken = wp.cell_data["broken"].astype(bool)
            mid = 0.5 * (wp.points[0::2] + wp.points[1::2])
            shown = self._keep(mid, opts) if opts.clip_wire else np.ones(len(t), bool)
            rb = model.body_radius[model.link_i] if model.n_links else np.zeros(0)
            rmax = float(rb.max()) if rb.size else 1e-4
            tmax = float(opts.tension_max) if opts.tension_max else float(max(t.max(), 0.0))
            taut = shown & ~broken & (t > 0.02 * tmax) if tmax > 0 else np.zeros(len(t), bool)
            rad = np.where(taut, rmax * np.sqrt(np.clip(t, 0, None) / (tmax or 1.0)), 0.0)
            rad = np.clip(rad, rmax / 8.0, rmax)
            self._drawn["wire"] = (wp, rad, shown)
            for mask, nm, kw in ((shown & ~taut & ~broken, "wire_slack",
                                  dict(color=render.SLACK_COLOR)),
                                 (shown & broken, "wire_broken", dict(color=render.BROKEN_COLOR))):
                self._lines(wp, t, rad, mask, 10, nm, show_scalar_bar=False, **kw)
            shown_field = color_by if layer_of == "wire" else None
            self._tubes(wp, "wire_taut", rad, taut, 10, shown_field,
                        wp.cell_data[shown_field] if shown_field else t, render.WIRE_COLOR,
                        opts, limits)

        # -- force chains
        self._clear("forces_strong", "forces_weak")
        cp = meshes.contact_part(model, state) if opts.layers.get("forces") else None
        if cp is not None and cp.n_cells:
            fn = cp.cell_data["normal_force"]
            mid = 0.5 * (cp.points[0::2] + cp.points[1::2])
            shown = self._keep(mid, opts)
            mean = float(fn.mean()) if fn.size else 0.0
            strong = shown & (fn > float(opts.strong) * mean)
            fmax = float(opts.force_max) if opts.force_max else float(fn.max())
            rmax = 0.5 * float(model.body_radius[model.sphere_ids].mean())
            rad = np.clip(rmax * fn / (fmax or 1.0), rmax / 10.0, rmax)
            self._drawn["forces"] = (cp, rad, strong)
            if opts.weak and np.any(shown & ~strong):
                idx = np.flatnonzero(shown & ~strong)
                lines = meshes.Part(points=cp.points.reshape(-1, 2, 3)[idx].reshape(-1, 3),
                                    cell_type="line", cells=np.arange(2 * idx.size).reshape(-1, 2))
                pl.add_mesh(lines.to_polydata(), color=render.WEAK_COLOR, line_width=1.0,
                            lighting=False, name="forces_weak", show_scalar_bar=False)
            shown_field = color_by if layer_of == "contacts" else None
            self._tubes(cp, "forces_strong", rad, strong, 8, shown_field,
                        cp.cell_data[shown_field] if shown_field else fn, _FORCE_COLOR,
                        opts, limits)

        # -- walls
        self._clear("walls")
        if opts.layers.get("walls"):
            render.add_walls(pl, model, state, opacity=0.12)

        # -- toroidal map
        self._clear("torus")
        if opts.layers.get("torus") and self.cylinder is not None and model.n_links:
            self._torus(state)

        if first or reset_camera:
            self.set_camera("iso")

    def _lines(self, part, values, rad, mask, n_sides, name, **kw):
        """The line cells of ``part`` where ``mask`` as tubes of radii ``rad`` [m] (a tube
        mesh of ``n_sides``, or glyphed cylinders with ``spheres="glyphs"``: a few
        floats a link for the browser, :mod:`workbench.view.glyphs`), carrying ``values`` as
        ``"value"``; ``kw``: :meth:`pyvista.Plotter.add_mesh`'s colour arguments."""
        if self.spheres == "glyphs":
            glyphs.stick_actor(self.plotter, part, values, rad, mask, name, **kw)
            return
        tubes = render._tube_lines(part, values, rad, mask, n_sides)
        if tubes is not None:
            self.plotter.add_mesh(tubes, name=name, smooth_shading=True, **kw)

    def _tubes(self, part, name, rad, mask, n_sides, field, values, color, opts, limits):
        """Tubes of ``part``'s lines where ``mask`` (radii ``rad`` [m]): coloured by
        ``values`` with a colour bar when ``field`` is the field shown, else in ``color``."""
        if field is None:
            self._lines(part, values, rad, mask, n_sides, name, color=color,
                        show_scalar_bar=False)
            return
        lo, hi = limits(values)
        factor, bar = self._bar(field, FIELDS[field][1], lo, hi)
        self._lines(part, values * factor, rad, mask, n_sides, name, scalars="value",
                    cmap=opts.cmap, clim=(lo * factor, hi * factor), log_scale=opts.log,
                    show_scalar_bar=True, scalar_bar_args=bar)

    def _ghost(self, part, kw):
        """Sand translucent: low-resolution polygon spheres (see module doc)."""
        import pyvista as pv

        mesh = part.to_polydata()
        mesh.point_data["diameter"] = 2.0 * part.point_data["radius"]
        ball = pv.Sphere(radius=0.5, theta_resolution=8, phi_resolution=6)
        balls = mesh.glyph(geom=ball, scale="diameter", orient=False, factor=1.0)
        kw = dict(kw)
        if "scalars" not in kw:
            kw.pop("show_scalar_bar", None)
        self.plotter.add_mesh(balls, name="sand_ghost", opacity=_GHOST_OPACITY,
                              smooth_shading=True, **kw)

    def _torus(self, state):
        from engine.analysis import toroidal_map

        try:
            if self.cylinder == "wall":
                cyl = render._cylinder_of(self.model, state)
            elif self.history is not None:        # the run's own cylinder, as nscd render's
                from ..frames import frame_cylinder

                cyl = frame_cylinder(self.history, model=self.model, state=state)
            else:
                cyl = meshes.sample_cylinder(self.model, state)
            tmap = toroidal_map(self.model, state, cyl, n_r=5, n_z=10, part="wire")
        except ValueError:
            return
        vals = np.asarray(tmap.equivalent, float)
        top = float(np.nanmax(vals)) if np.isfinite(vals).any() else 1.0
        factor, unit = reading_unit("Pa", top)
        title = f"wire eq. stress, torus [{unit}]"
        surf = render.revolved_map(vals * factor, tmap.r_edges, tmap.z_edges, cyl.center,
                                   title, sweep=270.0)
        bar = render._bar(title, vertical=False, position_x=0.05, position_y=0.04, width=0.4,
                          height=0.07, n_labels=3)
        bar["title"] = title          # horizontal: no lifting newline
        self.plotter.add_mesh(surf, scalars=title, cmap="viridis", name="torus",
                              clim=(0.0, top * factor if top > 0 else 1.0),
                              nan_color=render.NAN_COLOR, opacity=0.6, show_scalar_bar=True,
                              scalar_bar_args=bar)

    def set_camera(self, camera="iso") -> None:
        """A camera preset of :data:`workbench.render.CAMERAS`, framing the scene's first
        frame (``"reset"``: the iso preset)."""
        name = "iso" if camera == "reset" else camera
        render.set_camera(self.plotter, name, bounds=self.bounds)

    def screenshot(self, path) -> str:
        """The current view to PNG ``path`` (the same renderer and theme as
        :func:`workbench.render.snapshot`; the same view gives the same bytes)."""
        from pathlib import Path

        from engine.files import replacing

        p = Path(path)
        self.plotter.render()
        with replacing(p, "the screenshot could not be written") as tmp:
            self.plotter.screenshot(str(tmp), transparent_background=False)
        return str(p)

    # ---------------------------------------------------------------- picking
    def ray_at(self, x: float, y: float):
        """The ray (origin, unit direction) [m] through display pixel (x, y) (from the
        bottom left of the render window)."""
        ren = self.plotter.renderer
        pts = []
        for z in (0.0, 1.0):
            ren.SetDisplayPoint(float(x), float(y), z)
            ren.DisplayToWorld()
            w = np.array(ren.GetWorldPoint(), float)
            pts.append(w[:3] / (w[3] if w[3] else 1.0))
        return self.ray(pts[0], pts[1])

    @staticmethod
    def ray(p0, p1):
        p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
        d = p1 - p0
        n = float(np.linalg.norm(d))
        return p0, (d / n if n > 0 else np.array([0.0, 0.0, -1.0]))

    def pick(self, origin, direction) -> dict | None:
        """What the ray hits first among the layers drawn: ``{"what": "bead" | "link" |
        "contact", "id": ..., values...}`` in SI units, or None."""
        o, d = np.asarray(origin, float), np.asarray(direction, float)
        model, state = self.model, self.state
        if state is None:
            return None
        hits = []                              # (t along the ray, priority, result)
        r_sphere = float(model.body_radius[model.sphere_ids].max())
        for name in ("wire_beads", "sand"):
            part = self._drawn.get(name)
            if part is None:
                continue
            c, r = part.points, part.point_data["radius"]
            tc = (c - o) @ d
            d2 = ((c - o) ** 2).sum(1) - tc * tc
            ok = (d2 <= r * r) & (tc > 0)
            if ok.any():
                idx = np.flatnonzero(ok)
                th = tc[idx] - np.sqrt(np.maximum(r[idx] ** 2 - d2[idx], 0.0))
                q = idx[int(np.argmin(th))]
                ghosted = name == "sand" and self._ghosted
                hits.append((float(th.min()), 1 if ghosted else 0, ("bead", part, q)))
        for name in ("wire", "forces"):
            got = self._drawn.get(name)
            if got is None:
                continue
            part, rad, mask = got
            idx = np.flatnonzero(mask)
            if idx.size == 0:
                continue
            pts = part.points.reshape(-1, 2, 3)[idx]
            dist, t = _segment_ray(pts[:, 0], pts[:, 1], o, d)
            ok = (dist <= np.maximum(rad[idx], 0.1 * r_sphere)) & (t > 0)
            if ok.any():
                j = np.flatnonzero(ok)[int(np.argmin(t[ok]))]
                hits.append((float(t[j]) - float(rad[idx][j]), 0,
                             ("link" if name == "wire" else "contact", part, int(idx[j]))))
        if not hits:
            return None
        hits.sort(key=lambda h: (h[1], h[0]))
        what, part, q = hits[0][2]
        return self._describe(what, part, q)

    @property
    def _ghosted(self) -> bool:
        return self.plotter.actors.get("sand_ghost") is not None

    def _describe(self, what, part, q) -> dict:
        model = self.model
        if what == "bead":
            pd = part.point_data
            b = int(pd["body_id"][q])
            v = np.asarray(pd["velocity"][q], float)
            return {"what": "bead", "id": b,
                    "kind": "wire bead" if pd["kind"][q] == meshes.BEAD_WIRE else "sand",
                    "group": model.group_names[int(pd["group"][q])],
                    "radius [m]": float(pd["radius"][q]),
                    "position [m]": [float(x) for x in part.points[q]],
                    "velocity [m/s]": [float(x) for x in v],
                    "speed [m/s]": float(pd["speed"][q]),
                    "spin [rad/s]": float(np.linalg.norm(pd["spin"][q])),
                    "fixed": bool(model.body_dof[b] != 0)}
        cd = part.cell_data
        if what == "link":
            return {"what": "link", "id": int(cd["link_id"][q]),
                    "beads": [int(model.link_i[q]), int(model.link_j[q])],
                    "tension [N]": float(cd["tension"][q]), "strain [-]": float(cd["strain"][q]),
                    "length [m]": float(cd["length"][q]),
                    "ref_length [m]": float(cd["ref_length"][q]),
                    "broken": bool(cd["broken"][q])}
        kinds = ("sand-sand", "sand-wire", "wire-wire", "wall")
        return {"what": "contact", "id": int(q), "bodies": [int(cd["i"][q]), int(cd["j"][q])],
                "kind": kinds[int(cd["kind"][q])],
                "normal force [N]": float(cd["normal_force"][q]),
                "tangential force [N]": float(cd["tangential_force"][q])}

