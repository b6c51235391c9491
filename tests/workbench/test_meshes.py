"""workbench.meshes: the arrays of each part equal the engine's; walls; PolyData wrappers."""
from __future__ import annotations

import numpy as np
import pytest

from engine import Scene, laws, run
from workbench import meshes

from .scenes import texsol_cylinder


@pytest.fixture(scope="module")
def scene():
    return texsol_cylinder()


def test_bead_part(scene):
    model, state, _ = scene
    p = meshes.bead_part(model, state)
    ids = model.sphere_ids
    np.testing.assert_array_equal(p.points, state.position[ids])
    np.testing.assert_array_equal(p.point_data["radius"], model.body_radius[ids])
    np.testing.assert_array_equal(p.point_data["velocity"], state.velocity[ids])
    wire = np.isin(ids, np.concatenate([model.link_i, model.link_j]))
    np.testing.assert_array_equal(p.point_data["kind"], wire.astype(int))
    assert p.point_data["kind"].sum() == len(np.unique(model.link_i))
    np.testing.assert_array_equal(p.point_data["group"], model.body_group[ids])
    assert p.cell_type == "vertex" and p.n_cells == ids.size


def test_wire_part(scene):
    model, state, _ = scene
    p = meshes.wire_part(model, state)
    links = state.links
    np.testing.assert_array_equal(p.cell_data["tension"], links.tension)
    np.testing.assert_array_equal(p.cell_data["broken"], links.broken.astype(int))
    np.testing.assert_array_equal(p.points[p.cells[:, 0]], state.position[links.i])
    np.testing.assert_array_equal(p.points[p.cells[:, 1]], state.position[links.j])
    np.testing.assert_allclose(p.cell_data["strain"], links.length / model.link_ref_length - 1)
    assert np.all(links.tension > 0)  # the ring is taut in this scene


def test_contact_part_forces_and_kinds(scene):
    model, state, _ = scene
    p = meshes.contact_part(model, state)
    c = state.contacts
    np.testing.assert_array_equal(p.cell_data["normal_force"], c.normal_force)
    f = c.force
    ft = np.linalg.norm(f - c.normal_force[:, None] * c.normal, axis=1)
    np.testing.assert_allclose(p.cell_data["tangential_force"], ft, rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(np.hypot(p.cell_data["normal_force"], p.cell_data["tangential_force"]),
                               np.linalg.norm(f, axis=1), rtol=1e-9)
    kind = p.cell_data["kind"]
    wall = model.body_kind[c.j] != 0
    bk = meshes.bead_kind(model)
    assert np.all(kind[wall] == meshes.CONTACT_WALL)
    expect = (bk[c.i] + bk[c.j])[~wall]
    np.testing.assert_array_equal(kind[~wall], expect)
    # this scene has sand-sand, sand-wire and wall contacts
    assert {0, 1, 3} <= set(kind.tolist())


def test_no_contacts_before_first_step():
    model, state, _ = texsol_cylinder(n_sand=20, wire_beads=8, steps=0)
    assert meshes.contact_part(model, state) is None
    assert meshes.contacts(model, state).n_cells == 0


def test_cylinder_walls(scene):
    model, state, cyl = scene
    p = meshes.wall_part(model, state, resolution=24)
    # side 2 x 24 triangles, bottom cap 24, no top cap
    assert p.n_cells == 3 * 24 and set(p.cell_data["sub"].tolist()) == {0, 1}
    r = np.hypot(p.points[:, 0], p.points[:, 1])
    side = np.unique(p.cells[p.cell_data["sub"] == 0])
    np.testing.assert_allclose(r[side], cyl.radius)
    assert p.points[:, 2].min() == 0.0
    np.testing.assert_allclose(p.points[:, 2].max(), cyl.height)


def test_box_planes_are_clipped_to_an_open_box():
    s = Scene()
    lo, hi = np.array([0.0, 0.0, 0.0]), np.array([4e-3, 3e-3, 5e-3])
    s.add_box(lo, hi)
    s.add_spheres([[2e-3, 1.5e-3, 1e-3]], 1e-3, density=2650.0)
    s.interact("sand", "wall", laws.Coulomb(mu=0.5))
    model, state = s.compile(dt=1e-4)
    p = meshes.wall_part(model, state, margin=0.0)
    assert p.n_cells == 5 * 2  # five rectangles, two triangles each
    np.testing.assert_allclose(p.points.min(axis=0), lo, atol=1e-15)
    np.testing.assert_allclose(p.points.max(axis=0), hi, atol=1e-15)
    # every triangle lies on its plane
    for w in model.wall_ids:
        tri = p.cells[p.cell_data["body_id"] == w]
        d = (p.points[tri.ravel()] - state.position[w]) @ model.body_axis[w]
        np.testing.assert_allclose(d, 0.0, atol=1e-15)


def test_pictures_are_framed_without_the_grains_that_fell_off():
    """A grain more than its diameter below a floor of fixed beads (one that rolled off the
    slope's rubber floor and fell) is left out of the bounds the camera frames; grains on
    the floor, or any grain without gravity, are not."""
    r = 0.5e-3
    for g, out in (((0, 0, -9.81), True), ((0, 0, 0), False)):
        s = Scene(gravity=g)
        s.fix(s.add_spheres([[x, 0.0, -r] for x in (-2e-3, 0.0, 2e-3)], r, density=1000.0,
                            group="floor"))
        s.add_spheres([[0, 0, r], [1e-3, 0, 3 * r], [0, 0, -0.2]], r, density=2650.0)
        s.interact("sand", "floor", laws.Coulomb(mu=0.5))
        s.interact("sand", "sand", laws.Coulomb(mu=0.5))
        s.interact("floor", "floor", None)
        model, state = s.compile(dt=1e-4)
        assert meshes.fallen(model, state).tolist() == [False] * 5 + [out]
        lo, hi = meshes.scene_bounds(model, state)
        assert lo[2] == pytest.approx(-2 * r if out else -0.2 - r)
        assert hi[2] == pytest.approx(4 * r)


def test_polydata_wrappers_carry_the_same_arrays(scene):
    pytest.importorskip("pyvista")
    model, state, _ = scene
    mb = meshes.scene(model, state)
    for name, part in (("beads", meshes.bead_part(model, state)),
                       ("wire", meshes.wire_part(model, state)),
                       ("contacts", meshes.contact_part(model, state)),
                       ("walls", meshes.wall_part(model, state))):
        poly = mb[name]
        assert poly.n_points == part.n_points and poly.n_cells == part.n_cells
        for k, v in {**part.point_data}.items():
            np.testing.assert_array_equal(poly.point_data[k], v)
        for k, v in part.cell_data.items():
            np.testing.assert_array_equal(poly.cell_data[k], v)
    assert mb["wire"].n_lines == len(state.links)
    assert mb["walls"].is_all_triangles


def test_brittle_wire_broken_flag():
    s = Scene(gravity=(0.0, 0.0, -9.81))
    beads = s.add_wire([[0, 0, 0], [0, 0, -3e-3], [0, 0, -6e-3]], radius=1e-3, density=2000.0,
                       law=laws.BrittleElasticWire(stiffness=1.0, max_tension=1e-4))
    s.interact("wire", "wire", None)
    s.fix(beads[:1])
    model, state = s.compile(dt=1e-4)
    run(model, state, 50, progress=False)
    p = meshes.wire_part(model, state)
    assert p.cell_data["broken"].tolist() == [1, 0]
    assert meshes.wall_part(model, state) is None
