"""Beads and links as glyphs the browser draws (``--mode client``): VTK's glyph mapper.

vtk.js draws neither VTK's point-Gaussian impostors nor round points that scale with the
camera, so client-side beads used to be flat squares of one size in pixels.  vtk.js does
draw ``vtkGlyph3DMapper`` (one small mesh instanced at every point, scaled and oriented by
point arrays: WebGL2 instancing) and trame-vtk's object manager in the page knows how to
build one, but trame-vtk's Python side has no serializer for it.  :func:`register` adds
that serializer (the glyphed points with their scale, orientation and colour arrays, the
small mesh as the glyph source, the scaling and orientation properties).

* :func:`sphere_actor`: the beads, a sphere of their diameter at each bead;
* :func:`stick_actor`: the wire's links and the force chains, a cylinder from one end of
  the segment to the other, of the segment's radius.  At a new frame of the paper-scale
  deposit (28 880 beads, 2 879 links) the page fetched 5.6 MB of arrays when the links
  were tube meshes, 0.49 MB with them glyphed (2026-12-03).

The server renders the same actors with VTK's glyph mapper (the screenshot button of
client mode uses the server's scene; picking is geometric, :mod:`workbench.view.scene`).
"""
from __future__ import annotations

import numpy as np

__all__ = ["register", "sphere_actor", "stick_actor", "SPHERE_RES", "STICK_RES"]

#: (theta, phi) resolution of the glyph sphere: 8 x 6 (~80 triangles) is round enough at
#: the sizes a bead takes on screen at the paper's scale, and 29 000 of them are 2.3 M
#: triangles for the browser's (software, here) WebGL.
SPHERE_RES = (8, 6)
#: sides of the glyph cylinder (as the tubes of workbench.render: 10 for the wire)
STICK_RES = 10

#: the glyphed points' arrays (fixed names: VTK has no getter for them)
SCALE = "glyph_scale"
ORIENT = "glyph_orient"


def _glyph_serializer(parent, mapper, mapper_id, context, depth):
    from trame_vtk.modules.vtk.serializers.cache import cache_properties
    from trame_vtk.modules.vtk.serializers.data import polydata_serializer
    from trame_vtk.modules.vtk.serializers.registry import class_name
    from trame_vtk.modules.vtk.serializers.serialize import serialize
    from trame_vtk.modules.vtk.serializers.utils import reference_id, wrap_id

    calls, deps = [], []
    for port, tag in ((0, "dataset"), (1, "source")):
        data = mapper.GetInputDataObject(port, 0)
        if data is None:
            return None
        did = f"{mapper_id}-{tag}"
        # every array of the (small, purpose-built) inputs: the scale and colour arrays
        inst = polydata_serializer(mapper, data, did, context, depth + 1,
                                   requested_fields=["*"])
        if inst is None:
            return None
        deps.append(inst)
        calls.append(["setInputData", [wrap_id(did), port]])
    lut = mapper.GetLookupTable()
    if lut is not None:
        lid = reference_id(lut)
        inst = serialize(mapper, lut, lid, context, depth + 1)
        if inst:
            deps.append(inst)
            calls.append(["setLookupTable", [wrap_id(lid)]])
    props = {
        "scalarRange": mapper.GetScalarRange(),
        "useLookupTableScalarRange": 1 if mapper.GetUseLookupTableScalarRange() else 0,
        "scalarVisibility": mapper.GetScalarVisibility(),
        "colorByArrayName": mapper.GetArrayName() if mapper.GetArrayAccessMode() == 1 else "",
        "colorMode": mapper.GetColorMode(),
        "scalarMode": mapper.GetScalarMode(),
        "interpolateScalarsBeforeMapping": 0,
        "scaling": bool(mapper.GetScaling()),
        "scaleMode": mapper.GetScaleMode(),
        "scaleFactor": mapper.GetScaleFactor(),
        "scaleArray": SCALE,                # (VTK has no getter)
        "orient": bool(mapper.GetOrient()),
        "orientationMode": mapper.GetOrientationMode(),
        "orientationArray": ORIENT,
    }
    return {"parent": reference_id(parent), "id": mapper_id, "type": class_name(mapper),
            "properties": cache_properties(mapper_id, context, props),
            "calls": calls, "dependencies": deps}


