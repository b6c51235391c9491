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
    Force chains: one tube per contact (centre to centre, or centre to the wall point)
    whose radius and colour grow with the normal force [N]; the strong network
    (fn > ``strong`` × mean fn, the usual split at the mean force) opaque and coloured,
    the weak network thin and light grey.
``torus``  (:func:`add_torus`)
    Toroidal map (paper Fig. 13c; :func:`engine.analysis.toroidal_map`): left, the
    axial section of the cylinder (the (r, z) map mirrored about the axis) as an image of
    the equivalent stress [Pa] per torus cell (grey = empty cell); right, the same map revolved about the cylinder axis over
    ``sweep`` degrees (cut open, so the inside shows).

Determinism: one fixed theme (:func:`theme`: white background, Arial, fixed font sizes,
no multi-sampling), a fixed window size, cameras computed from the scene bounds only
(:data:`CAMERAS`), no random colours.  The same input gives the same pixels on the same
GL stack (checked by ``tests/workbench/test_render.py``).

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
           "picture_kind", "value_range"]

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


def theme():
    """The fixed :class:`pyvista.themes.Theme` of every picture (a fresh copy)."""
    import pyvista as pv

    t = pv.themes.DocumentTheme()
    t.background = "white"
    t.window_size = list(WINDOW_SIZE)
    t.font.family = "arial"
    t.font.color = "black"
    t.font.size = 14
    t.font.title_size = 14
    t.font.label_size = 12
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


