"""What a test starts from (issue 30 §1-2, engine.experiments.start): a prepared sample, an
end state, the paper's whole preparation; the prestrain set at the loading; the layer-crown
confinement."""

import warnings

import numpy as np
import pytest

from engine import Scene, io, laws
from engine.drivers import Confinement, LayerCrown
from engine.experiments import (box_triaxial, cylinder_triaxial, gravity_deposit,
                                slope_deposit)
from engine.experiments.start import from_state, start_of, state_of
from engine.experiments.triaxial import _prestrained, deposit_history
from engine.prep import Box, Cylinder, box_sample, cylinder_sample, slope_sample

QUIET = dict(progress=False)
#: The cylinder and box tests at their smallest useful size, loaded a little.
CYL = dict(axial_strain=0.005, **QUIET)
BOX = dict(axial_strain=0.003, **QUIET)
#: The deposit the paper preparation runs for a cylinder test with the test's defaults.
CYL_DEPOSIT = dict(dt=5e-5, tol=3e-4, mu_wall=0.5, steps=6000, **QUIET)


def curves(r):
    return np.concatenate([r.deviator, r.mean_stress, r.volumetric_strain,
                           r.wire_equivalent, r.time])


@pytest.fixture(scope="module")
def deposit(tmp_path_factory):
    """The deposit the paper preparation runs for the cylinder test, run apart."""
    d = tmp_path_factory.mktemp("deposit")
    return gravity_deposit(sample=cylinder_sample(0.05, seed=0), history=str(d / "dep.h5"),
                           **CYL_DEPOSIT)


@pytest.fixture(scope="module")
def paper_cyl(tmp_path_factory, deposit):
    """The cylinder test with the paper preparation, and the same deposit run apart."""
    d = tmp_path_factory.mktemp("paper")
    r = cylinder_triaxial(0.05, preparation="paper", history=str(d / "c.h5"), **CYL)
    return r, deposit, d


@pytest.mark.slow
def test_a_given_sample_runs_as_the_tests_own(tmp_path):
    """The sample the test would build, given: the same run, bit for bit (cylinder, box,
    slope)."""
    own = cylinder_triaxial(0.05, history=str(tmp_path / "a.h5"), **CYL)
    given = cylinder_triaxial(sample=cylinder_sample(0.05, seed=0),
                              history=str(tmp_path / "b.h5"), **CYL)
    assert np.array_equal(curves(own), curves(given))
    assert given.params["sample"] == "a cylinder sample (engine.prep)"
    own = box_triaxial(0.05, history=str(tmp_path / "c.h5"), **BOX)
    given = box_triaxial(sample=box_sample(0.05, seed=0), history=str(tmp_path / "d.h5"),
                         **BOX)
    assert np.array_equal(curves(own), curves(given))
    kw = dict(steps=60, record_every=10, **QUIET)
    own = slope_deposit(0.01, history=str(tmp_path / "e.h5"), **kw)
    smp = slope_sample(0.01, seed=0)
    x0 = smp.sand_centers.copy()
    given = slope_deposit(sample=smp, history=str(tmp_path / "f.h5"), **kw)
    assert np.array_equal(own.kinetic_energy, given.kinetic_energy)
    assert np.array_equal(smp.sand_centers, x0)      # the caller's sample is not moved


@pytest.mark.slow
def test_the_paper_preparation_is_the_deposit_then_the_test(paper_cyl):
    """preparation="paper" = gravity_deposit of the geometric sample in its mould, then the
    test from its end state: the same run bit for bit as the two done apart, from the
    result, from its history file or from (model, state)."""
    r, dep, d = paper_cyl
    start = r.extra["start"]
    assert start["deposit"]["at_rest"] and start["deposit"]["history"] == deposit_history(
        str(d / "c.h5"))
    assert r.params["preparation"] == "paper"
    for sample in (dep, dep.history, io.load(dep.history)):
        again = cylinder_triaxial(sample=sample, history=str(d / "again.h5"), **CYL)
        assert np.array_equal(curves(r), curves(again))
    # the deposit ended at rest in its mould: the mould carries the sample's weight
    assert dep.settlement > 0 and abs(dep.wall_force / dep.weight - 1) < 0.01