def _scalar_bar_serializer(parent, actor, actor_id, context, depth):
    """A colour bar for vtk.js as VTK lays it out: trame-vtk's own serializer sends every
    bar vertical at the same place, in a serif font, so the toroidal map's horizontal bar
    was drawn over the field's.  Here vtk.js's automatic layout gets the bar's orientation
    (vertical: at the right, horizontal: at the bottom) and the theme's font family."""
    from trame_vtk.modules.vtk.serializers.cache import cache_properties
    from trame_vtk.modules.vtk.serializers.serialize import serialize
    from trame_vtk.modules.vtk.serializers.utils import reference_id, wrap_id

    lut = actor.GetLookupTable()
    if not lut:
        return None
    lid = reference_id(lut)
    inst = serialize(actor, lut, lid, context, depth + 1)
    if not inst:
        return None
    title = actor.GetTitleTextProperty()
    color = "#%02x%02x%02x" % tuple(int(round(255 * c)) for c in title.GetColor())
    family = {"Arial": "Arial, Helvetica, sans-serif", "Courier": "Courier, monospace",
              "Times": "Times, serif"}.get(title.GetFontFamilyAsString(), "sans-serif")
    style = {"fontColor": color, "fontStyle": "normal", "fontFamily": family}
    props = {
        "visibility": actor.GetVisibility(), "pickable": 0, "dragable": 0,
        "useBounds": actor.GetUseBounds(), "automated": True,
        "axisLabel": actor.GetTitle(),
        "orientation": "horizontal" if actor.GetOrientation() == 0 else "vertical",
        "axisTextStyle": dict(style), "tickTextStyle": dict(style),
        "drawNanAnnotation": actor.GetDrawNanAnnotation(),
        "drawBelowRangeSwatch": actor.GetDrawBelowRangeSwatch(),
        "drawAboveRangeSwatch": actor.GetDrawAboveRangeSwatch(),
    }
    return {"parent": reference_id(parent), "id": actor_id, "type": "vtkScalarBarActor",
            "properties": cache_properties(actor_id, context, props),
            "calls": [["setScalarsToColors", [wrap_id(lid)]]], "dependencies": [inst]}


def _lookup_table_serializer(parent, lut, lut_id, context, depth):
    """trame-vtk's lookup table, with its mapping range: vtk.js's table keeps its default
    range, 0-255, until a mapper colours through it, which a translucent actor (the
    toroidal map, drawn at 60 % opacity) had not done when its colour bar was laid out, so
    the map's bar read 0-255 whatever the data."""
    from trame_vtk.modules.vtk.serializers.initialize import lookup_table_serializer_selector

    inst = lookup_table_serializer_selector(parent, lut, lut_id, context, depth)
    if inst and "properties" in inst and hasattr(lut, "GetRange"):
        inst["properties"]["mappingRange"] = list(lut.GetRange())
    return inst


def register() -> None:
    """Teach trame-vtk's serializer VTK's glyph mapper, and colour bars as VTK lays them
    out.  trame-vtk puts its own serializers back when its protocol starts (its colour
    bar's among them): the viewer calls this once the server is ready, before the page's
    first scene, and each glyph actor made calls it too."""
    from trame_vtk.modules.vtk.serializers.registry import (register_instance_serializer,
                                                            register_js_class)

    for cls in ("vtkGlyph3DMapper", "vtkOpenGLGlyph3DMapper"):
        register_js_class(cls, "vtkGlyph3DMapper")
    register_instance_serializer("vtkGlyph3DMapper", _glyph_serializer)
    register_instance_serializer("vtkScalarBarActor", _scalar_bar_serializer)
    register_instance_serializer("vtkLookupTable", _lookup_table_serializer)


