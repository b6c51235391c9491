"""Weber stress (Eq. 18) and best-fit strain (Eq. 19)."""
import numpy as np
import pytest

from engine import Scene, laws, run, step
from engine.analysis import best_fit_strain, weber_stress
from engine.contact import tangent_frame
from engine.prep import Box, Cylinder, TorusCell
from tests.helpers import G, box_pile


def _hand_assembly():
    """Spheres A (0,0,0) and B (2e-3,0,0) of radius 1e-3 touching, and a 2-bead wire far away;
    one step, then the contact and link impulses are overwritten with known values."""
    s = Scene(gravity=(0, 0, 0))
    s.add_spheres([[0, 0, 0], [2e-3, 0, 0]], 1e-3, density=1000.0)
    s.add_wire([[0, 0, 0.05], [0, 0, 0.053]], radius=1e-3, density=1000.0,
               law=laws.ElasticWire(stiffness=1.0))
    s.interact("sand", "sand", laws.Coulomb(mu=0.5))
    s.interact("wire", "wire", None)
    s.interact("wire", "sand", None)
    model, state = s.compile(dt=1e-4)
    step(model, state)
    c = state.contacts_buf
    assert c.count == 1 and (c.i[0], c.j[0]) == (0, 1)
    h = state.last_dt
    c.impulse[0] = (3.0 * h, 1.0 * h, -0.5 * h)  # [N·s]: f = 3 n + t − 0.5 s on sphere 0
    state.link_impulse[0] = 2.0 * h  # 2 N of tension
    return model, state


def test_weber_stress_of_a_hand_built_assembly():
    model, state = _hand_assembly()
    x = state.position
    n = (x[0] - x[1]) / np.linalg.norm(x[0] - x[1])
    fr = tangent_frame(*n)
    t, s = np.array(fr[:3]), np.array(fr[3:])
    f = 3 * n + t - 0.5 * s
    l_c = x[0] - x[1]
    m = state.link_normal[0]
    l_w = x[2] - x[3]
    region = Box((-0.01, -0.01, -0.01), (0.01, 0.01, 0.07))
    V = region.volume
    sand = -np.outer(l_c, f) / V
    wire = -np.outer(l_w, -2.0 * m) / V  # force on bead i: −T n
    r_sand = weber_stress(model, state, region=region, part="sand")
    r_wire = weber_stress(model, state, region=region, part="wire")
    r_all = weber_stress(model, state, region=region)
    np.testing.assert_allclose(r_sand.tensor, sand, rtol=0, atol=1e-12 * np.abs(sand).max())
    np.testing.assert_allclose(r_wire.tensor, wire, rtol=0, atol=1e-12 * np.abs(wire).max())
    np.testing.assert_allclose(r_all.tensor, r_sand.tensor + r_wire.tensor, rtol=0, atol=1e-15)
    # signs: the compressed contact gives σ_xx < 0, the wire in tension σ_zz > 0
    assert r_sand.tensor[0, 0] < 0 and r_wire.tensor[2, 2] > 0 and r_wire.principal[0] > 0
    assert (r_sand.n_contacts, r_sand.n_links, r_wire.n_links) == (1, 0, 1)
    assert r_all.mean_pressure == pytest.approx(-np.trace(r_all.tensor) / 3, rel=1e-14)
    dev = r_all.tensor - np.trace(r_all.tensor) / 3 * np.eye(3)
    assert r_all.equivalent == pytest.approx(np.linalg.norm(dev), rel=1e-14)


def test_pile_at_rest_stress_is_symmetric_and_its_zz_part_integrates_to_the_weight():
    """At rest: σ symmetric; V σ_zz = −W (z_G − z_floor) (frictionless side walls), from the
    equilibrium of every grain (the floor carries W at z_floor, gravity acts at z_G)."""
    model, state, _, radii = box_pile(200, 12e-3)
    run(model, state, 1500, progress=False)
    ids = model.sphere_ids
    m = model.body_mass[ids]
    W = m.sum() * G
    zg = m @ state.position[ids, 2] / m.sum()
    top = (state.position[ids, 2] + radii).max()
    res = weber_stress(model, state, region=Box((0, 0, 0), (12e-3, 12e-3, top)))
    sig = res.tensor
    assert np.abs(sig - sig.T).max() < 1e-3 * np.abs(sig).max()
    assert res.volume * sig[2, 2] == pytest.approx(-W * zg, rel=1e-3)
    assert res.mean_pressure > 0  # compressed


