"""The reinforcement study's controls: beads without links (LooseWire), the beads taken out
of a TexSol sample (after the geometric deposit, at the loading), and the one measurement
basis of the cylinder test (the membrane wraps grains and beads)."""

import numpy as np
import pytest

from engine import Scene, io, laws, run
from engine.experiments import cylinder_triaxial
from engine.experiments.start import from_sample, remove_group, without_wire
from engine.prep import cylinder_sample

G = 9.81
CYL = dict(axial_strain=0.005, progress=False)


def hanging_chain(law, n=12):
    """A chain of ``n`` beads in a horizontal line, its two end beads fixed."""
    s = Scene(gravity=(0.0, 0.0, -G))
    x = np.c_[np.arange(n) * 0.3e-3, np.zeros(n), np.full(n, 5e-3)]
    beads = s.add_wire(x, radius=0.135e-3, density=1400.0, group="wire", law=law)
    s.interact("wire", "wire", laws.Coulomb(mu=0.3))
    s.fix([beads[0], beads[-1]])
    return s.compile(dt=5e-5, theta=0.5, tol=1e-6, max_iter=1000)


def test_a_loose_wire_carries_exactly_no_force():
    """The elastic chain sags and pulls (T > 0); the loose one's links carry exactly 0 at
    every step and its free beads fall as in free fall: z0 − g t²/2, which the θ-method
    (θ = 0.5) integrates exactly under a constant force."""
    model, state = hanging_chain(laws.ElasticWire(stiffness=1.0))
    run(model, state, 200, progress=False)
    assert state.links.tension.max() > 1e-6
    model, state = hanging_chain(laws.LooseWire())
    z0 = state.position[1:-1, 2].copy()
    for _ in range(200):
        run(model, state, 1, progress=False)
        assert np.all(state.link_impulse == 0.0)
    t = state.time
    np.testing.assert_allclose(state.position[1:-1, 2], z0 - 0.5 * G * t * t, rtol=0,
                               atol=1e-15)
    assert np.all(state.links.tension == 0.0)


def test_loose_beads_keep_their_contacts():
    """A loose wire lying on a floor rests on it: the floor carries its weight (within the
    solver's tolerance), though its links carry nothing."""
    s = Scene(gravity=(0.0, 0.0, -G))
    r = 0.135e-3
    x = np.c_[np.arange(8) * 0.3e-3, np.zeros(8), np.full(8, r)]
    beads = s.add_wire(x, radius=r, density=1400.0, group="wire", law=laws.LooseWire())
    floor = s.add_plane(point=(0, 0, 0), normal=(0, 0, 1), group="wall")
    s.interact("wire", "wall", laws.Coulomb(mu=0.3))
    s.interact("wire", "wire", laws.Coulomb(mu=0.3))
    model, state = s.compile(dt=5e-5, theta=0.5, tol=1e-8, max_iter=1000)
    run(model, state, 50, progress=False)
    from engine.analysis import wall_forces

    weight = model.body_mass[beads].sum() * G
    assert wall_forces(model, state, [floor])[0, 2] == pytest.approx(-weight, rel=1e-6)
    assert np.all(state.link_impulse == 0.0)


def test_beads_removed_leave_the_mechanics():
    """After :func:`remove_group`, the beads touch nothing, pull nothing and do not move,
    while the grains fall on: a grain resting on a bead before falls freely after."""
    s = Scene(gravity=(0.0, 0.0, -G))
    r = 0.135e-3
    xb = np.c_[np.arange(6) * 0.3e-3, np.zeros(6), np.full(6, r)]
    beads = s.add_wire(xb, radius=r, density=1400.0, group="wire",
                       law=laws.ElasticWire(stiffness=1.0))
    grain = s.add_spheres([[0.75e-3, 0.0, 2 * r + 0.2e-3]], [0.2e-3], density=2650.0,
                          group="sand")
    s.add_plane(point=(0, 0, 0), normal=(0, 0, 1), group="wall")
    for a, b in (("wire", "wall"), ("wire", "wire"), ("wire", "sand"), ("sand", "wall")):
        s.interact(a, b, laws.Coulomb(mu=0.5))
    model, state = s.compile(dt=5e-5, theta=0.5, tol=1e-8, max_iter=1000)
    run(model, state, 100, progress=False)
    assert (np.isin(state.contacts.i, beads) & (state.contacts.j == grain[0])).any() or \
        (np.isin(state.contacts.j, beads) & (state.contacts.i == grain[0])).any()
    model = remove_group(model, state, "wire")
    xb0 = state.position[beads].copy()
    z0, t0 = state.position[grain[0], 2], state.time
    run(model, state, 40, progress=False)
    assert not np.isin(np.r_[state.contacts.i, state.contacts.j], beads).any()
    assert np.array_equal(state.position[beads], xb0)
    assert np.all(state.link_impulse == 0.0)
    t = state.time - t0
    assert state.position[grain[0], 2] == pytest.approx(z0 - 0.5 * G * t * t, abs=1e-12)


