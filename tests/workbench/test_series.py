"""SeriesWriter: PVD timesteps, sphere VTUs and contact-line VTUs of a short run."""
from __future__ import annotations

import subprocess
import sys

import meshio
import numpy as np
import pytest

from engine import Scene, laws, run
from engine.step import CallbackWriter
from workbench.series import SeriesWriter, read_pvd

R = 1e-3  # [m]


def _scene():
    """Five spheres on a plane: a row of three touching ones, one on top of the row
    (sphere–sphere contacts) and one falling from 2 mm (contacts appear during the run)."""
    s = Scene(gravity=(0.0, 0.0, -9.81))
    s.add_plane(point=(0, 0, 0), normal=(0, 0, 1), group="wall")
    radii = np.array([R, 0.9 * R, R, 0.8 * R, 1.1 * R])
    x0, x1 = 0.0, R + 0.9 * R
    x2 = x1 + 0.9 * R + R
    z_top = R + np.sqrt((R + 0.8 * R) ** 2 - (0.5 * (x1 - x0)) ** 2) * 1.001
    centers = [[x0, 0, R], [x1, 0, 0.9 * R], [x2, 0, R], [0.5 * (x0 + x1), 0, z_top],
               [6 * R, 0, 2e-3 + 1.1 * R]]
    s.add_spheres(centers, radii, density=2650.0, group="sand")
    s.interact("sand", "sand", laws.Coulomb(mu=0.5))
    s.interact("sand", "wall", laws.Coulomb(mu=0.5))
    return s.compile(dt=1e-3, theta=0.5, tol=1e-6, max_iter=500)


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    out = tmp_path_factory.mktemp("series")
    model, state = _scene()
    writer = SeriesWriter(out, every=5, name="fall")
    times, normal_forces = [], []

    def record(model, state):
        times.append(state.time)
        normal_forces.append(state.contacts.normal_force.copy())

    summary = run(model, state, 20, writers=[writer, CallbackWriter(record, trigger=5)],
                  progress=False)
    return out, writer, model, state, summary, times, normal_forces


def test_pvd_timesteps_are_state_times(result):
    out, writer, model, state, summary, times, _ = result
    assert summary.steps == 20 and writer.frames == 5     # the start state, then 5 ... 20
    entries = read_pvd(writer.pvd_path)
    spheres = [e for e in entries if e["part"] == 0]
    assert [e["timestep"] for e in spheres] == [0.0, *times]  # exact: written with repr
    assert all(e["file"].is_file() for e in entries)
    # each timestep has both parts (the start's contacts part is empty)
    assert [e["timestep"] for e in entries if e["part"] == 1] == [0.0, *times]


def test_sphere_vtu(result):
    out, writer, model, state, *_ = result
    entries = [e for e in read_pvd(writer.pvd_path) if e["part"] == 0]
    ids = model.sphere_ids
    for e in entries:
        mesh = meshio.read(e["file"])
        assert mesh.points.shape == (ids.size, 3)
        np.testing.assert_array_equal(mesh.point_data["radius"], model.body_radius[ids])
        np.testing.assert_array_equal(mesh.point_data["group"], model.body_group[ids])
        assert mesh.cells[0].type == "vertex" and len(mesh.cells[0].data) == ids.size
    last = meshio.read(entries[-1]["file"])
    np.testing.assert_array_equal(last.points, state.position[ids])
    np.testing.assert_array_equal(last.point_data["velocity"], state.velocity[ids])


def test_contact_lines_last_frame(result):
    out, writer, model, state, _, _, normal_forces = result
    entries = [e for e in read_pvd(writer.pvd_path) if e["part"] == 1]
    mesh = meshio.read(entries[-1]["file"])
    c = state.contacts
    assert len(c) > 0 and np.any(model.body_kind[c.j] == 0) and np.any(model.body_kind[c.j] != 0)
    fn = mesh.cell_data["normal_force"][0]
    np.testing.assert_allclose(fn, c.normal_force, rtol=1e-12, atol=0.0)
    np.testing.assert_allclose(fn, normal_forces[-1], rtol=1e-12, atol=0.0)
    assert mesh.cells[0].type == "line" and len(mesh.cells[0].data) == len(c)
    # lines start at sphere i; end at sphere j, or at the contact point on a wall
    p = mesh.points[mesh.cells[0].data]
    np.testing.assert_array_equal(p[:, 0], state.position[c.i])
    wall = model.body_kind[c.j] != 0
    np.testing.assert_array_equal(p[~wall, 1], state.position[c.j[~wall]])
    np.testing.assert_array_equal(p[wall, 1], c.point[wall])