@pytest.mark.slow
def test_the_box_paper_preparation_is_the_deposit_then_the_test(tmp_path):
    r = box_triaxial(0.05, preparation="paper", deposit_steps=400,
                     history=str(tmp_path / "b.h5"), **BOX)
    dep = gravity_deposit(sample=box_sample(0.05, seed=0), dt=5e-5, tol=3e-4, mu_wall=0.0,
                          steps=400, history=str(tmp_path / "dep.h5"), **QUIET)
    again = box_triaxial(sample=dep, history=str(tmp_path / "again.h5"), **BOX)
    assert np.array_equal(curves(r), curves(again))


@pytest.mark.slow
def test_the_layered_preparation_is_the_paper_one_of_a_layered_sample(tmp_path):
    """preparation="layered" = the paper preparation of the sample built in layers
    (build="layered"): bit for bit; a sample given with it is refused in one line."""
    r = box_triaxial(0.05, preparation="layered", deposit_steps=400,
                     history=str(tmp_path / "l.h5"), **BOX)
    again = box_triaxial(sample=box_sample(0.05, seed=0, build="layered"), preparation="paper",
                         deposit_steps=400, history=str(tmp_path / "p.h5"), **BOX)
    assert r.params["preparation"] == "layered"
    assert np.array_equal(curves(r), curves(again))
    with pytest.raises(ValueError, match="preparation = 'layered'") as e:
        box_triaxial(sample=box_sample(0.05, seed=0), preparation="layered",
                     history=str(tmp_path / "x.h5"), **BOX)
    assert "\n" not in str(e.value)


def test_an_end_state_keeps_its_wire(deposit):
    """The test's model takes the state's link reference lengths (not its current lengths:
    slack links stay slack), laws and broken links, and its particles' velocities; the
    mould's walls are left behind."""
    dep = deposit
    m0, s0 = io.load(dep.history)
    st = start_of("cylinder_triaxial", Cylinder, (m0, s0), None, wire=True)
    sc = Scene()
    sand, beads = st.add_to(sc)
    sc.interact("sand", "sand", laws.Coulomb(mu=0.5))
    sc.interact("wire", "sand", laws.Coulomb(mu=0.3))
    sc.interact("wire", "wire", laws.Coulomb(mu=0.3))
    model, state = sc.compile(dt=5e-5)
    model = st.carry_over(model, state)
    ids = np.concatenate([sand, *beads])
    src = np.concatenate([m0.bodies_in("sand"), m0.bodies_in("wire")])
    np.testing.assert_array_equal(state.position[ids], s0.position[src])
    np.testing.assert_array_equal(state.vel6[ids], s0.vel6[src])
    np.testing.assert_array_equal(model.link_ref_length, m0.link_ref_length)
    np.testing.assert_array_equal(model.link_stiffness, m0.link_stiffness)
    g = np.linalg.norm(s0.position[m0.link_i] - s0.position[m0.link_j], axis=1)
    assert np.any(g < m0.link_ref_length)          # some links are slack after the deposit
    assert model.n_walls == 0 and isinstance(st.container, Cylinder)
    assert st.container.radius == cylinder_sample(0.05, seed=0).container.radius