def _glyph_actor(pl, pts, source, name: str, scalars, kw, *, by_components=False):
    """Add the points ``pts`` (a PolyData carrying :data:`SCALE`, and :data:`ORIENT` when
    oriented) to ``pl`` as ``source`` glyphed: pyvista builds the actor, its lookup table
    and colour bar from the points, then the mapper is swapped for a glyph mapper."""
    from vtkmodules.vtkRenderingCore import vtkGlyph3DMapper

    register()
    actor = pl.add_mesh(pts, scalars=scalars, name=name, style="points", **kw)
    old = actor.mapper
    g = vtkGlyph3DMapper()
    g.SetInputData(pts)
    g.SetSourceData(source)
    g.SetScaleArray(SCALE)
    if by_components:
        g.SetScaleModeToScaleByVectorComponents()
    else:
        g.SetScaleModeToScaleByMagnitude()
    g.SetScaleFactor(1.0)
    g.ScalingOn()
    if ORIENT in pts.point_data:
        g.SetOrientationArray(ORIENT)
        g.SetOrientationModeToDirection()
        g.OrientOn()
    else:
        g.OrientOff()
    g.SetLookupTable(old.GetLookupTable())
    g.SetScalarVisibility(old.GetScalarVisibility())
    if scalars is not None:
        g.SetScalarModeToUsePointFieldData()
        g.SelectColorArray(scalars)
        g.SetScalarRange(old.GetScalarRange())
        g.SetUseLookupTableScalarRange(old.GetUseLookupTableScalarRange())
        g.SetColorModeToMapScalars()
    actor.SetMapper(g)
    old.RemoveAllInputs()
    _SWAPPED.append(old)            # kept, its data released: see ViewScene.retire
    prop = actor.GetProperty()
    prop.SetRepresentationToSurface()
    prop.SetInterpolationToPhong()
    return actor


_SOURCES: dict = {}
#: pyvista's mappers swapped out of glyph actors, kept alive (their data released) so that
#: no object the page knows by its address gets a new one's (ViewScene.retire)
_SWAPPED: list = []


def _source(kind: str):
    """The glyph meshes, made once (the same mesh at every frame: its arrays' hashes do
    not change, so the page keeps them)."""
    import pyvista as pv

    if kind not in _SOURCES:
        if kind == "sphere":
            _SOURCES[kind] = pv.Sphere(radius=0.5, theta_resolution=SPHERE_RES[0],
                                       phi_resolution=SPHERE_RES[1])
        else:       # unit length along x, unit diameter
            _SOURCES[kind] = pv.Cylinder(center=(0.0, 0.0, 0.0), direction=(1.0, 0.0, 0.0),
                                         radius=0.5, height=1.0, resolution=STICK_RES,
                                         capping=True)
    return _SOURCES[kind]


def sphere_actor(pl, part, name: str, scalars=None, **kw):
    """The beads of vertex ``part`` as spheres of their radius, glyphed, in plotter ``pl``
    (``kw``: :meth:`pyvista.Plotter.add_mesh`'s colour, colour map, limits and colour bar
    arguments, as for :func:`workbench.render._spheres`)."""
    import pyvista as pv

    pts = pv.PolyData(np.ascontiguousarray(part.points, dtype=np.float32))
    pts.point_data[SCALE] = (2.0 * part.point_data["radius"]).astype(np.float32)
    if scalars is not None:
        pts.point_data[scalars] = np.asarray(part.point_data[scalars], np.float32)
    return _glyph_actor(pl, pts, _source("sphere"), name, scalars, kw)


def stick_actor(pl, part, values, radius, mask, name: str, scalars=None, **kw):
    """The line cells of ``part`` where ``mask`` as cylinders of per-line ``radius`` [m],
    glyphed, carrying ``values`` as the point array ``"value"`` (shown when ``scalars``
    is ``"value"``); ``kw`` as for :func:`sphere_actor`.  ``None`` when no line is shown
    (as :func:`workbench.render._tube_lines`)."""
    import pyvista as pv

    idx = np.flatnonzero(mask)
    if idx.size == 0:
        return None
    ends = part.points.reshape(-1, 2, 3)[idx]
    d = ends[:, 1] - ends[:, 0]
    length = np.linalg.norm(d, axis=1)
    pts = pv.PolyData(np.ascontiguousarray(0.5 * (ends[:, 0] + ends[:, 1]), np.float32))
    # a zero-length segment keeps the x axis (both VTK and vtk.js leave it so)
    pts.point_data[ORIENT] = np.where(length[:, None] > 0, d, [1.0, 0.0, 0.0]).astype(
        np.float32)
    r2 = 2.0 * np.asarray(radius, float)[idx]
    pts.point_data[SCALE] = np.column_stack([length, r2, r2]).astype(np.float32)
    pts.point_data["value"] = np.asarray(values, np.float32)[idx]
    return _glyph_actor(pl, pts, _source("stick"), name, scalars, kw, by_components=True)