def _bar(title: str, **kw) -> dict:
    # the trailing newline lifts the title off the top label (they touched)
    args = dict(title=title + "\n", vertical=True, n_labels=5, fmt="%.3g", color="black",
                font_family="arial", title_font_size=14, label_font_size=12,
                position_x=0.86, position_y=0.1, width=0.06, height=0.8)
    args.update(kw)
    return args


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
            legend = pl.add_legend(entries, bcolor="white", border=False, face="circle",
                                   size=(0.13, 0.035 * (len(entries) + 1)),
                                   loc="upper right", name="kind_legend")
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
                     show_scalar_bar=True, scalar_bar_args=_bar(title))
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
                    scalar_bar_args=_bar(f"tension [{unit}]"))
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
               weak: bool = True, n_sides: int = 8) -> None:
    """Preset ``forces``: force chains.

    Contacts with fn > ``strong`` × mean fn (the strong network) are tubes of radius
    ``max_radius`` × fn / max fn (default: the mean sphere radius × 0.5) coloured by fn [N]
    over ``clim`` (default: from 0, where the forces start, to max fn); the weak
    network is drawn as 1-px light-grey lines (``weak=False`` hides it).
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
        pl.add_mesh(lines.to_polydata(), color=WEAK_COLOR, line_width=1.0, lighting=False,
                    name="forces_weak", show_scalar_bar=False)
    lim = clim if clim is not None else _from_zero(fmax)
    f, unit = reading_unit("N", max(abs(lim[0]), abs(lim[1])))
    tubes = _tube_lines(part, fn * f, np.maximum(rad, thin), is_strong, n_sides)
    if tubes is not None:
        pl.add_mesh(tubes, scalars="value", cmap=cmap, clim=(lim[0] * f, lim[1] * f),
                    name="forces_strong", smooth_shading=True, show_scalar_bar=True,
                    scalar_bar_args=_bar(f"normal force [{unit}]"))


def _cylinder_of(model, state):
    from engine.prep.containers import Cylinder

    cyl = [w for w in model.wall_ids if model.body_kind[w] == 2]
    if not cyl:
        raise ValueError("preset 'torus' needs cylinder=Cylinder(...): the scene has no cylinder")
    w = cyl[0]
    if not np.allclose(model.body_axis[w], (0.0, 0.0, 1.0)):
        raise ValueError("toroidal maps need a vertical (+z) cylinder")
    return Cylinder(radius=float(model.body_radius[w]), height=float(model.body_height[w]),
                    center=tuple(state.position[w]))


def _torus_map(model, state, cylinder, n_r, n_z, part):
    from engine.analysis import toroidal_map

    if cylinder is None:
        cylinder = _cylinder_of(model, state)
    return cylinder, toroidal_map(model, state, cylinder, n_r=n_r, n_z=n_z, part=part)


def _torus_values(tmap, field, part):
    if field == "equivalent":
        return tmap.equivalent, f"eq. stress\n{part} [Pa]"
    if field == "pressure":
        return -np.trace(tmap.stress, axis1=2, axis2=3) / 3.0, f"pressure\n{part} [Pa]"
    raise ValueError(f"field must be 'equivalent' or 'pressure', got {field!r}")


def _torus_span(values):
    finite = values[np.isfinite(values)]
    if finite.size and finite.max() > finite.min():
        return float(finite.min()), float(finite.max())
    return _from_zero(float(finite.max()) if finite.size else 0.0)


def add_torus(pl, model, state, *, cylinder=None, tmap=None, n_r: int = 5, n_z: int = 10,
              part: str = "wire", field: str = "equivalent", clim=None, cmap="viridis",
              sweep: float = 270.0, resolution: int = 72, camera="iso") -> None:
    """Preset ``torus`` on a plotter of shape (1, 2): the axial section (left: the (r, z)
    map mirrored about the axis) and the revolved view (right) of a toroidal map.

    ``tmap`` (an :class:`engine.analysis.ToroidalMap`) is computed with
    :func:`engine.analysis.toroidal_map` (``cylinder``, ``n_r``, ``n_z``, ``part``) when
    not given; ``cylinder`` defaults to the scene's first (vertical) cylinder.  ``field``
    is ``"equivalent"`` (‖dev σ‖ [Pa]) or ``"pressure"`` (−tr σ / 3 [Pa], compression
    positive).
    """
    if tmap is None:
        cylinder, tmap = _torus_map(model, state, cylinder, n_r, n_z, part)
    values, title = _torus_values(tmap, field, part)
    span = clim if clim is not None else _torus_span(values)
    f, unit = reading_unit("Pa", max(abs(span[0]), abs(span[1])))      # kPa under 15 kPa
    values, title = values * f, title.replace("[Pa]", f"[{unit}]")
    clim = (span[0] * f, span[1] * f)
    re_, ze = np.asarray(tmap.r_edges, float), np.asarray(tmap.z_edges, float)
    lim = clim if clim is not None else _torus_span(values)

    # left: the axial section (paper Fig. 13c: "drawn in the axial/radial section"), the
    # (r, z) map mirrored about the axis so that it reads as a cut through the sample and
    # is twice as wide as a half section; drawn in the x-y plane (x = ±r, z along y)
    sec = axial_section(values, re_, ze, title)
    xe = np.asarray(sec.x)
    pl.subplot(0, 0)
    pl.add_text("axial section", font_size=10, color="black", position="upper_left")
    pl.add_mesh(sec, scalars=title, cmap=cmap, clim=lim, nan_color=NAN_COLOR, show_edges=True,
                edge_color="white", lighting=False, show_scalar_bar=True,
                scalar_bar_args=_bar(title, position_x=0.84, width=0.07))
    pl.show_bounds(xtitle="r [m], both sides of the axis", ytitle="z [m]", ztitle="",
                   show_zaxis=False, color="black", font_size=11, fmt="%.2g",
                   location="front", grid=False, use_2d=True, n_xlabels=3, n_ylabels=5)
    set_camera(pl, "top", bounds=np.array([[xe[0], ze[0], 0.0], [xe[-1], ze[-1], 0.0]]))
    pl.enable_parallel_projection()
    pl.reset_camera()
    pl.camera.zoom(0.8)

    # right: revolved about the axis over `sweep` degrees
    c = np.asarray(tmap_center(cylinder, model, state), float)
    pl.subplot(0, 1)
    pl.add_text(f"revolved ({sweep:g} deg)", font_size=10, color="black", position="upper_left")
    pl.add_mesh(revolved_map(values, re_, ze, c, title, sweep=sweep, resolution=resolution),
                scalars=title, cmap=cmap, clim=lim, nan_color=NAN_COLOR, show_scalar_bar=False,
                smooth_shading=False)
    lo = c - (re_[-1], re_[-1], 0.0)
    hi = c + (re_[-1], re_[-1], ze[-1])
    set_camera(pl, camera, bounds=np.array([lo, hi]))


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
def plotter(model, state, preset: str = "beads", *, camera="iso", window_size=WINDOW_SIZE,
            zoom: float = 1.0, title: str | None = None, bounds=None, **options):
    """An off-screen :class:`pyvista.Plotter` holding the picture of ``preset`` (see the
    module doc; ``options`` go to the preset's builder).  ``bounds`` ((2, 3) [m]) frames the
    camera on that box instead of this state's free bodies (one camera for several frames:
    :mod:`workbench.frames`).  The caller closes it."""
    if preset not in PRESETS:
        raise ValueError(f"unknown preset {preset!r}; presets are {list(PRESETS)}")
    w, h = (int(v) for v in window_size)
    if w < 16 or h < 16:
        raise ValueError(f"window_size must be at least 16 x 16 px, got {window_size!r}")
    headless_backend()
    import pyvista as pv

    shape = (1, 2) if preset == "torus" else (1, 1)
    pl = pv.Plotter(off_screen=True, window_size=[w, h], theme=theme(), shape=shape,
                    border=False)
    try:
        if preset == "torus":
            add_torus(pl, model, state, camera=camera, **options)
            if zoom != 1.0:
                pl.camera.zoom(float(zoom))
        else:
            {"beads": add_beads, "wire": add_wire, "forces": add_forces}[preset](
                pl, model, state, **options)
            box = meshes.scene_bounds(model, state, free_only=True) if bounds is None \
                else np.asarray(bounds, float)
            set_camera(pl, camera, bounds=box, zoom=zoom)
        text = title if title is not None else f"t = {float(state.time):.4g} s"
        if text:
            # a corner annotation ("lower_left") clips the first glyph at the window edge
            pl.add_text(text, position=(0.015, 0.015), viewport=True, font_size=10,
                        color="black", name="title")
    except Exception:
        pl.close()
        raise
    return pl


def snapshot(model, state, path, preset: str = "beads", *, camera="iso",
             window_size=WINDOW_SIZE, **options) -> Path:
    """Render ``preset`` off-screen to the PNG ``path`` (parent directories created) and
    return the path (``.png`` added when it has no suffix, as the image writer does).  See
    :func:`plotter` for ``camera``, ``window_size``, ``zoom``, ``title`` and the module doc
    for each preset's ``options``.  A wire preset (``wire``, ``torus``) of a scene without
    wire links warns: its picture shows no wire."""
    path = Path(path)
    if not path.suffix:
        path = path.with_suffix(".png")
    path.parent.mkdir(parents=True, exist_ok=True)
    pl = plotter(model, state, preset, camera=camera, window_size=window_size, **options)
    try:
        if preset in ("wire", "torus") and model.n_links == 0:
            import warnings

            shows = "the walls only" if preset == "wire" else "an empty map"
            warnings.warn(f"snapshot: preset {preset!r} draws the wire, and this scene has no "
                          f"wire links: {path} shows {shows}", RuntimeWarning, stacklevel=2)
        pl.screenshot(str(path), transparent_background=False)
    finally:
        pl.close()
    return path