def test_weber_stress_bad_input():
    model, state = _hand_assembly()
    with pytest.raises(ValueError, match="part must be one of"):
        weber_stress(model, state, part="sandwich")
    with pytest.raises(ValueError, match="contains no sphere centre"):
        weber_stress(model, state, region=Box((1, 1, 1), (2, 2, 2)))
    fresh = state.copy()
    fresh.last_dt = 0.0  # as before the first step
    with pytest.raises(ValueError, match="run at least one step"):
        weber_stress(model, fresh)


@pytest.mark.parametrize("gradient", [
    [[1e-3, 2e-4, 0], [2e-4, -5e-4, 1e-4], [0, 1e-4, 3e-4]],     # symmetric (rotation-free)
    [[0, -1e-3, 0], [1e-3, 0, 0], [0, 0, 0]],                     # pure rotation
    [[2e-3, 5e-4, -1e-4], [0, 1e-3, 0], [3e-4, 0, -2e-3]],        # general
])
def test_best_fit_strain_recovers_an_affine_field(gradient):
    rng = np.random.default_rng(0)
    x0 = rng.uniform(-1e-2, 1e-2, (50, 3))
    E = np.asarray(gradient)
    x1 = x0 + x0 @ E.T + np.array([1e-3, -2e-3, 5e-4])  # affine + translation
    r = best_fit_strain(x0, x1)
    np.testing.assert_allclose(r.gradient, E, rtol=0, atol=1e-12)
    np.testing.assert_allclose(r.tensor, 0.5 * (E + E.T), rtol=0, atol=1e-12)
    assert r.volumetric == pytest.approx(np.trace(E), abs=1e-12)
    np.testing.assert_allclose(np.trace(r.deviatoric), 0, atol=1e-15)


def test_best_fit_strain_of_a_rigid_translation_is_zero():
    x0 = np.random.default_rng(1).uniform(0, 1e-2, (20, 3))
    r = best_fit_strain(x0, x0 + [3e-3, 0, -1e-3])
    np.testing.assert_allclose(r.tensor, 0, atol=1e-15)


def test_best_fit_strain_refuses_degenerate_sets():
    rng = np.random.default_rng(2)
    flat = np.column_stack([rng.uniform(0, 1, (10, 2)), np.zeros(10)])
    with pytest.raises(ValueError, match="rank 2 < 3"):
        best_fit_strain(flat, flat)
    with pytest.raises(ValueError, match="at least 4 non-coplanar particles, got 3"):
        best_fit_strain(flat, flat, ids=[0, 1, 2])


def test_torus_cells_tile_the_cylinder():
    cyl = Cylinder(radius=4.5e-3, height=20e-3)
    rs = np.linspace(0, cyl.radius, 6)
    zs = np.linspace(0, cyl.height, 9)
    cells = [TorusCell(rs[a], rs[a + 1], zs[b], zs[b + 1]) for a in range(5) for b in range(8)]
    assert sum(c.volume for c in cells) == pytest.approx(cyl.volume, rel=1e-14)
    p = np.random.default_rng(3).uniform([-4.5e-3, -4.5e-3, 0], [4.5e-3, 4.5e-3, 20e-3], (2000, 3))
    inside = cyl.contains(p)
    counts = sum(c.contains(p).astype(int) for c in cells)
    assert np.all(counts[inside] >= 1) and np.all(counts[~inside] == 0)