def test_linked_beads_of_a_state_may_overlap():
    """A slack link lets its beads overlap (no contact between them): such a wire re-added
    with its reference lengths compiles; a new wire whose beads overlap is still refused,
    and so is an overlap between beads that touch."""
    c = np.array([[0, 0, 1e-3], [1.5e-4, 0, 1e-3], [3.5e-4, 0, 1e-3]])
    law = laws.ElasticWire(stiffness=1.0)
    sc = Scene()
    sc.add_wire(c, radius=1e-4, density=1400.0, law=law, reference_lengths=[2.2e-4, 2.2e-4])
    sc.interact("wire", "wire", laws.Coulomb(mu=0.3))
    model, state = sc.compile(dt=1e-5)
    np.testing.assert_array_equal(model.link_ref_length, [2.2e-4, 2.2e-4])
    with pytest.raises(ValueError, match="overlap their neighbour"):
        Scene().add_wire(c, radius=1e-4, density=1400.0, law=law)
    with pytest.raises(ValueError, match="overlap their neighbour"):
        Scene().add_wire(c, radius=1e-4, density=1400.0, law=law, neighbour_contact=True,
                         reference_lengths=[2.2e-4, 2.2e-4])
    with pytest.raises(ValueError, match="reference_lengths must be 2 lengths"):
        Scene().add_wire(c, radius=1e-4, density=1400.0, law=law, reference_lengths=[1e-4])


def test_bad_starts_are_refused_by_name(tmp_path, deposit):
    dep = deposit
    h = str(tmp_path / "x.h5")
    cases = [
        (lambda: cylinder_triaxial(sample=box_sample(0.05), history=h, **CYL),
         "needs a cylinder sample"),
        (lambda: box_triaxial(sample=cylinder_sample(0.05), history=h, **BOX),
         "needs a box sample"),
        (lambda: box_triaxial(sample=dep, history=h, **BOX), "cylinder mould"),
        (lambda: cylinder_triaxial(sample=cylinder_sample(0.05), wire=False, history=h, **CYL),
         "wire = False but the sample"),
        (lambda: cylinder_triaxial(sample=dep, wire_law=laws.RigidWire(), history=h, **CYL),
         "keep their own law"),
        (lambda: cylinder_triaxial(sample=dep, preparation="paper", history=h, **CYL),
         "an end state already"),
        (lambda: cylinder_triaxial(sample=cylinder_sample(0.05), wire_density=5e5, history=h,
                                   **CYL), "wire_density build"),
        (lambda: box_triaxial(sample=box_sample(0.05), bead_radius=1e-4, history=h, **BOX),
         "bead_radius build"),
        (lambda: cylinder_triaxial(sample=dep, bead_radius=2e-4, history=h, **CYL),
         "bead_radius build"),
        (lambda: cylinder_triaxial(preparation="wet", history=h, **CYL),
         r"preparation = 'wet'"),
        (lambda: cylinder_triaxial(confinement="rubber", history=h, **CYL),
         r"confinement = 'rubber'"),
        (lambda: cylinder_triaxial(wire_mode="spiral", history=h, **CYL),
         r"wire_mode = 'spiral'"),
        (lambda: cylinder_triaxial(wire_prestrain=1.5, history=h, **CYL), "wire_prestrain"),
        (lambda: cylinder_triaxial(wire_prestrain=0.01, neighbour_contact=True, history=h,
                                   **CYL), "pulls its beads into their contact"),
        (lambda: cylinder_triaxial(sample=42, history=h, **CYL), "got int"),
        (lambda: cylinder_triaxial(sample=str(tmp_path / "none.h5"), history=h, **CYL),
         "none.h5"),
        (lambda: gravity_deposit(sample=cylinder_sample(0.05), wire_density=1e5, history=h,
                                 **QUIET), "wire_density builds"),
    ]
    for call, match in cases:
        with pytest.raises((ValueError, FileNotFoundError), match=match):
            call()
    # a state without a "sand" group, and one with spheres of another group
    sc = Scene()
    sc.add_spheres([[0, 0, 1e-3]], 5e-4, density=2650.0, group="grains")
    sc.interact("grains", "grains", laws.Coulomb(mu=0.5))
    with pytest.raises(ValueError, match='no "sand" group'):
        from_state(*sc.compile(dt=1e-5), "a scene")
    sc = Scene()
    sc.add_spheres([[0, 0, 1e-3]], 5e-4, density=2650.0, group="sand")
    sc.add_spheres([[0, 0, 3e-3]], 5e-4, density=2650.0, group="rock")
    sc.interact("sand", "sand", laws.Coulomb(mu=0.5))
    sc.interact("sand", "rock", laws.Coulomb(mu=0.5))
    sc.interact("rock", "rock", laws.Coulomb(mu=0.5))
    with pytest.raises(ValueError, match="group\\(s\\) rock"):
        from_state(*sc.compile(dt=1e-5), "a scene")
    with pytest.raises(ValueError, match="must be an engine.prep.Sample"):
        state_of([1, 2])


