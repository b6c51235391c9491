"""Off-screen PyVista pictures of a state: beads, wire tension network, force chains,
toroidal stress map.

::

    from workbench.render import snapshot
    snapshot(model, state, "out/beads.png")                          # preset "beads", camera "iso"
    snapshot(model, state, "out/wire.png", preset="wire", camera="front")
    snapshot(model, state, "out/forces.png", preset="forces", strong="mean")
    snapshot(model, state, "out/torus.png", preset="torus", part="wire", n_r=5, n_z=10)

Presets (``preset=``; ``**options`` listed with each builder)

``beads``  (:func:`add_beads`)
    Every sphere at its radius, sand and wire beads coloured by kind (a legend box
    "sand" / "wire"), walls translucent.
``wire``  (:func:`add_wire`)
    The wire's tension network: each link a tube whose radius and colour grow with its
    tension [N]; slack links (tension <= ``slack`` × max) thin and grey; broken links
    red and thin; walls translucent.
``forces``  (:func:`add_forces`)
    Force chains: the strong network (fn > ``strong`` × mean fn, the usual split at the
    mean force), one tube per contact (centre to centre, or centre to the wall point) of
    radius proportional to the normal force [N] and coloured by it over a bar from 0;
    ``weak=True`` adds the weak network as thin light-grey lines.
``torus``  (:func:`add_torus`)
    Toroidal map (paper Fig. 13c; :func:`engine.analysis.toroidal_map`): left, the
    axial section of the cylinder (the (r, z) map mirrored about the axis) as an image of
    the equivalent stress [Pa] per torus cell (grey = empty cell), with axes in mm; right,
    the same map revolved about the cylinder axis over ``sweep`` degrees (cut open, so the
    inside shows), unlit so that its colours are the bar's; one horizontal colour bar
    under both.  The cylinder: ``cylinder=``, else the scene's cylinder wall, else a
    ValueError (a box sample, a deposit); from a history, :mod:`workbench.frames` passes
    a ``cylinder_triaxial`` run's own cylinder at that frame
    (:func:`workbench.frames.frame_cylinder`).

Every picture has a title, by default ``step 913 · t = 45.65 ms`` (:func:`default_title`;
a history frame also says the axial strain of a triaxial test:
:func:`workbench.frames.frame_title`), and ``axes=True`` adds the bounds of the framed box
with ticks in mm (units for reading).

Sizes: font sizes and line widths are given for the default 800 x 600 window and scale
with the window's smaller side (:func:`ui_scale`: min(w, h) / 600; fonts never below
:data:`MIN_FONT` px), so a 1600 x 1200 picture reads as the 800 x 600 one and a
400 x 300 one keeps its colour-bar titles inside the window.

Determinism: one fixed theme (:func:`theme`: white background, Arial, font sizes fixed for
a window size, no multi-sampling), a fixed window size, cameras computed from the scene
bounds only (:data:`CAMERAS`), no random colours.  The same input gives the same pixels on
the same GL stack (checked by ``tests/workbench/test_render.py``).

Headless: the plotter is always off-screen.  VTK >= 9.4 wheels pick a GL back end at
run time; with no ``DISPLAY`` we ask for EGL (Mesa's llvmpipe software rasteriser when
there is no GPU: Debian packages ``libegl1`` + ``libegl-mesa0`` + ``libgl1-mesa-dri``),
or OSMesa (``libosmesa6``) when EGL is missing, through ``VTK_DEFAULT_OPENGL_WINDOW``
unless the caller has set it (:func:`headless_backend`); this also saves VTK a failed
attempt at an X connection.  ``make install`` installs these packages with apt when
missing.  No X server, no xvfb.

Only this module and :mod:`workbench.meshes`' PyVista wrappers import PyVista (lazily).
"""
from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import numpy as np

from . import meshes
from .units import reading_unit

__all__ = ["PRESETS", "CAMERAS", "snapshot", "plotter", "theme", "set_camera", "add_beads",
           "add_wire", "add_forces", "add_torus", "add_walls", "headless_backend", "revolved_map",
           "picture_kind", "value_range", "ui_scale", "font_px", "default_title", "time_text",
           "add_axes", "nice_ticks", "scene_summary", "wall_cylinder", "no_cylinder_error",
           "FONT_SIZES", "MIN_FONT", "TORUS_LAYOUT"]

PRESETS = ("beads", "wire", "forces", "torus")