def test_force_network_of_a_column():
    """10 spheres stacked on a floor: 9 sphere–sphere contacts carrying the weight above."""
    from engine.analysis import force_network, wall_forces

    r = 5e-3
    s = Scene(gravity=(0, 0, -G))
    floor = s.add_plane(group="floor")
    s.add_spheres([[0, 0, r + 2 * r * k] for k in range(10)], r, density=2650.0)
    s.interact("sand", "sand", laws.Coulomb(mu=0.5))
    s.interact("sand", "floor", laws.Coulomb(mu=0.5))
    model, state = s.compile(dt=1e-4, tol=1e-10, max_iter=5000)
    run(model, state, 300, progress=False)
    net = force_network(model, state)
    mg = model.body_mass[1] * G
    assert len(net.normal_force) == 9
    np.testing.assert_allclose(np.sort(net.normal_force), mg * np.arange(1, 10), rtol=1e-6)
    assert net.mean_force == pytest.approx(5 * mg, rel=1e-6)
    assert net.strong.sum() == 4  # 6..9 mg are above the mean 5 mg
    assert net.coordination == pytest.approx(1.8)
    assert net.coordination_no_rattlers == pytest.approx(2.0)  # the 8 inner spheres
    assert np.sum(net.pdf * np.diff(net.pdf_edges)) == pytest.approx(1.0)
    np.testing.assert_allclose(wall_forces(model, state, [floor])[0], [0, 0, -10 * mg], rtol=1e-6,
                               atol=1e-12)


def test_toroidal_map_of_an_r_only_field_is_constant_in_z():
    """Closed wire rings whose tension depends on their radius only, the same rings in every
    z slab: each r column of the map is constant in z; cell volumes tile the cylinder."""
    from engine.analysis import toroidal_map

    R, H, nz = 8e-3, 12e-3, 4
    rb = 0.3e-3
    s = Scene(gravity=(0, 0, 0))
    rings = []
    for zc in (np.arange(nz) + 0.5) * H / nz:
        for rho in (2e-3, 6e-3):
            k = int(2 * np.pi * rho / (2.4 * rb))
            phi = np.linspace(0, 2 * np.pi, k, endpoint=False)
            pts = np.column_stack([rho * np.cos(phi), rho * np.sin(phi), np.full(k, zc)])
            rings.append((rho, s.add_wire(pts, radius=rb, density=1000.0, group="wire",
                                          law=laws.ElasticWire(stiffness=1.0), closed=True)))
    s.interact("wire", "wire", None)
    model, state = s.compile(dt=1e-4)
    step(model, state)
    h = state.last_dt
    tension = {2e-3: 1.0, 6e-3: 3.0}  # [N], a function of r only
    bead_rho = np.hypot(*state.position[model.link_i, :2].T)
    state.link_impulse[:] = np.where(bead_rho < 4e-3, tension[2e-3], tension[6e-3]) * h
    cyl = Cylinder(radius=R, height=H)
    tm = toroidal_map(model, state, cyl, n_r=2, n_z=nz, part="wire")
    assert tm.volume.sum() == pytest.approx(cyl.volume, rel=1e-14)
    for a in range(2):
        col = tm.stress[a]
        np.testing.assert_allclose(col, np.broadcast_to(col[0], col.shape), rtol=0,
                                   atol=1e-9 * np.abs(col).max())
    assert tm.equivalent[1, 0] > tm.equivalent[0, 0] > 0  # the outer, tighter rings
    # slabs: Eq. (18) is a sum over the region's particles, so a slab's stress is its cells'
    # volume-weighted mean; here the same in every slab
    from engine.analysis import weber_stress
    from engine.prep.containers import TorusCell

    slabs = tm.slab_stress()
    for b in range(nz):
        direct = weber_stress(model, state, region=TorusCell(0.0, R, tm.z_edges[b],
                                                              tm.z_edges[b + 1]), part="wire")
        np.testing.assert_allclose(slabs[b], direct.tensor, rtol=0,
                                   atol=1e-12 * np.abs(direct.tensor).max())
    eq = tm.slab_equivalent()
    np.testing.assert_allclose(eq, eq[0], rtol=1e-12)
    assert eq[0] > 0


def test_macro_stiffness_recovers_the_slope_of_a_noisy_line():
    from engine.analysis import macro_stiffness

    rng = np.random.default_rng(4)
    e = np.linspace(0, 0.01, 200)
    H = 4.4e3
    sig = H * e + 90.0 + rng.normal(0, 0.003 * H * 0.01, e.size)
    m = macro_stiffness(e, sig)
    assert m.H == pytest.approx(H, rel=0.01) and m.start == 0
    # a stiffer start (3H up to 0.2 %) is left out of the linear range
    knee = 0.002
    sig2 = np.where(e < knee, 3 * H * e, 3 * H * knee + H * (e - knee)) + rng.normal(0, 0.003 * H * 0.01, e.size)
    m2 = macro_stiffness(e, sig2, rel_tol=0.005)
    assert m2.H == pytest.approx(H, rel=0.01) and m2.start_point[0] >= knee * 0.9