@pytest.mark.slow
def test_a_users_own_scene_is_a_start(tmp_path):
    """A user's scene and state (sand poured in a box of planes, no wire) start the box test;
    the box is read from its side planes."""
    smp = box_sample(0.05, wire=False, seed=3)
    sc = Scene()
    smp.add_to(sc)
    lo, hi = smp.container.lo, smp.container.hi
    sc.add_plane(point=lo, normal=(0, 0, 1))
    for ax in (0, 1):
        n = np.zeros(3)
        n[ax] = 1
        sc.add_plane(point=lo, normal=n)
        sc.add_plane(point=hi, normal=-n)
    sc.interact("sand", "sand", laws.Coulomb(mu=0.5))
    sc.interact("sand", "wall", laws.Coulomb(mu=0.0))
    model, state = sc.compile(dt=5e-5, tol=3e-4)
    st = from_state(model, state, "a scene")
    assert isinstance(st.container, Box)
    np.testing.assert_allclose(st.container.lo[:2], lo[:2])
    np.testing.assert_allclose(st.container.hi[:2], hi[:2])
    r = box_triaxial(sample=(model, state), history=str(tmp_path / "b.h5"), **BOX)
    own = box_triaxial(sample=smp, history=str(tmp_path / "c.h5"), **BOX)
    # the same grains and walls: the same run
    assert np.array_equal(curves(r), curves(own))
    assert not r.params["wire"]


def test_the_prestrain_is_set_at_the_loading():
    """wire_prestrain ε₀: every link's reference length becomes g/(1+ε₀), g its length at
    the start of the loading, so an elastic wire's tension is k ε₀ there (Eq. 14-15)."""
    smp = cylinder_sample(0.05, seed=1)
    sc = Scene()
    k = 0.7
    smp.add_to(sc, wire_law=laws.ElasticWire(stiffness=k))
    sc.interact("sand", "sand", laws.Coulomb(mu=0.5))
    sc.interact("wire", "sand", laws.Coulomb(mu=0.3))
    sc.interact("wire", "wire", laws.Coulomb(mu=0.3))
    model, state = sc.compile(dt=5e-5)
    eps = 0.03
    m2 = _prestrained(model, state, eps)
    g = np.linalg.norm(state.position[m2.link_i] - state.position[m2.link_j], axis=1)
    T = m2.link_stiffness * np.maximum(g - m2.link_ref_length, 0) / m2.link_ref_length
    np.testing.assert_allclose(T, k * eps, rtol=1e-12)


@pytest.mark.slow
def test_a_prestrained_wire_starts_the_loading_in_tension(tmp_path):
    """With ε₀ = 2 % set at the loading, the wire's Weber stress over the first loading
    records is several times the unprestrained run's on the same sample."""
    kw = dict(axial_strain=0.003, record_every=5, **QUIET)
    plain = cylinder_triaxial(0.05, history=str(tmp_path / "a.h5"), **kw)
    pre = cylinder_triaxial(0.05, wire_prestrain=0.02, history=str(tmp_path / "b.h5"), **kw)
    assert pre.params["wire_prestrain"] == 0.02
    # the records up to the loading's start are the same run
    assert pre.wire_equivalent[0] == plain.wire_equivalent[0]
    assert np.mean(pre.wire_equivalent[1:4]) > 2 * np.mean(plain.wire_equivalent[1:4])