def test_writer_rejects_bad_every(tmp_path):
    with pytest.raises(ValueError, match="every"):
        SeriesWriter(tmp_path, every=0)


def test_import_workbench_is_cheap():
    code = ("import sys, workbench; "
            "heavy = [m for m in ('vtk', 'pyvista', 'vtkmodules', 'meshio', 'matplotlib') "
            "if m in sys.modules]; assert not heavy, heavy; "
            "workbench.series; assert 'vtk' not in sys.modules and 'pyvista' not in sys.modules")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_wire_links_are_written_with_tension_and_broken_flag(tmp_path):
    """Part 2: one line per link, tension equal to state.links.tension, broken flag."""
    s = Scene(gravity=(0.0, 0.0, -9.81))
    beads = s.add_wire([[0, 0, 0], [0, 0, -3e-3], [0, 0, -6e-3]], radius=1e-3, density=2000.0,
                       law=laws.BrittleElasticWire(stiffness=1.0, max_tension=1e-4))
    s.interact("wire", "wire", None)
    s.fix(beads[:1])
    model, state = s.compile(dt=1e-4)
    writer = SeriesWriter(tmp_path, every=10, name="w")
    run(model, state, 200, writers=[writer], progress=False)
    wires = [e for e in read_pvd(writer.pvd_path) if e["part"] == 2]
    assert len(wires) == 21                                  # the start, then every 10 steps
    mesh = meshio.read(wires[-1]["file"])
    lines = mesh.cells_dict["line"]
    assert lines.shape == (2, 2)
    np.testing.assert_array_equal(mesh.cell_data["tension"][0], state.links.tension)
    np.testing.assert_array_equal(mesh.cell_data["broken"][0], state.links.broken.astype(int))
    assert state.links.broken[0]  # 2 beads of 8.4e-5 N hang on link 0: it broke


def test_walls_part_and_new_arrays(result):
    """Part 3 (walls) in every frame; contact lines carry ft and kind; beads carry kind."""
    out, writer, model, state, *_ = result
    entries = read_pvd(writer.pvd_path)
    walls = [e for e in entries if e["part"] == 3]
    assert [e["timestep"] for e in walls] == [e["timestep"] for e in entries if e["part"] == 0]
    mesh = meshio.read(walls[-1]["file"])
    assert mesh.cells[0].type == "triangle"
    assert set(mesh.cell_data["body_id"][0].tolist()) == set(model.wall_ids.tolist())
    np.testing.assert_allclose(mesh.points[:, 2], 0.0)  # the floor plane z = 0
    lines = meshio.read([e for e in entries if e["part"] == 1][-1]["file"])
    c = state.contacts
    ft = np.linalg.norm(c.force - c.normal_force[:, None] * c.normal, axis=1)
    np.testing.assert_allclose(lines.cell_data["tangential_force"][0], ft, rtol=1e-12, atol=1e-18)
    wall = model.body_kind[c.j] != 0
    np.testing.assert_array_equal(lines.cell_data["kind"][0], np.where(wall, 3, 0))
    beads = meshio.read([e for e in entries if e["part"] == 0][-1]["file"])
    np.testing.assert_array_equal(beads.point_data["kind"], 0)  # sand only


def test_writer_options(tmp_path):
    model, state = _scene()
    run(model, state, 3, progress=False)
    w = SeriesWriter(tmp_path, name="z", walls=False, compression="zlib")
    w.write(model, state)
    parts = sorted({e["part"] for e in read_pvd(w.pvd_path)})
    assert parts == [0, 1]
    raw = SeriesWriter(tmp_path / "raw", name="z")
    raw.write(model, state)
    a, b = meshio.read(tmp_path / "z_000000.vtu"), meshio.read(tmp_path / "raw" / "z_000000.vtu")
    np.testing.assert_array_equal(a.points, b.points)
    with pytest.raises(ValueError, match="compression"):
        SeriesWriter(tmp_path, compression="gzip")