def test_weber_mean_stress_equals_the_confining_pressure():
    """64 grains in a box whose three far walls are pressure-driven (p = 10 kPa on their
    current area), no gravity, relaxed: the Weber mean pressure of the sample equals p
    within 5 % (boundary equilibrium: the average stress equals the applied traction)."""
    from tests.helpers import settle

    rng = np.random.default_rng(5)
    n1, a, r = 4, 2.1e-3, 1e-3
    g = (np.arange(n1) + 0.5) * a
    pts = np.array([[x, y, z] for x in g for y in g for z in g]) + rng.uniform(-5e-5, 5e-5, (n1 ** 3, 3))
    L = n1 * a
    s = Scene(gravity=(0, 0, 0))
    s.add_spheres(pts, r * rng.uniform(0.9, 1.0, n1 ** 3), density=2650.0)
    w = s.add_box((0, 0, 0), (L, L, L), group="wall", top=True)  # floor, x-, x+, y-, y+, lid
    far = {0: w[2], 1: w[4], 2: w[5]}
    p = 1e4

    def area(axis):
        u, v = [k for k in range(3) if k != axis]
        return lambda model, state: state.position[far[u], u] * state.position[far[v], v]

    for axis, wall in far.items():
        s.drive(wall, pressure=p, area=area(axis), mass=1e-3)
    s.interact("sand", "sand", laws.Coulomb(mu=0.3))
    s.interact("sand", "wall", laws.Coulomb(mu=0.3))
    model, state = s.compile(dt=2e-5, tol=1e-5, max_iter=2000)
    settle(model, state, 1500, ids=np.concatenate([model.sphere_ids, list(far.values())]))
    res = weber_stress(model, state)  # region: the sample's bounding box = the wall box
    assert res.mean_pressure == pytest.approx(p, rel=0.05)
    assert np.all(res.principal < 0)  # compressed along every direction


def test_slope_profile_of_a_cone_and_floor_pressure_of_a_pile():
    """A cone of grains with a 30° flank: the linear fit of h(r) gives 30° within 2°.  Once
    settled on the floor, p(r) integrated over the annuli equals the floor reaction."""
    from engine.analysis import slope_profile

    r, angle = 0.5e-3, np.radians(30)
    H0 = 8e-3
    g = np.arange(-12, 13) * 2.05 * r
    pts = [(x, y, z) for x in g for y in g for z in np.arange(r, H0, 2.05 * r)
           if z + r <= H0 - np.tan(angle) * np.hypot(x, y) + 1e-12]
    s = Scene(gravity=(0, 0, -G))
    floor = s.add_plane(group="floor")
    s.add_spheres(np.asarray(pts), r, density=2650.0)
    s.interact("sand", "sand", laws.Coulomb(mu=0.6))
    s.interact("sand", "floor", laws.Coulomb(mu=0.6))
    model, state = s.compile(dt=1e-4, tol=1e-5, max_iter=2000)
    prof = slope_profile(model, state, floor=floor, r_max=H0 / np.tan(angle) * 0.9, degree=1,
                         n_bins=12)
    assert prof.max_slope_deg == pytest.approx(30.0, abs=2.0)
    run(model, state, 100, progress=False)
    prof = slope_profile(model, state, floor=floor, n_bins=12)
    area = np.pi * np.diff(prof.r_edges ** 2)
    c = state.contacts
    assert (prof.pressure * area).sum() == pytest.approx(c.normal_force[c.j == floor].sum(), rel=1e-12)