def test_layer_crown_loads():
    """LMGC90's layer crowns: in each layer the crown grains (centre farther than r_out −
    2 r_max) carry radial inward forces proportional to their radii, summing to p 2π r_out t;
    in all, p 2π R H."""
    smp = cylinder_sample(0.1, wire=False, seed=0)
    sc = Scene()
    sand = smp.add_to(sc)[0]
    sc.interact("sand", "sand", laws.Coulomb(mu=0.5))
    model, state = sc.compile(dt=5e-5)
    p = 2e4
    lc = LayerCrown(p, sand)
    area = lc.apply(model, state)
    f = state.load[sand]
    loaded = np.flatnonzero(np.linalg.norm(f, axis=1) > 0)
    np.testing.assert_array_equal(np.sort(lc.ids[lc.surface]), sand[loaded])
    x = state.position[sand]
    r = model.body_radius[sand]
    er = x[:, :2] / np.hypot(x[:, 0], x[:, 1])[:, None]
    fr = np.einsum("ka,ka->k", f[:, :2], er)
    np.testing.assert_allclose(f[:, 2], 0)
    assert np.all(fr[loaded] < 0)
    np.testing.assert_allclose(-fr.sum(), p * area, rtol=1e-12)
    np.testing.assert_allclose(area, 2 * np.pi * lc.radius * lc.height, rtol=1e-12)
    # within a layer, the force over the radius is one value
    z0 = (x[:, 2] - r).min()
    t = lc.height / max(1, round(lc.height / (2 * r.max())))
    lay = np.clip(((x[:, 2] - z0) / t).astype(int), 0, None)
    for k in np.unique(lay[loaded])[:5]:
        sel = loaded[lay[loaded] == k]
        ratio = -fr[sel] / r[sel]
        np.testing.assert_allclose(ratio, ratio[0], rtol=1e-12)
    # more grains are loaded than by the free-surface membrane (a crown 2 r_max deep)
    fs = Confinement(p, sand)
    fs.apply(model, state)
    assert lc.surface.size > fs.surface.size


def test_a_layer_crown_cylinder_reaches_the_pressure(tmp_path):
    r = cylinder_triaxial(0.05, confinement="layer_crown", history=str(tmp_path / "c.h5"),
                          **CYL)
    assert r.extra["isotropic"]["reached"] and r.params["confinement"] == "layer_crown"
    assert abs(r.mean_stress[0] / 15e3 - 1) < 0.05


def test_the_cylinders_bead_size_is_a_knob(tmp_path):
    """bead_radius builds the cylinder's wire of beads that size (as the box's), recorded."""
    r = cylinder_triaxial(0.05, bead_radius=2.7e-4, history=str(tmp_path / "c.h5"), **CYL)
    assert r.params["bead_radius"] == 2.7e-4
    model, _ = io.load(r.history, frame=0)
    np.testing.assert_array_equal(model.body_radius[model.bodies_in("wire")], 2.7e-4)


def test_an_orthotropic_wire_lies_in_layers():
    """wire_mode="orthotropic" walks Eq. (17): the links' directions stay near the
    horizontal plane (rise 5°), where Eq. (16)'s are spread over the sphere."""
    def mean_nz(s):
        d = np.vstack([np.diff(c, axis=0) for c in s.wire])
        return float(np.mean(np.abs(d[:, 2]) / np.linalg.norm(d, axis=1)))

    iso = cylinder_sample(0.1, seed=0)
    ortho = cylinder_sample(0.1, seed=0, wire_mode="orthotropic")
    assert mean_nz(ortho) < 0.1 < 0.3 < mean_nz(iso)
    assert len(ortho.wire) > 1                     # one wire per layer