def test_beads_removed_after_the_deposit_leave_the_sand_where_it_was():
    smp = cylinder_sample(0.05, seed=3)
    st = without_wire(from_sample(smp))
    assert not st.has_wire and st.sample.wire == []
    assert np.array_equal(st.sample.sand_centers, smp.sand_centers)
    assert np.array_equal(st.sample.sand_radii, smp.sand_radii)
    # the same grain sizes as the sand sample of the seed
    assert np.array_equal(np.sort(st.sample.sand_radii),
                          np.sort(cylinder_sample(0.05, wire=False, seed=3).sand_radii))
    with pytest.raises(ValueError, match="remove_beads = 'after_deposit'.*without a wire"):
        without_wire(from_sample(cylinder_sample(0.05, wire=False)))


@pytest.fixture(scope="module")
def twins(tmp_path_factory):
    d = tmp_path_factory.mktemp("controls")
    out = {}
    for name, kw in (("wire", {}), ("loose", dict(wire_law=laws.LooseWire())),
                     ("at_loading", dict(remove_beads="at_loading")),
                     ("after_deposit", dict(remove_beads="after_deposit"))):
        out[name] = cylinder_triaxial(0.05, history=str(d / f"{name}.h5"), **kw)
    return out


@pytest.mark.slow
def test_a_wire_sample_and_its_loose_twin_are_measured_alike(twins):
    """The membrane wraps grains and beads: the TexSol sample and its loose-bead twin,
    prepared from one sample, start the loading on the same radius within 1 %, and their
    volume and solid fractions are those of all their particles."""
    a, b = twins["wire"].extra["start"], twins["loose"].extra["start"]
    assert b["radius"] == pytest.approx(a["radius"], rel=0.01)
    for s in (a, b):
        assert s["solid_fraction_all"] > s["solid_fraction"]
        assert 0.5 < s["core_solid_fraction"] < 0.7 and s["core_sand_fraction"] < \
            s["core_solid_fraction"]
        assert s["sand_outer_radius"] > 0.9 * s["radius"]
    assert np.all(twins["loose"].wire_stress == 0.0)
    assert b["taut_share"] == 0.0 and b["max_tension"] == 0.0
    assert twins["loose"].params["wire_law"] == "LooseWire(prestrain=0.0)"


@pytest.mark.slow
def test_beads_removed_at_the_loading_stay_out(twins):
    r = twins["at_loading"]
    assert r.params["remove_beads"] == "at_loading"
    # (the first row is the isotropic stage's last record, the beads still in)
    assert np.all(r.wire_stress[1:] == 0.0) and np.any(r.wire_stress[0] != 0.0)
    beads = io.load_model(r.history).bodies_in("wire")
    x = [f["position"][beads] for f in io.frame_arrays(r.history, ["position"])]
    assert np.array_equal(x[-1], x[-2])
    s = r.extra["start"]
    assert s["solid_fraction_all"] == s["solid_fraction"]
    # the same packing as the TexSol run's at the loading start (the runs share every step
    # before it), but for the beads
    assert s["radius"] == pytest.approx(twins["wire"].extra["start"]["radius"], rel=0.02)


@pytest.mark.slow
def test_beads_removed_after_the_deposit_give_a_sand_run(twins):
    r = twins["after_deposit"]
    assert r.params["wire"] is False and r.params["remove_beads"] == "after_deposit"
    assert "beads removed" in r.params["sample"] or "beads removed" in r.extra["start"]["source"]
    assert r.params["n_beads"] == 0