def test_max_slope_of_known_profiles():
    """max_slope: a straight heap gives its angle whatever the degree; a parabola h = a r²
    on [0, R] gives atan(2 a R) from degree 2 on; the 8th degree recovers an exact 8th-degree
    profile at millimetre radii (the fit is made on [-1, 1]); a line on a curved heap is
    gentler than its cubic; too few bins or a degree < 1 raise."""
    from engine.analysis import max_slope

    r = (np.arange(12) + 0.5) * 1e-3
    for deg in (1, 3, 8):
        fit, th = max_slope(r, 5e-3 - np.tan(np.radians(25.0)) * r, deg)
        assert th == pytest.approx(25.0, abs=1e-6)
    a = 40.0
    for deg in (2, 3, 8):
        fit, th = max_slope(r, a * r ** 2, deg, samples=1000)
        assert th == pytest.approx(np.degrees(np.arctan(2 * a * r[-1])), rel=1e-6)
        assert fit(r) == pytest.approx(a * r ** 2, abs=1e-12)
    c = np.array([3e-3, -0.5, 40.0, 3e3, -2e5, 1e7, -2e8, 1e9, 1e11])   # h = sum c_k r^k
    h = np.polynomial.polynomial.polyval(r, c)
    fit, th = max_slope(r, h, 8, samples=5000)
    d = np.polynomial.polynomial.polyval(np.linspace(r[0], r[-1], 5000),
                                         np.polynomial.polynomial.polyder(c))
    assert th == pytest.approx(np.degrees(np.arctan(np.abs(d).max())), rel=1e-6)
    curved = 3e-3 * (1 - (r / r[-1]) ** 4)
    assert max_slope(r, curved, 1)[1] < max_slope(r, curved, 3)[1] - 5
    holes = np.where(r < 4e-3, curved, np.nan)                 # 4 occupied bins
    assert max_slope(r, holes, 3)[1] > 0
    with pytest.raises(ValueError, match="4 occupied bins, need more than degree=4"):
        max_slope(r, holes, 4)
    with pytest.raises(ValueError, match="degree must be >= 1"):
        max_slope(r, curved, 0)


def test_boundary_measures():
    """Wall stress of a pile's floor = weight / area; box and cylinder strains of an imposed
    homogeneous deformation."""
    from engine.analysis import box_strain, cylinder_strain, wall_stress

    model, state, box, radii = box_pile(100, 10e-3)
    run(model, state, 1000, progress=False)
    W = model.body_mass[model.sphere_ids].sum() * G
    assert wall_stress(model, state, [box[0]], [1e-4])[0] == pytest.approx(W / 1e-4, rel=1e-3)

    b = box_strain((10e-3, 10e-3, 20e-3), (10.1e-3, 10.1e-3, 19e-3))
    assert b["axial"] == pytest.approx(-0.05) and b["strain"][0] == pytest.approx(0.01)
    assert b["volumetric"] == pytest.approx(1.01 ** 2 * 0.95 - 1)

    x0 = state.position.copy()
    x1 = x0.copy()
    x1[:, :2] *= 1.02  # radial stretch about the z axis through (0, 0)
    x1[:, 2] *= 0.97
    zero = cylinder_strain(model, x0 - [5e-3, 5e-3, 0], x0 + [0, 0, 2e-3] - [5e-3, 5e-3, 0])
    assert max(abs(zero["axial"]), abs(zero["radial"]), abs(zero["volumetric"])) < 1e-12
    cs = cylinder_strain(model, x0 - [5e-3, 5e-3, 0], x1 - [5.1e-3, 5.1e-3, 0])
    # the centres move by the imposed strain, the radii do not: the envelope strains lie
    # between 0 and the imposed values, at (extent of centres)/(extent of spheres) of them
    zc = x0[model.sphere_ids, 2]
    ext = np.ptp(zc) / ((zc + radii).max() - (zc - radii).min())
    assert cs["axial"] == pytest.approx(-0.03 * ext, rel=0.05)
    assert 0 < cs["radial"] < 0.02


def test_regions_volume_containment_and_bad_input():
    from engine.prep import Box, Sphere

    sp = Sphere(radius=2e-3, center=(1e-3, 0, 0))
    assert sp.volume == pytest.approx(4 / 3 * np.pi * 8e-9, rel=1e-14)
    assert sp.contains([[1e-3, 0, 1.99e-3], [1e-3, 0, 2.01e-3]]).tolist() == [True, False]
    with pytest.raises(ValueError, match="radius must be finite and > 0"):
        Sphere(radius=0.0)
    with pytest.raises(ValueError, match="Box needs hi > lo"):
        Box((0, 0, 0), (1, 0, 1))
    with pytest.raises(ValueError, match="r_in < r_out"):
        TorusCell(2e-3, 1e-3, 0, 1e-3)