#: Camera presets: (direction from the focal point to the camera, view-up vector).
CAMERAS = {
    "iso": ((1.0, -1.6, 1.0), (0.0, 0.0, 1.0)),
    "front": ((0.0, -1.0, 0.0), (0.0, 0.0, 1.0)),
    "side": ((1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
    "top": ((0.0, 0.0, 1.0), (0.0, 1.0, 0.0)),
}

#: Default window size [px] (width, height).
WINDOW_SIZE = (800, 600)

#: The smaller window side [px] at which :data:`FONT_SIZES` and line widths are as given
#: (the default window); other windows scale them by min(w, h) / this (:func:`ui_scale`).
REFERENCE_SIDE = 600

#: Font sizes [px] in the default window: the picture's title, a colour bar's title and
#: labels, a panel's title (the torus preset's), axis titles and tick labels.
FONT_SIZES = dict(title=16, bar_title=14, bar_label=12, panel=15, axis_title=13, axis_label=12)

#: No font is drawn smaller than this [px] (a 400 x 300 picture stays legible).
MIN_FONT = 8

#: The torus preset's window: two panels (axial section | revolved view) over one strip
#: holding the colour bar and the title (keywords of :class:`pyvista.Plotter`).
TORUS_LAYOUT = dict(shape=(2, 2), groups=[(1, slice(None))], row_weights=[0.78, 0.22])

# colours (fixed; named so that pictures and legends agree)
SAND_COLOR = "#d9b36c"
WIRE_COLOR = "#1f4e9c"
FIXED_COLOR = "#9a9a9a"   # fixed spheres (the slope's rubber floor)
FIXED_KIND = 2            # their ``kind`` in the beads picture only (meshes: sand or wire)
WALL_COLOR = "#9aa5b1"
SLACK_COLOR = "#b0b0b0"
BROKEN_COLOR = "#d62728"
WEAK_COLOR = "#c8c8c8"
NAN_COLOR = "#e6e6e6"


def _loadable(name: str) -> bool:
    import ctypes

    try:
        ctypes.CDLL(name)
    except OSError:
        return False
    return True


def headless_backend() -> str | None:
    """Choose VTK's off-screen GL window when there is no display (see module doc).

    When neither ``DISPLAY``, ``WAYLAND_DISPLAY`` nor ``VTK_DEFAULT_OPENGL_WINDOW`` is set,
    sets the latter to ``vtkEGLRenderWindow`` if ``libEGL.so.1`` loads, else to
    ``vtkOSOpenGLRenderWindow`` if ``libOSMesa.so.8`` loads (both give the same pixels
    with Mesa's llvmpipe); returns the variable's value.  Call before the first render
    window is made (:func:`plotter` does).
    """
    key = "VTK_DEFAULT_OPENGL_WINDOW"
    if key not in os.environ and not os.environ.get("DISPLAY") \
            and not os.environ.get("WAYLAND_DISPLAY"):
        if _loadable("libEGL.so.1"):
            os.environ[key] = "vtkEGLRenderWindow"
        elif _loadable("libOSMesa.so.8"):
            os.environ[key] = "vtkOSOpenGLRenderWindow"
    return os.environ.get(key)


def ui_scale(window_size) -> float:
    """The factor of font sizes and line widths in a window of ``window_size`` (w, h) [px]:
    min(w, h) / :data:`REFERENCE_SIDE` (1 for the default 800 x 600, 2 for 1600 x 1200)."""
    w, h = (int(v) for v in window_size)
    return min(w, h) / REFERENCE_SIDE


def font_px(size, scale: float = 1.0) -> int:
    """A font size [px]: ``size`` (px in the default window, or a key of
    :data:`FONT_SIZES`) × ``scale``, rounded, at least :data:`MIN_FONT`."""
    base = FONT_SIZES[size] if isinstance(size, str) else float(size)
    return max(MIN_FONT, int(round(base * float(scale))))


def _line_px(width: float, scale: float) -> float:
    """A line width [px]: ``width`` (px in the default window) × ``scale``, at least 1."""
    return max(1.0, float(width) * float(scale))


def _scale_of(pl) -> float:
    return ui_scale(pl.window_size)


def theme(scale: float = 1.0):
    """The fixed :class:`pyvista.themes.Theme` of every picture (a fresh copy); ``scale``
    (:func:`ui_scale`) multiplies its font sizes."""
    import pyvista as pv

    t = pv.themes.DocumentTheme()
    t.background = "white"
    t.window_size = list(WINDOW_SIZE)
    t.font.family = "arial"
    t.font.color = "black"
    t.font.size = font_px(14, scale)
    t.font.title_size = font_px("bar_title", scale)
    t.font.label_size = font_px("bar_label", scale)
    t.font.fmt = "%.3g"
    t.multi_samples = 0
    t.anti_aliasing = None
    t.smooth_shading = False  # True breaks point-Gaussian colours (PyVista 0.49); tubes ask for it
    t.show_scalar_bar = False
    t.colorbar_orientation = "vertical"
    t.colorbar_vertical.position_x = 0.86
    t.colorbar_vertical.position_y = 0.1
    t.colorbar_vertical.width = 0.06
    t.colorbar_vertical.height = 0.8
    t.cmap = "viridis"
    t.nan_color = NAN_COLOR
    return t


def _bar(title: str, scale: float = 1.0, window_size=WINDOW_SIZE, **kw) -> dict:
    """``scalar_bar_args`` of a vertical colour bar at the right of the picture, its fonts
    and its width scaled by ``scale`` and placed from the right edge of a window of
    ``window_size`` [px] so that its title and labels stay inside (``kw`` overrides)."""
    w = float(window_size[0])
    width = min(0.06 * 800 * scale / w, 0.2)              # 48 px at 800 x 600
    right = min(0.08 * 800 * scale / w, 0.25)             # room for the title's right half
    # the trailing newline lifts the title off the top label (they touched)
    args = dict(title=title + "\n", vertical=True, n_labels=5, fmt="%.3g", color="black",
                font_family="arial", title_font_size=font_px("bar_title", scale),
                label_font_size=font_px("bar_label", scale),
                position_x=1.0 - width - right, position_y=0.1, width=width, height=0.8)
    args.update(kw)
    return args


def _pl_bar(pl, title: str, **kw) -> dict:
    """:func:`_bar` for the window of plotter ``pl``."""
    return _bar(title, _scale_of(pl), pl.window_size, **kw)


def set_camera(pl, camera="iso", bounds=None, zoom: float = 1.0) -> None:
    """Place the camera of plotter ``pl``.

    ``camera`` is a preset name of :data:`CAMERAS` (looking at the centre of ``bounds``,
    a (2, 3) array [m], or of the plotter's props, then fitted to them), or an explicit
    ``(position, focal_point, view_up)`` triple [m].
    """
    if isinstance(camera, str):
        if camera not in CAMERAS:
            raise ValueError(f"unknown camera {camera!r}; presets are {sorted(CAMERAS)}")
        direction, up = (np.asarray(v, float) for v in CAMERAS[camera])
        b = np.asarray(bounds, float) if bounds is not None else \
            np.asarray(pl.bounds, float).reshape(3, 2).T
        focal = 0.5 * (b[0] + b[1])
        size = float(np.linalg.norm(b[1] - b[0])) or 1.0
        pos = focal + direction / np.linalg.norm(direction) * 3.0 * size
        pl.camera_position = [tuple(pos), tuple(focal), tuple(up)]
        pl.reset_camera(bounds=(b[0, 0], b[1, 0], b[0, 1], b[1, 1], b[0, 2], b[1, 2]))
    else:
        try:
            pos, focal, up = (tuple(float(x) for x in v) for v in camera)
        except (TypeError, ValueError):
            raise ValueError("camera must be a preset name or (position, focal_point, "
                             f"view_up), got {camera!r}") from None
        pl.camera_position = [pos, focal, up]
    if zoom != 1.0:
        pl.camera.zoom(float(zoom))


# -- preset builders -----------------------------------------------------------------------
def add_walls(pl, model, state, *, opacity: float = 0.15, color=WALL_COLOR, **options) -> None:
    """Walls as translucent surfaces (``options`` go to :func:`workbench.meshes.wall_part`)."""
    part = meshes.wall_part(model, state, **options)
    if part is not None and opacity > 0:
        pl.add_mesh(part.to_polydata(), color=color, opacity=float(opacity), smooth_shading=False,
                    show_scalar_bar=False, lighting=True, name="walls")


def _spheres(pl, part, name: str, scalars=None, **kw):
    """Spheres at their true radius as point-Gaussian sphere impostors (cheap for 10⁵
    beads; exact silhouettes)."""
    mesh = part.to_polydata()
    actor = pl.add_mesh(mesh, style="points_gaussian", render_points_as_spheres=True,
                        emissive=False, smooth_shading=False, scalars=scalars, name=name, **kw)
    mapper = actor.mapper
    mapper.scale_array = "radius"
    mapper.SetScaleFactor(1.0)
    return actor


def _select(part, mask):
    """Sub-part of a vertex part (points where ``mask``)."""
    idx = np.flatnonzero(mask)
    return meshes.Part(points=part.points[idx], cell_type="vertex",
                       cells=np.arange(idx.size, dtype=np.int64).reshape(-1, 1),
                       point_data={k: v[idx] for k, v in part.point_data.items()})


def _black_legend_text(legend, colors) -> None:
    """Legend labels in black, each symbol in its colour.  vtkLegendBoxActor paints an
    entry's text in the entry's colour (the light sand colour was hard to read on white);
    with no entry colour it uses the text property's, and the symbol its own RGB scalars."""
    import pyvista as pv

    for i, col in enumerate(colors):
        sym = pv.wrap(legend.GetEntrySymbol(i)).copy()
        rgb = np.asarray(pv.Color(col).int_rgb, np.uint8)
        sym.point_data["rgb"] = np.tile(rgb, (sym.n_points, 1))
        sym.point_data.active_scalars_name = "rgb"
        legend.SetEntrySymbol(i, sym)
        legend.SetEntryColor(i, -1.0, -1.0, -1.0)
    legend.GetEntryTextProperty().SetColor(0.0, 0.0, 0.0)


def picture_kind(model, part) -> np.ndarray:
    """(n,) the ``kind`` of a bead part's spheres as the pictures colour them: sand, wire,
    or :data:`FIXED_KIND` for a fixed sphere that is not a wire bead (a floor of beads: a
    third colour)."""
    kind = part.point_data["kind"]
    fixed = (model.body_dof[part.point_data["body_id"]] != 0) & (kind != meshes.BEAD_WIRE)
    return np.where(fixed, FIXED_KIND, kind)


def add_beads(pl, model, state, *, walls: bool = True, wall_opacity: float = 0.15,
              color_by: str = "kind", clim=None, cmap="viridis", cut=None) -> None:
    """Preset ``beads``: spheres coloured by ``color_by`` = ``"kind"`` (sand / wire,
    legend box), ``"speed"`` [m/s] or ``"group"``; translucent walls.

    ``cut`` = (3,) direction: leave out the sand grains whose centre lies on that side of
    the plane through the scene centre normal to it (e.g. ``cut=(0, -1, 0)`` with the
    ``front`` camera opens the sample and shows the wire); wire beads are always drawn.
    """
    part = meshes.bead_part(model, state)
    if cut is not None:
        d = np.asarray(cut, float)
        if d.shape != (3,) or not np.any(d):
            raise ValueError(f"cut must be a non-zero 3-vector, got {cut!r}")
        centre = meshes.scene_bounds(model, state).mean(axis=0)
        keep = ((part.points - centre) @ d <= 0) | (part.point_data["kind"] == meshes.BEAD_WIRE)
        part = _select(part, keep)
    if part.n_points:
        if color_by == "kind":
            kind = picture_kind(model, part)
            fixed = kind == FIXED_KIND
            colors = [SAND_COLOR, WIRE_COLOR] + ([FIXED_COLOR] if fixed.any() else [])
            if fixed.any():
                part = dataclasses.replace(part, point_data=dict(
                    part.point_data, kind=kind.astype(part.point_data["kind"].dtype)))
            _spheres(pl, part, "beads", scalars="kind", cmap=colors,
                     clim=(-0.5, len(colors) - 0.5), n_colors=len(colors),
                     show_scalar_bar=False)
            # a legend box, not an annotated bar: the bar's labels sat on its colours
            kinds = set(np.unique(part.point_data["kind"]).tolist())
            entries = [[name, col] for k, name, col in ((meshes.BEAD_SAND, "sand", SAND_COLOR),
                                                       (meshes.BEAD_WIRE, "wire", WIRE_COLOR),
                                                       (FIXED_KIND, "fixed", FIXED_COLOR))
                       if k in kinds]
            # sized in px of the default window, scaled as the fonts (the box's text fills
            # it); upper right, where no colour bar is (this picture has none)
            sc, (w, h) = _scale_of(pl), pl.window_size
            size = (min(104.0 * sc / w, 0.4), min(21.0 * sc * (len(entries) + 1) / h, 0.5))
            legend = pl.add_legend(entries, bcolor="white", border=False, face="circle",
                                   size=size, loc="upper right", name="kind_legend")
            _black_legend_text(legend, [col for _, col in entries])
        elif color_by in ("speed", "group"):
            if clim is None:  # explicit: the point-Gaussian mapper's bar would show 0-1
                clim = _span(part.point_data[color_by])
            title = "group"
            if color_by == "speed":                         # mm/s, µm/s ... for reading
                f, unit = reading_unit("m/s", max(abs(clim[0]), abs(clim[1])))
                part = dataclasses.replace(part, point_data=dict(
                    part.point_data, speed=part.point_data["speed"] * f))
                clim, title = (clim[0] * f, clim[1] * f), f"speed [{unit}]"
            _spheres(pl, part, "beads", scalars=color_by, cmap=cmap, clim=clim,
                     show_scalar_bar=True, scalar_bar_args=_pl_bar(pl, title))
        else:
            raise ValueError(f"color_by must be 'kind', 'speed' or 'group', got {color_by!r}")
    if walls:
        add_walls(pl, model, state, opacity=wall_opacity)


def _span(v):
    """(min, max) of ``v``, or (0, 1) when it holds one value (a colour bar needs a range)."""
    v = np.asarray(v, float)
    return (float(v.min()), float(v.max())) if v.size and v.max() > v.min() else (0.0, 1.0)


def _from_zero(vmax: float):
    """(0, ``vmax``): forces and tensions start at 0; (0, 1) when there are none."""
    return (0.0, float(vmax)) if vmax > 0 else (0.0, 1.0)


def value_range(model, state, preset: str, *, color_by: str = "kind", cylinder=None,
                n_r: int = 5, n_z: int = 10, part: str = "wire", field: str = "equivalent",
                **_):
    """The data range of ``preset``'s colour scale in this state: (0, max T) for ``wire``,
    (0, max fn) for ``forces``, the field's (min, max) for ``beads`` coloured by ``speed``
    or ``group``, the map's finite (min, max) for ``torus``; None without a colour scale
    (beads by kind) or without data (an empty map).  The range may be empty, (0, 0) for a
    slack wire: :func:`workbench.frames.common_clim` joins the ranges of several frames, a
    single picture widens an empty one to (0, 1)."""
    if preset == "beads":
        if color_by == "kind":
            return None
        if color_by not in ("speed", "group"):
            raise ValueError(f"color_by must be 'kind', 'speed' or 'group', got {color_by!r}")
        v = np.asarray(meshes.bead_part(model, state).point_data[color_by], float)
        return (float(v.min()), float(v.max())) if v.size else None
    if preset == "wire":
        w = meshes.wire_part(model, state)
        t = w.cell_data["tension"] if w is not None else np.zeros(0)
        return 0.0, float(max(t.max(), 0.0)) if t.size else 0.0
    if preset == "forces":
        c = meshes.contact_part(model, state)
        fn = c.cell_data["normal_force"] if c is not None else np.zeros(0)
        return 0.0, float(fn.max()) if fn.size else 0.0
    if preset == "torus":
        _, tmap = _torus_map(model, state, cylinder, n_r, n_z, part)
        v = _torus_values(tmap, field, part)[0]
        v = v[np.isfinite(v)]
        return (float(v.min()), float(v.max())) if v.size else None
    raise ValueError(f"unknown preset {preset!r}; presets are {list(PRESETS)}")


def _tube_lines(part, values, radius, mask, n_sides: int):
    """Tubes around the line cells of ``part`` where ``mask``, of per-line ``radius`` [m]
    (constant along a line: a line part owns its two points), carrying ``values``."""
    import pyvista as pv

    idx = np.flatnonzero(mask)
    if idx.size == 0:
        return None
    pts = part.points.reshape(-1, 2, 3)[idx].reshape(-1, 3)
    k = idx.size
    conn = np.column_stack([np.full(k, 2), 2 * np.arange(k), 2 * np.arange(k) + 1]).ravel()
    lines = pv.PolyData(pts, lines=conn)
    lines.point_data["tube_radius"] = np.repeat(np.asarray(radius, float)[idx], 2)
    lines.point_data["value"] = np.repeat(np.asarray(values, float)[idx], 2)
    return lines.tube(scalars="tube_radius", absolute=True, n_sides=n_sides, capping=True)


def add_wire(pl, model, state, *, max_radius: float | None = None, slack: float = 0.02,
             clim=None, cmap="plasma", beads: bool = False, walls: bool = True,
             wall_opacity: float = 0.1, n_sides: int = 10) -> None:
    """Preset ``wire``: tension network.

    Each taut link (tension T > ``slack`` × max T) is a tube of radius
    ``max_radius`` × sqrt(T / max T) (tube area ∝ tension; ``max_radius`` defaults to the
    largest bead radius) coloured by T [N] over ``clim`` (default (0, max T)); slack links
    are thin grey tubes (radius ``max_radius``/8), broken ones thin red.  ``beads=True``
    also draws the wire beads faintly.
    """
    part = meshes.wire_part(model, state)
    if walls:
        add_walls(pl, model, state, opacity=wall_opacity)
    if part is None:
        return
    t = part.cell_data["tension"]
    broken = part.cell_data["broken"].astype(bool)
    rb = model.body_radius[model.link_i] if model.n_links else np.zeros(0)
    rmax = float(max_radius) if max_radius is not None else float(rb.max())
    tmax = float(max(t.max(), 0.0))
    taut = (~broken) & (t > slack * tmax) if tmax > 0 else np.zeros(len(t), bool)
    thin = np.full(len(t), rmax / 8.0)
    rad = np.where(taut, rmax * np.sqrt(np.clip(t, 0.0, None) / (tmax or 1.0)), thin)
    rad = np.maximum(rad, rmax / 8.0)
    for mask, name, kw in (
            ((~taut) & (~broken), "slack", dict(color=SLACK_COLOR)),
            (broken, "broken", dict(color=BROKEN_COLOR))):
        tubes = _tube_lines(part, t, rad, mask, n_sides)
        if tubes is not None:
            pl.add_mesh(tubes, name=f"wire_{name}", show_scalar_bar=False, smooth_shading=True, **kw)
    lim = clim if clim is not None else _from_zero(tmax)
    f, unit = reading_unit("N", max(abs(lim[0]), abs(lim[1])))     # mN for a sand sample
    tubes = _tube_lines(part, t * f, rad, taut, n_sides)
    if tubes is not None:
        pl.add_mesh(tubes, scalars="value", cmap=cmap, clim=(lim[0] * f, lim[1] * f),
                    name="wire_taut", smooth_shading=True, show_scalar_bar=True,
                    scalar_bar_args=_pl_bar(pl, f"tension [{unit}]"))
    if beads:
        import pyvista as pv

        bp = meshes.bead_part(model, state)
        wb = _select(bp, bp.point_data["kind"] == meshes.BEAD_WIRE)
        if wb.n_points:
            # faint sphere meshes: translucent point-Gaussian impostors were drawn as opaque
            # black discs (issue 29 item 3)
            ball = pv.Sphere(radius=1.0, theta_resolution=12, phi_resolution=8)
            pl.add_mesh(wb.to_polydata().glyph(geom=ball, scale="radius", orient=False),
                        color=WIRE_COLOR, opacity=0.25, smooth_shading=True, name="wire_beads")


def add_forces(pl, model, state, *, strong: float = 1.0, max_radius: float | None = None,
               clim=None, cmap="plasma", walls: bool = True, wall_opacity: float = 0.1,
               weak: bool = False, n_sides: int = 8) -> None:
    """Preset ``forces``: force chains, the strong network.

    Contacts with fn > ``strong`` × mean fn (the strong network) are tubes of radius
    ``max_radius`` × fn / max fn (proportional to the force; default ``max_radius``: the
    mean sphere radius × 0.5; at least ``max_radius``/10, so that none vanishes) coloured
    by fn [N] over ``clim`` (default: from 0, where the forces start, to max fn).
    ``weak=True`` also draws the weak network, as thin light-grey lines (off by default:
    with it, a sample of a few thousand contacts is a bird's nest).
    """
    part = meshes.contact_part(model, state)
    if walls:
        add_walls(pl, model, state, opacity=wall_opacity)
    if part is None:
        return
    fn = part.cell_data["normal_force"]
    fmax = float(fn.max()) if fn.size else 0.0
    rmax = float(max_radius) if max_radius is not None else \
        0.5 * float(model.body_radius[model.sphere_ids].mean())
    threshold = float(strong) * float(fn.mean())
    is_strong = fn > threshold if fmax > 0 else np.zeros(len(fn), bool)
    rad = rmax * np.clip(fn / (fmax or 1.0), 0.0, 1.0)
    thin = rmax / 10.0
    if weak and np.any(~is_strong):
        idx = np.flatnonzero(~is_strong)
        lines = meshes.Part(points=part.points.reshape(-1, 2, 3)[idx].reshape(-1, 3),
                            cell_type="line", cells=np.arange(2 * idx.size).reshape(-1, 2))
        pl.add_mesh(lines.to_polydata(), color=WEAK_COLOR, lighting=False, name="forces_weak",
                    line_width=_line_px(1.0, _scale_of(pl)), show_scalar_bar=False)
    lim = clim if clim is not None else _from_zero(fmax)
    f, unit = reading_unit("N", max(abs(lim[0]), abs(lim[1])))
    tubes = _tube_lines(part, fn * f, np.maximum(rad, thin), is_strong, n_sides)
    if tubes is not None:
        pl.add_mesh(tubes, scalars="value", cmap=cmap, clim=(lim[0] * f, lim[1] * f),
                    name="forces_strong", smooth_shading=True, show_scalar_bar=True,
                    scalar_bar_args=_pl_bar(pl, f"normal force [{unit}]"))


def scene_summary(model) -> str:
    """A few words on what a scene holds: ``"729 spheres, walls: 2 planes"``."""
    from engine.model import CYLINDER, PLANE

    kinds = model.body_kind[model.wall_ids] if len(model.wall_ids) else np.zeros(0, int)
    walls = [f"{n} {name}{'s' if n != 1 else ''}" for n, name in
             ((int((kinds == PLANE).sum()), "plane"), (int((kinds == CYLINDER).sum()), "cylinder"))
             if n]
    n = len(model.sphere_ids)
    return f"{n} sphere{'s' if n != 1 else ''}, walls: {', '.join(walls) or 'none'}"


#: The end of the refusal of a toroidal map without a cylinder (one line).
_CYLINDER_HINT = ("pass cylinder=Cylinder(radius, height, center) to draw one anyway, or render "
                  "the run's history file (workbench.frames.render_frames, nscd render "
                  "--preset torus), which takes a cylinder_triaxial run's own cylinder")


def no_cylinder_error(what: str, hint: str = _CYLINDER_HINT) -> ValueError:
    """The one-line refusal of a toroidal map on ``what`` (the scene, said in a few words)."""
    return ValueError(f"preset 'torus': a toroidal map needs a cylindrical sample, and {what}; "
                      f"{hint}")


def wall_cylinder(model, state):
    """The :class:`~engine.prep.containers.Cylinder` of the scene's first cylinder wall, or
    None without one; ValueError for a cylinder that is not vertical (+z)."""
    from engine.model import CYLINDER
    from engine.prep.containers import Cylinder

    cyl = [w for w in model.wall_ids if model.body_kind[w] == CYLINDER]
    if not cyl:
        return None
    w = cyl[0]
    if not np.allclose(model.body_axis[w], (0.0, 0.0, 1.0)):
        raise ValueError("toroidal maps need a vertical (+z) cylinder")
    return Cylinder(radius=float(model.body_radius[w]), height=float(model.body_height[w]),
                    center=tuple(state.position[w]))


def _cylinder_of(model, state):
    """The scene's cylinder wall (:func:`wall_cylinder`), or the refusal."""
    cyl = wall_cylinder(model, state)
    if cyl is None:
        raise no_cylinder_error(f"this scene ({scene_summary(model)}) has no cylinder wall")
    return cyl


def _torus_map(model, state, cylinder, n_r, n_z, part):
    from engine.analysis import toroidal_map

    if cylinder is None:
        cylinder = _cylinder_of(model, state)
    return cylinder, toroidal_map(model, state, cylinder, n_r=n_r, n_z=n_z, part=part)


def _torus_values(tmap, field, part):
    of = {"wire": "the wire", "sand": "the sand", "all": "sand + wire"}.get(part, part)
    if field == "equivalent":
        return tmap.equivalent, f"equivalent stress of {of} [Pa]"
    if field == "pressure":
        return -np.trace(tmap.stress, axis1=2, axis2=3) / 3.0, f"pressure of {of} [Pa]"
    raise ValueError(f"field must be 'equivalent' or 'pressure', got {field!r}")


def _torus_span(values):
    finite = values[np.isfinite(values)]
    if finite.size and finite.max() > finite.min():
        return float(finite.min()), float(finite.max())
    return _from_zero(float(finite.max()) if finite.size else 0.0)


def _text(pl, text: str, position, size: int, *, name=None, halign: str = "left",
          valign: str = "bottom", orientation: float = 0.0, world: bool = False):
    """A text actor of ``size`` px at ``position``: normalised viewport coordinates of the
    current renderer, or world coordinates (x, y, z) when ``world``; anchored at its
    ``halign`` x ``valign`` corner."""
    import pyvista as pv

    if world:
        actor = pv.Text(text)
        actor.GetPositionCoordinate().SetCoordinateSystemToWorld()
        actor.GetPositionCoordinate().SetValue(*(float(v) for v in position))
        pl.add_actor(actor, reset_camera=False, name=name, pickable=False, render=False)
    else:
        actor = pl.add_text(text, position=tuple(position), viewport=True, font_size=size / 2,
                            color="black", name=name, orientation=orientation, render=False)
    prop = actor.GetTextProperty()
    prop.SetFontFamilyToArial()
    prop.SetColor(0.0, 0.0, 0.0)
    prop.SetFontSize(int(size))
    prop.SetOrientation(float(orientation))
    getattr(prop, f"SetJustificationTo{halign.capitalize()}")()
    getattr(prop, f"SetVerticalJustificationTo{valign.capitalize()}")()
    return actor


def nice_ticks(lo: float, hi: float, n: int = 5) -> np.ndarray:
    """About ``n`` round tick values (steps of 1, 2, 2.5 or 5 × 10^k) in [lo, hi]."""
    lo, hi = float(lo), float(hi)
    if not hi > lo:
        return np.array([lo])
    raw = (hi - lo) / max(int(n) - 1, 1)
    k = 10.0 ** np.floor(np.log10(raw))
    step = min((m * k for m in (1.0, 2.0, 2.5, 5.0, 10.0) if m * k >= raw * 0.999),
               default=10.0 * k)
    first = np.ceil(lo / step - 1e-9) * step
    ticks = np.arange(first, hi + step * 1e-9, step)
    return np.round(ticks / step) * step + 0.0        # no -0


def _tick_label(v: float) -> str:
    return f"{v:.3g}"


def _section_axes(pl, xe, ze, scale: float, vp_px) -> None:
    """Axes with ticks in mm (units for reading) of the axial section drawn in the x-y plane
    over x in [xe[0], xe[-1]], y in [ze[0], ze[-1]] [m]: r below, z at the left, each set
    off from the image by a gap, so that their first labels do not meet at the corner;
    then the camera framing the section and its labels in the viewport (``vp_px``, its
    (width, height) [px])."""
    import pyvista as pv

    x0, x1, z0, z1 = float(xe[0]), float(xe[-1]), float(ze[0]), float(ze[-1])
    f, unit = reading_unit("m", max(abs(x0), abs(x1), abs(z0), abs(z1)))
    lab, tit = font_px("axis_label", scale), font_px("axis_title", scale)
    gap, tick, pad = 6.0 * scale, 5.0 * scale, 3.0 * scale              # [px]
    # room [px] around the image: labels and titles left and below, the panel title above
    zt = nice_ticks(z0 * f, z1 * f, 5)
    rt = nice_ticks(x0 * f, x1 * f, 5)
    width_label = 0.6 * lab * max(len(_tick_label(v)) for v in zt)
    left = gap + tick + pad + width_label + pad + tit + 2 * pad
    below = gap + tick + pad + lab + pad + tit + 2 * pad
    above = font_px("panel", scale) + 4 * pad + 6.0 * scale
    right = 12.0 * scale
    vw, vh = (float(v) for v in vp_px)
    aw, ah = max(vw - left - right, 10.0), max(vh - below - above, 10.0)
    wpp = max((x1 - x0) / aw, (z1 - z0) / ah)                            # [m / px]
    cx = 0.5 * (x0 + x1) - 0.5 * (left - right) * wpp
    cy = 0.5 * (z0 + z1) - 0.5 * (below - above) * wpp
    pl.camera_position = [(cx, cy, 1.0), (cx, cy, 0.0), (0.0, 1.0, 0.0)]
    pl.enable_parallel_projection()
    pl.camera.parallel_scale = 0.5 * vh * wpp
    pl.camera.clipping_range = (0.5, 1.5)

    ya = z0 - gap * wpp                          # the r axis, below the image
    xa = x0 - gap * wpp                          # the z axis, left of it
    segs = [[(x0, ya), (x1, ya)], [(xa, z0), (xa, z1)]]
    segs += [[(v / f, ya), (v / f, ya - tick * wpp)] for v in rt]
    segs += [[(xa, v / f), (xa - tick * wpp, v / f)] for v in zt]
    pts = np.array([(x, y, 0.0) for seg in segs for (x, y) in seg])
    n = len(segs)
    lines = pv.PolyData(pts, lines=np.column_stack([np.full(n, 2), 2 * np.arange(n),
                                                    2 * np.arange(n) + 1]).ravel())
    pl.add_mesh(lines, color="black", line_width=_line_px(1.0, scale), lighting=False,
                name="section_axes", show_scalar_bar=False, reset_camera=False)
    for i, v in enumerate(rt):
        _text(pl, _tick_label(v), (v / f, ya - (tick + pad) * wpp, 0.0), lab, world=True,
              halign="centered", valign="top", name=f"section_r{i}")
    for i, v in enumerate(zt):
        _text(pl, _tick_label(v), (xa - (tick + pad) * wpp, v / f, 0.0), lab, world=True,
              halign="right", valign="centered", name=f"section_z{i}")
    _text(pl, f"r [{unit}], both sides of the axis",
          (0.5 * (x0 + x1), ya - (tick + 2 * pad + lab + pad) * wpp, 0.0), tit, world=True,
          halign="centered", valign="top", name="section_r_title")
    _text(pl, f"z [{unit}]", (xa - (tick + 2 * pad + width_label + pad) * wpp,
                              0.5 * (z0 + z1), 0.0), tit, world=True, halign="centered",
          valign="bottom", orientation=90.0, name="section_z_title")


def _cell_grid_lines(r_edges, z_edges, center, sweep: float, resolution: int):
    """The (r, z) cell boundaries of a revolved map as lines on its surface: arcs at each
    z edge on the outer (and inner) wall, arcs at each r edge on the top and bottom, and the
    grid of both on the two cut faces, each lifted off its face by 0.2 % of the map's size
    (lines on a face z-fight with it): a :class:`pyvista.PolyData`."""
    import pyvista as pv

    re_, ze = np.asarray(r_edges, float), np.asarray(z_edges, float)
    c = np.asarray(center, float)
    eps = 2e-3 * max(re_[-1], ze[-1] - ze[0])
    k = max(2, int(round(resolution * sweep / 360.0)))
    th = np.deg2rad(np.linspace(0.0, float(sweep), k + 1))

    def arc(r, z):
        return np.column_stack([r * np.cos(th), r * np.sin(th), np.full_like(th, z)])

    polys = [arc(re_[-1] + eps, z) for z in ze]                # on the outer wall
    if re_[0] > 0:                                             # on the inner wall
        polys += [arc(re_[0] - eps, z) for z in ze]
    polys += [arc(r, ze[-1] + eps) for r in re_ if r > 0]      # on the top
    polys += [arc(r, ze[0] - eps) for r in re_ if r > 0]       # on the bottom
    for t, side in ((th[0], -1.0), (th[-1], 1.0)):             # on the cut faces
        u = np.array([np.cos(t), np.sin(t), 0.0])
        out = side * eps * np.array([-np.sin(t), np.cos(t), 0.0])
        polys += [np.array([r * u + (0, 0, ze[0]), r * u + (0, 0, ze[-1])]) + out for r in re_]
        polys += [np.array([re_[0] * u + (0, 0, z), re_[-1] * u + (0, 0, z)]) + out
                  for z in ze]
    pts = np.concatenate(polys) + c
    conn, start = [], 0
    for p in polys:
        conn += [len(p), *range(start, start + len(p))]
        start += len(p)
    return pv.PolyData(pts, lines=np.asarray(conn))


def add_torus(pl, model, state, *, cylinder=None, tmap=None, n_r: int = 5, n_z: int = 10,
              part: str = "wire", field: str = "equivalent", clim=None, cmap="viridis",
              sweep: float = 270.0, resolution: int = 72, camera="iso") -> None:
    """Preset ``torus`` on a plotter of :data:`TORUS_LAYOUT` (or of shape (1, 2): the bar
    then at the right of the revolved view): the axial section (upper left: the (r, z) map
    mirrored about the axis, axes in mm) and the revolved view (upper right, unlit: its
    colours are the bar's) of a toroidal map, and one horizontal colour bar under both.

    ``tmap`` (an :class:`engine.analysis.ToroidalMap`) is computed with
    :func:`engine.analysis.toroidal_map` (``cylinder``, ``n_r``, ``n_z``, ``part``) when
    not given; ``cylinder`` defaults to the scene's cylinder wall, and a scene without one
    is refused (ValueError; a history's frame passes its run's cylinder:
    :func:`workbench.frames.frame_cylinder`).  ``field`` is ``"equivalent"`` (‖dev σ‖
    [Pa]) or ``"pressure"`` (−tr σ / 3 [Pa], compression positive).
    """
    if tmap is None:
        cylinder, tmap = _torus_map(model, state, cylinder, n_r, n_z, part)
    values, title = _torus_values(tmap, field, part)
    span = clim if clim is not None else _torus_span(values)
    f, unit = reading_unit("Pa", max(abs(span[0]), abs(span[1])))      # kPa under 15 kPa
    values, title = values * f, title.replace("[Pa]", f"[{unit}]")
    lim = (span[0] * f, span[1] * f)
    re_, ze = np.asarray(tmap.r_edges, float), np.asarray(tmap.z_edges, float)
    sc = _scale_of(pl)
    W, H = pl.window_size
    strip = pl.shape[0] >= 2
    panel = font_px("panel", sc)
    edge = _line_px(1.0, sc)

    # left: the axial section (paper Fig. 13c: "drawn in the axial/radial section"), the
    # (r, z) map mirrored about the axis so that it reads as a cut through the sample and
    # is twice as wide as a half section; drawn in the x-y plane (x = ±r, z along y)
    sec = axial_section(values, re_, ze, title)
    xe = np.asarray(sec.x)
    pl.subplot(0, 0)
    _text(pl, "axial section", (0.02, 0.975), panel, valign="top", name="panel_section")
    section = pl.add_mesh(sec, scalars=title, cmap=cmap, clim=lim, nan_color=NAN_COLOR,
                          show_edges=True, edge_color="white", line_width=edge, lighting=False,
                          show_scalar_bar=False, name="torus_section", reset_camera=False)
    vx0, vy0, vx1, vy1 = pl.renderer.GetViewport()
    _section_axes(pl, xe, ze, sc, ((vx1 - vx0) * W, (vy1 - vy0) * H))

    # right: revolved about the axis over `sweep` degrees, unlit (flat colours: those of
    # the bar), the cells' edges drawn on its surface
    c = np.asarray(tmap_center(cylinder, model, state), float)
    pl.subplot(0, 1)
    _text(pl, f"revolved ({sweep:g}°)", (0.02, 0.975), panel, valign="top",
          name="panel_revolved")
    pl.add_mesh(revolved_map(values, re_, ze, c, title, sweep=sweep, resolution=resolution),
                scalars=title, cmap=cmap, clim=lim, nan_color=NAN_COLOR, show_scalar_bar=False,
                smooth_shading=False, lighting=False, name="torus_revolved")
    pl.add_mesh(_cell_grid_lines(re_, ze, c, sweep, resolution), color="white",
                line_width=edge, lighting=False, name="torus_cells", show_scalar_bar=False)
    lo = c - (re_[-1], re_[-1], 0.0)
    hi = c + (re_[-1], re_[-1], ze[-1])
    set_camera(pl, camera, bounds=np.array([lo, hi]))
    pl.camera.zoom(1.1)                         # (reset_camera fits the bounding sphere)

    if strip:     # one horizontal bar under both panels, its title above it
        pl.subplot(1, 0)
        sh = float(TORUS_LAYOUT["row_weights"][1]) / sum(TORUS_LAYOUT["row_weights"]) * H
        bar_h = 34.0 * sc / sh                  # the bar and its labels below it
        y = 0.5 - 0.5 * bar_h + 4.0 * sc / sh
        args = dict(title="", vertical=False, n_labels=5, fmt="%.3g", color="black",
                    font_family="arial", label_font_size=font_px("bar_label", sc),
                    title_font_size=font_px("bar_title", sc),
                    position_x=0.25, position_y=y, width=0.5, height=bar_h)
        bar = pl.add_scalar_bar(mapper=section.mapper, **args)
        bar.SetTextPositionToPrecedeScalarBar()               # labels under the bar
        _text(pl, title, (0.5, y + bar_h + 5.0 * sc / sh), font_px("bar_title", sc),
              halign="centered", valign="bottom", name="bar_title")
    else:         # a vertical bar at the right of the revolved view (its viewport's size)
        x0, _, x1, _ = pl.renderer.GetViewport()
        pl.add_scalar_bar(mapper=section.mapper, **_bar(title.replace(" of ", "\nof "), sc,
                                                         ((x1 - x0) * W, H)))
        pl.camera.zoom(0.8)                     # room for it


def revolved_map(values, r_edges, z_edges, center, name: str = "values", *,
                 sweep: float = 270.0, resolution: int = 72):
    """The surface of an axisymmetric (r, z) cell map revolved about the vertical axis
    through ``center`` (the base centre [m]) over ``sweep`` degrees (cut open, so the inside
    shows), ``values`` (nr, nz) as cell data ``name``: a :class:`pyvista.PolyData`."""
    import pyvista as pv

    re_, ze = np.asarray(r_edges, float), np.asarray(z_edges, float)
    k = max(2, int(round(resolution * sweep / 360.0)))
    th = np.deg2rad(np.linspace(0.0, float(sweep), k + 1))
    rr, tt, zz = np.meshgrid(re_, th, ze, indexing="ij")
    c = np.asarray(center, float)
    grid = pv.StructuredGrid(c[0] + rr * np.cos(tt), c[1] + rr * np.sin(tt), c[2] + zz)
    # cells of the structured grid in VTK order (r fastest, then θ, then z)
    cell = np.asarray(values, float)[:, None, :].repeat(k, axis=1)  # (nr, k, nz)
    grid.cell_data[name] = cell.ravel(order="F")
    return grid.extract_surface(algorithm="dataset_surface")


def axial_section(values, r_edges, z_edges, name: str = "values"):
    """The axial section of an axisymmetric (r, z) cell map: a :class:`pyvista.RectilinearGrid`
    in the x-y plane, x = ±r (the map mirrored about the axis), y = z, one cell per map cell
    on each side, ``values`` (nr, nz) as cell data ``name``.  When the map starts off the
    axis (r_edges[0] > 0) the hole is one NaN cell across it."""
    import pyvista as pv

    re_, ze = np.asarray(r_edges, float), np.asarray(z_edges, float)
    vals = np.asarray(values, float)
    if vals.shape != (re_.size - 1, ze.size - 1):
        raise ValueError(f"values must have shape {(re_.size - 1, ze.size - 1)} (r cells, "
                         f"z cells), got {vals.shape}")
    on_axis = re_[0] == 0.0
    xe = np.concatenate([-re_[::-1], re_[1:] if on_axis else re_])
    hole = np.full((0 if on_axis else 1, vals.shape[1]), np.nan)
    both = np.concatenate([vals[::-1], hole, vals], axis=0)        # (2 nr [+ 1], nz)
    sec = pv.RectilinearGrid(xe, ze, np.array([0.0]))
    sec.cell_data[name] = both.ravel(order="F")                     # x fastest (VTK order)
    return sec


def tmap_center(cylinder, model, state):
    """Base centre [m] of the cylinder of a toroidal map (``cylinder`` or the scene's)."""
    if cylinder is None:
        try:
            cylinder = _cylinder_of(model, state)
        except ValueError:
            return (0.0, 0.0, 0.0)
    return cylinder.center


# -- entry points --------------------------------------------------------------------------
def time_text(t: float) -> str:
    """``t`` [s] for reading: ``"45.65 ms"``, ``"2.5 s"``, ``"0 s"`` (4 significant digits;
    the prefix that puts it between 1 and 1000, as :func:`workbench.units.reading_unit`
    does for its units; never above s)."""
    from .units import PREFIXED

    t = float(t)
    if "s" in PREFIXED:
        f, unit = reading_unit("s", t)
    else:                      # the prefix reading_unit gives a length, applied to seconds
        f, unit = reading_unit("m", t)
        unit = unit[:-1] + "s"
    if f < 1.0:
        f, unit = 1.0, "s"
    return f"{t * f:.4g} {unit}"


def default_title(state, *more: str) -> str:
    """The default title of a picture of ``state``: ``"step 913 · t = 45.65 ms"``, then
    each of ``more`` (e.g. ``"axial strain 5.00 %"``: :func:`workbench.frames.frame_title`)
    after a ``·``."""
    parts = [f"step {int(state.step)}", f"t = {time_text(state.time)}", *more]
    return " · ".join(p for p in parts if p)


def add_axes(pl, bounds, *, scale: float | None = None):
    """The box ``bounds`` ((2, 3) [m]) as axes on its outer edges with ticks at round
    values (VTK's cube axes) and titles in units for reading (mm for a sample of a few mm:
    :func:`workbench.units.reading_unit`), fonts and lines scaled with the window
    (``scale``, default :func:`ui_scale` of ``pl``).  Returns the actor (name ``"axes"``)."""
    from vtkmodules.vtkRenderingAnnotation import vtkCubeAxesActor

    b = np.asarray(bounds, float)
    sc = _scale_of(pl) if scale is None else float(scale)
    f, unit = reading_unit("m", float(np.abs(b).max()))
    actor = vtkCubeAxesActor()
    actor.SetBounds(*np.column_stack([b[0], b[1]]).ravel())
    actor.SetXAxisRange(b[0, 0] * f, b[1, 0] * f)
    actor.SetYAxisRange(b[0, 1] * f, b[1, 1] * f)
    actor.SetZAxisRange(b[0, 2] * f, b[1, 2] * f)
    actor.SetCamera(pl.camera)
    actor.SetFlyModeToOuterEdges()
    actor.SetTickLocationToOutside()
    actor.SetUseTextActor3D(False)
    actor.SetLabelScaling(False, 0, 0, 0)              # labels in mm, no "x 10^-3" title
    for i, axis in enumerate("XYZ"):       # (the label format: VTK's, from the range)
        getattr(actor, f"Set{axis}Title")(f"{axis.lower()} [{unit}]")
        getattr(actor, f"Get{axis}AxesLinesProperty")().SetColor(0.0, 0.0, 0.0)
        getattr(actor, f"Get{axis}AxesLinesProperty")().SetLineWidth(_line_px(1.0, sc))
        for prop, size in ((actor.GetTitleTextProperty(i), "axis_title"),
                           (actor.GetLabelTextProperty(i), "axis_label")):
            prop.SetColor(0.0, 0.0, 0.0)
            prop.SetFontFamilyToArial()
            prop.SetFontSize(font_px(size, sc))
    pl.add_actor(actor, reset_camera=False, name="axes", pickable=False, render=False)
    return actor


def plotter(model, state, preset: str = "beads", *, camera="iso", window_size=WINDOW_SIZE,
            zoom: float = 1.0, title: str | None = None, bounds=None, axes: bool = False,
            **options):
    """An off-screen :class:`pyvista.Plotter` holding the picture of ``preset`` (see the
    module doc; ``options`` go to the preset's builder).  ``bounds`` ((2, 3) [m]) frames the
    camera on that box instead of this state's free bodies (one camera for several frames:
    :mod:`workbench.frames`).  ``title`` replaces the default one (:func:`default_title`;
    ``""``: none).  ``axes=True`` draws the framed box as axes with ticks in mm
    (:func:`add_axes`; the torus preset's axial section always has its axes, in mm, and
    its revolved view none).  Fonts and line widths scale with ``window_size``
    (:func:`ui_scale`).  The caller closes it."""
    if preset not in PRESETS:
        raise ValueError(f"unknown preset {preset!r}; presets are {list(PRESETS)}")
    w, h = (int(v) for v in window_size)
    if w < 16 or h < 16:
        raise ValueError(f"window_size must be at least 16 x 16 px, got {window_size!r}")
    headless_backend()
    import pyvista as pv

    sc = ui_scale((w, h))
    layout = dict(TORUS_LAYOUT) if preset == "torus" else dict(shape=(1, 1))
    pl = pv.Plotter(off_screen=True, window_size=[w, h], theme=theme(sc), border=False,
                    **layout)
    try:
        if preset == "torus":
            add_torus(pl, model, state, camera=camera, **options)
            pl.subplot(0, 1)                                   # the revolved view
            if zoom != 1.0:
                pl.camera.zoom(float(zoom))
            # (no `axes`: the axial section has its own, in mm)
            pl.subplot(1, 0)                                   # the strip under the panels
            where = (0.015, 0.06)
        else:
            {"beads": add_beads, "wire": add_wire, "forces": add_forces}[preset](
                pl, model, state, **options)
            box = meshes.scene_bounds(model, state, free_only=True) if bounds is None \
                else np.asarray(bounds, float)
            # with axes: room for their labels
            set_camera(pl, camera, bounds=box, zoom=(0.85 if axes else 1.0) * zoom)
            if axes:
                add_axes(pl, box, scale=sc)
            where = (0.015, 0.015)
        text = title if title is not None else default_title(state)
        if text:
            # a corner annotation ("lower_left") clips the first glyph at the window edge
            _text(pl, text, where, font_px("title", sc), name="title")
    except Exception:
        pl.close()
        raise
    return pl


def snapshot(model, state, path, preset: str = "beads", *, camera="iso",
             window_size=WINDOW_SIZE, **options) -> Path:
    """Render ``preset`` off-screen to the PNG ``path`` (parent directories created) and
    return the path (``.png`` added when it has no suffix, as the image writer does).  See
    :func:`plotter` for ``camera``, ``window_size``, ``zoom``, ``title``, ``bounds``,
    ``axes`` and the module doc for each preset's ``options``.  The torus preset takes the
    scene's cylinder wall or ``cylinder=``, and refuses a scene without one (a state has no
    history: :func:`workbench.frames.render_frames` takes a cylinder_triaxial run's own
    cylinder).  A picture of the wire (``wire``, ``torus`` of ``part="wire"``) of a scene
    without wire links warns: it shows no wire."""
    path = Path(path)
    if not path.suffix:
        path = path.with_suffix(".png")
    path.parent.mkdir(parents=True, exist_ok=True)
    pl = plotter(model, state, preset, camera=camera, window_size=window_size, **options)
    try:
        if model.n_links == 0 and (preset == "wire" or preset == "torus" and options.get(
                "tmap") is None and options.get("part", "wire") == "wire"):
            import warnings

            shows = "the walls only" if preset == "wire" else "an empty map"
            warnings.warn(f"snapshot: preset {preset!r} draws the wire, and this scene has no "
                          f"wire links: {path} shows {shows}", RuntimeWarning, stacklevel=2)
        from engine.files import replacing

        with replacing(path, "the picture could not be written") as tmp:
            pl.screenshot(str(tmp), transparent_background=False)
    finally:
        pl.close()
    return path