def test_frame_without_contacts_keeps_its_contacts_part(tmp_path):
    """Before the first step there are no contact forces: part 1 is still written (no
    points, no cells, every array), so all frames have the same parts."""
    model, state = _scene()
    w = SeriesWriter(tmp_path, name="s")
    w.write(model, state)
    entries = read_pvd(w.pvd_path)
    assert [e["part"] for e in entries] == [0, 1, 3]
    text = entries[1]["file"].read_text()
    assert 'NumberOfPoints="0" NumberOfCells="0"' in text
    for name in ("normal_force", "tangential_force", "force", "kind"):
        assert f'Name="{name}"' in text
    assert 'name="contacts"' in w.pvd_path.read_text()


@pytest.mark.parametrize("compression", [None, "zlib", "lzma"])
def test_field_data_read_back_exactly(tmp_path, compression):
    """Every part of a frame carries step, time, the group ids by name and the caller's
    fields, stored in binary (raw or compressed as the file's arrays are): meshio reads the
    very same numbers back, NaN included."""
    model, state = _scene()
    run(model, state, 3, progress=False)
    w = SeriesWriter(tmp_path, name="f", compression=compression)
    sigma = np.arange(9.0).reshape(3, 3) / 7.0
    w.write(model, state, fields={"stress": sigma, "axial_strain": np.nan, "stage": 1})
    for e in read_pvd(w.pvd_path):
        fd = {k: np.ravel(v) for k, v in meshio.read(e["file"]).field_data.items()}
        assert fd["step"].tolist() == [state.step] and fd["time"].tolist() == [state.time]
        assert {k: v.tolist() for k, v in fd.items() if k.startswith("group:")} == \
            {f"group:{g}": [i] for i, g in enumerate(model.group_names)}
        assert fd["stress"].tolist() == sigma.ravel().tolist()
        assert np.isnan(fd["axial_strain"]).all() and fd["stage"].tolist() == [1]
    with pytest.raises(ValueError, match=r"fields\['label'\]: field data are numbers"):
        w.write(model, state, fields={"label": "start"})


def test_state_script_is_written_beside_the_pvd(tmp_path):
    """close() writes open_in_paraview.py with the colour limits of the frames written."""
    model, state = _scene()
    w = SeriesWriter(tmp_path, every=1, name="s")
    w.write(model, state)
    run(model, state, 5, writers=[w], progress=False)
    w.close()
    text = (tmp_path / "open_in_paraview.py").read_text()
    assert "PVD = 's.pvd'" in text
    compile(text, "open_in_paraview.py", "exec")        # valid Python
    fmax = w.ranges[("contacts", "normal_force")][1]
    assert fmax > 0 and repr(fmax) in text
    assert not (tmp_path / "x").exists()
    off = SeriesWriter(tmp_path / "x", name="s", state_script=False)
    off.write(model, state)
    off.close()
    assert not (tmp_path / "x" / "open_in_paraview.py").exists()


def test_a_shorter_series_replaces_an_older_one_of_the_same_name(tmp_path):
    """Writing a series where an older, longer one of the same name lies leaves no frame of
    the older one behind (its VTUs would look like the new series' last frames), says so
    in a warning (three parts a frame here: beads, contacts, walls), and touches no other
    series or file of the folder."""
    model, state = _scene()
    w = SeriesWriter(tmp_path, name="s")
    for _ in range(3):
        w.write(model, state)
    other = SeriesWriter(tmp_path, name="t")
    other.write(model, state)
    (tmp_path / "s_notes.txt").write_text("mine")
    with pytest.warns(UserWarning, match=r"replaced the older series 's' there \(9 VTU"):
        again = SeriesWriter(tmp_path, name="s")
        again.write(model, state)
    names = sorted(p.name for p in tmp_path.iterdir())
    assert [n for n in names if n.startswith("s_")] == [
        "s_000000.vtu", "s_contacts_000000.vtu", "s_notes.txt", "s_walls_000000.vtu"]
    assert len(read_pvd(again.pvd_path)) == 3
    assert "t_000000.vtu" in names and len(read_pvd(other.pvd_path)) == 3