def test_bad_controls_are_refused_in_one_line():
    with pytest.raises(ValueError, match="remove_beads = 'at_loading'.*wire = False"):
        cylinder_triaxial(0.05, wire=False, remove_beads="at_loading", **CYL)
    with pytest.raises(ValueError, match="remove_beads"):
        cylinder_triaxial(0.05, remove_beads="sometimes", **CYL)


@pytest.fixture(scope="module")
def encased(tmp_path_factory):
    """The positive control at scale 0.1, seed 0: a column encased by a rigid helix (one
    d_min under the surface, pitch d_max) and its loose twin (the same packing and beads,
    no link force), loaded to 5 % (bench/control_helix.py's pair)."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "bench"))
    from control_helix import one_pair

    return one_pair(0.1, 0, laws.RigidWire(), 0.05, None, 15e3,
                    str(tmp_path_factory.mktemp("helix")))


@pytest.mark.slow
def test_an_encased_column_is_stronger_than_its_loose_twin(encased):
    """The helix's hoop tension confines the column: the encased column carries more q
    than its loose twin at the end and over the second half of the loading.  The twins
    start on membrane radii within 5 %: the helix is the sample's surface, and its loose
    beads settle inward in the isotropic stage (seen: 1.571 against 1.523 mm)."""
    r = encased
    assert r["start_radius"][1] == pytest.approx(r["start_radius"][0], rel=0.05)
    assert r["tension"] > 0 and r["window"]["dq"] > 0 and r["dq"] > 0


@pytest.mark.slow
def test_an_encased_column_gains_what_its_hoop_tension_predicts(encased):
    """Δσ₃ = T/(R s), Δq ≈ K_p Δσ₃ (K_p = σ₁/σ₃ of the loose column), within ±30 %, from
    the measured T and R over the second half of the loading.  Met since the triaxial
    tests take the position correction by default: 1.20 at scale 0.1 seed 0 (2026-12-08);
    without it the beads sank into the grains and the same run gave 1.7-1.9 (an expected
    failure until then; docs/reinforcement.md, 'The positive control')."""
    assert 0.7 <= encased["window_ratio"]["ring"] <= 1.3, encased["window_ratio"]


@pytest.mark.slow
def test_a_ring_at_rest_confines_its_core_as_its_closed_form_says(tmp_path):
    """The positive control without a failure's noise (bench/bench_overlap.py's helix at
    rest, scale 0.1, seed 0): an elastic helix one d_max deep, prestrained 5 % at the
    loading and let settle, against its loose twin; the sand's radial stress in the core
    rises by T/(R s) of the ring's own tension within ±30 %, with the position correction
    (overlap_tol = 0.005: seen 0.86; without it the beads sink into the grains and the
    ring relaxes: 0.69 on this seed, 0.34-0.80 on seeds 0-2)."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "bench"))
    from bench_overlap import helix

    r = helix(0, 0.005, str(tmp_path))
    assert r["t_over_rs"] > 0
    assert 0.7 <= r["ratio"] <= 1.3, r


@pytest.mark.slow
def test_a_wire_made_taut_at_the_loading_does_not_lengthen(tmp_path):
    """``wire_taut_at_loading``: every link's reference length becomes its length at the
    start of the loading, so a rigid wire's links can only shorten from there (g <= L,
    Eq. 12): over 1 % of axial strain no link lengthens by more than 5 % of the bead spacing
    2 r_w + g_w (the velocity-level constraint at tol 3e-4 drifts by about 10 µm over these
    110 steps); without the reset the slack links of the same run lengthen by more than
    20 % of it."""
    def stretch(taut):
        r = cylinder_triaxial(0.05, wire_law=laws.RigidWire(), wire_taut_at_loading=taut,
                              axial_strain=0.01, frames=10, history=str(tmp_path / f"{taut}.h5"),
                              progress=False)
        assert r.params["wire_taut_at_loading"] is taut
        m = io.load_model(r.history)
        steps, _ = io.frame_index(r.history)
        k0 = int(np.flatnonzero(steps == r.step[0])[0])       # the loading's start
        g = np.array([np.linalg.norm(f["position"][m.link_i] - f["position"][m.link_j], axis=1)
                      for f in io.frame_arrays(r.history, ["position"],
                                               frames=range(k0, len(steps)))])
        spacing = 2.2 * m.body_radius[m.link_i[0]]
        return float((g[1:] - g[0]).max() / spacing)

    assert stretch(True) < 0.05
    assert stretch(False) > 0.2