def test_slope_profile_leaves_out_a_grain_that_fell_off_the_floor():
    """A grain below the rubber floor (it rolled off the edge and fell: one at z = -0.43 m
    gave a 89.5 deg slope through the outer bin) changes nothing in the profile."""
    from engine import Scene, laws
    from engine.analysis import slope_profile

    def profile(fallen):
        s = Scene(gravity=(0, 0, -9.81))
        rb = 0.3e-3
        g = np.arange(-8, 9) * 2 * rb
        fx, fy = np.meshgrid(g, g)
        floor = s.add_spheres(np.column_stack([fx.ravel(), fy.ravel(), np.full(fx.size, rb)]),
                              rb, density=1000.0, group="rubber")
        s.fix(floor)
        r = 0.25e-3
        heap = [(x, 0.0, 2 * rb + r + 2 * r * k) for x, k in ((0.0, 2), (0.0, 1), (0.0, 0),
                                                              (1.2e-3, 0), (2.4e-3, 0))]
        if fallen:
            heap.append((4.5e-3, 1e-3, -0.43))
        s.add_spheres(np.array(heap), r, density=2650.0)
        s.interact("sand", "sand", laws.Coulomb(mu=0.5))
        s.interact("sand", "rubber", laws.Coulomb(mu=0.5))
        s.interact("rubber", "rubber", None)
        model, state = s.compile(dt=1e-5)
        return slope_profile(model, state, floor=floor, r_max=4.8e-3, n_bins=4, n_sectors=1,
                             degree=1)

    a, b = profile(False), profile(True)
    assert np.array_equal(np.isnan(a.height), np.isnan(b.height))
    assert np.allclose(a.height[~np.isnan(a.height)], b.height[~np.isnan(b.height)])
    assert b.max_slope_deg == pytest.approx(a.max_slope_deg)


def test_solid_fraction_counts_each_spheres_part_inside():
    """A sphere inside counts whole, one centred on a base plane half (symmetry); one cut by
    the side agrees with a Monte Carlo count of its points inside (5e5 points: 2 SE about
    1.4e-3 of the sphere); the fraction is the volume inside over the cylinder's."""
    from engine.analysis import solid_fraction, sphere_volume_in_cylinder
    from engine.prep import Cylinder

    C = Cylinder(1.0, 2.0, (0.1, -0.2, 0.0))
    r = 0.1
    V = 4 / 3 * np.pi * r ** 3
    got = sphere_volume_in_cylinder([[0.1, -0.2, 1.0], [0.5, -0.2, 0.0], [3.0, 0.0, 1.0]],
                                    [r, r, r], C)
    assert got == pytest.approx([V, V / 2, 0.0], rel=1e-12, abs=1e-15)
    rng = np.random.default_rng(0)
    p = rng.uniform(-1, 1, (2_000_000, 3))
    p = 0.5 * p[(p * p).sum(1) <= 1][:500_000]
    for c in ([1.1, -0.2, 1.0], [0.1 + 0.6, -0.2 + 0.8, 1.9]):        # the side; side + top
        q = p + c
        inside = (np.hypot(q[:, 0] - 0.1, q[:, 1] + 0.2) <= 1.0) & (q[:, 2] >= 0) & \
            (q[:, 2] <= 2.0)
        v = sphere_volume_in_cylinder([c], [0.5], C)[0] / (4 / 3 * np.pi * 0.125)
        assert v == pytest.approx(inside.mean(), abs=3e-3)
    assert solid_fraction([[0.1, -0.2, 1.0]], [r], C) == pytest.approx(V / C.volume, rel=1e-12)


def test_encasement_of_a_ring():
    """Δσ₃ = T/(R s) of beads on a circle of radius R about the axis, and K_p Δσ₃."""
    from engine.analysis.wire import encasement

    R, s = 2e-3, 0.8e-3
    a = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    x = np.c_[0.3e-3 + R * np.cos(a), -0.1e-3 + R * np.sin(a), np.zeros(40)]
    e = encasement(np.full(40, 0.01), x, pitch=s, axis=(0.3e-3, -0.1e-3))
    assert e.radius == pytest.approx(R, rel=1e-12)
    assert e.confinement == pytest.approx(0.01 / (R * s), rel=1e-12)
    assert e.deviator_gain(3.0) == pytest.approx(3 * 0.01 / (R * s), rel=1e-12)
    with pytest.raises(ValueError, match="pitch"):
        encasement([0.01], x, pitch=0.0)
