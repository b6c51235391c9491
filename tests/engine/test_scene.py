"""Bad input gives a ValueError naming the field and the allowed range or offending ids."""
import numpy as np
import pytest

from engine import Scene, laws, step


def _base():
    s = Scene()
    s.add_plane(group="wall")
    s.add_spheres([[0, 0, 1e-3], [0, 0, 3.5e-3]], 1e-3, density=2650.0, group="sand")
    s.interact("sand", "sand", laws.Coulomb(mu=0.5))
    s.interact("sand", "wall", laws.Coulomb(mu=0.5))
    return s


def _compile(**kw):
    def go():
        opts = dict(dt=1e-4)
        opts.update(kw)
        _base().compile(**opts)
    return go


def _spheres(**kw):
    def go():
        args = dict(centers=[[0, 0, 1]], radii=1e-3, density=2650.0)
        args.update(kw)
        Scene().add_spheres(**args)
    return go


def _missing_law():
    s = Scene()
    s.add_plane(group="wall")
    s.add_spheres([[0, 0, 1e-3]], 1e-3, density=2650.0, group="sand")
    s.compile(dt=1e-4)


def _missing_sand_sand():
    s = Scene()
    s.add_spheres([[0, 0, 1e-3], [0, 0, 5e-3]], 1e-3, density=2650.0, group="sand")
    s.compile(dt=1e-4)


def _unknown_group():
    s = _base()
    s.interact("sand", "wires", laws.Coulomb(mu=0.3))
    s.compile(dt=1e-4)


def _overlap():
    s = Scene()
    s.add_spheres([[0, 0, 0], [1.9e-3, 0, 0], [10e-3, 0, 0]], 1e-3, density=2650.0)
    s.interact("sand", "sand", laws.Coulomb(mu=0.5))
    s.compile(dt=1e-4)


def _wall_penetration():
    s = Scene()
    s.add_plane(group="wall")
    s.add_spheres([[0, 0, 0.5e-3]], 1e-3, density=2650.0)
    s.interact("sand", "wall", laws.Coulomb(mu=0.5))
    s.compile(dt=1e-4)


def _wire(centers=((0, 0, 0), (2.2e-3, 0, 0), (4.4e-3, 0, 0)), law=None, **kw):
    def go():
        Scene().add_wire(centers, radius=1e-3, density=1400.0,
                         law=laws.RigidWire() if law is None else law, **kw)
    return go


def _wire_law_in_interact():
    s = _base()
    s.interact("sand", "sand", laws.RigidRod(), replace=True)     # refused as it is declared


BAD = {
    "wire stiffness zero": (lambda: laws.ElasticWire(stiffness=0.0), r"ElasticWire: stiffness = 0.0: must be a finite number > 0$"),
    "wire stiffness negative": (lambda: laws.ElasticRod(stiffness=-1.0), r"ElasticRod: stiffness = -1.0: must be a finite number > 0$"),
    "wire prestrain -1": (lambda: laws.ElasticWire(stiffness=1.0, prestrain=-1.0), r"prestrain = -1.0: must be a number in \(-1, 1\]$"),
    "wire max tension zero": (lambda: laws.BrittleElasticWire(stiffness=1.0, max_tension=0.0), r"max_tension = 0.0: must be a finite number > 0$"),
    "wire one bead": (_wire(centers=[[0, 0, 0]]), r"at least 2 beads, got 1"),
    "wire bead overlap": (_wire(centers=[[0, 0, 0], [2.2e-3, 0, 0], [3.5e-3, 0, 0]]),
                          r"overlap their neighbour by more than 1% .* at links \[1\]"),
    "wire nan centre": (_wire(centers=[[0, 0, 0], [np.nan, 0, 0]]), r"centers must be finite.*ids \[1\]"),
    "wire contact law": (_wire(law=laws.Coulomb(mu=0.3)), r"law must be a wire law"),
    "wire law in interact": (_wire_law_in_interact, r"RigidRod is a wire law"),

    "zero radius": (_spheres(radii=0.0), r"radii must be finite and > 0 m"),
    "negative radius": (_spheres(radii=[-1e-3]), r"radii .*> 0 m.*ids \[0\]"),
    "zero density": (_spheres(density=0.0), r"density must be finite and > 0 \[kg/m³\]"),
    "negative density": (_spheres(density=-5.0), r"density .*> 0"),
    "nan centre": (_spheres(centers=[[0, np.nan, 0]]), r"centers must be finite.*ids \[0\]"),
    "dt zero": (_compile(dt=0.0), r"^Options: dt = 0.0: must be a finite number > 0$"),
    "dt negative": (_compile(dt=-1e-4), r"dt = -0.0001: must be a finite number > 0$"),
    "theta low": (_compile(theta=0.4), r"theta = 0.4: must be a number in \[0.5, 1\]$"),
    "theta high": (_compile(theta=1.2), r"theta = 1.2: must be a number in \[0.5, 1\]$"),
    "tol zero": (_compile(tol=0.0), r"tol = 0.0: must be a finite number > 0$"),
    "max_iter zero": (_compile(max_iter=0), r"max_iter = 0: must be an integer in \[1, 1000000000\]$"),
    "relax zero": (_compile(relax=0.0), r"relax = 0.0: must be a number in \(0, 2\)$"),
    "relax 2": (_compile(relax=2.0), r"relax = 2.0: must be a number in \(0, 2\)$"),
    "relax over with anderson": (_compile(relax=1.4, anderson=4), r"relax = 1.4 > 1 \(over-relaxation\) works with the unmixed sweep on one thread only"),
    "dt string": (_compile(dt="1e-5"), r"^Options: dt = '1e-5': must be a finite number > 0, not a string$"),
    "max_iter string": (_compile(max_iter="10"), r"max_iter = '10': must be an integer in \[1, 1000000000\], not a string$"),
    "mu string": (lambda: laws.Coulomb(mu="0.3"), r"^Coulomb: mu = '0.3': must be a number >= 0, not a string$"),
    "gravity strings": (lambda: _base().compile(dt=1e-4)[0].with_options(gravity=("0", "0", "-9.81")), r"gravity = \('0', '0', '-9.81'\): must be numbers, not strings$"),
    "max_iter bool": (_compile(max_iter=True), r"max_iter = True: must be an integer in \[1, 1000000000\], not a bool$"),
    "theta numpy bool": (_compile(theta=np.True_), r"theta = (np\.)?True_?: must be a number in \[0.5, 1\], not a bool$"),
    "tol numpy string": (_compile(tol=np.str_("1e-4")), r"tol = (np\.str_\()?'1e-4'\)?: must be a finite number > 0, not a string$"),
    "stiffness bytes": (lambda: laws.ElasticWire(stiffness=b"1"), r"stiffness = b'1': must be a finite number > 0, not a string$"),
    "mu negative": (lambda: laws.Coulomb(mu=-0.1), r"Coulomb: mu = -0.1: must be a number >= 0$"),
    "mu nan": (lambda: laws.Coulomb(mu=np.nan), r"Coulomb: mu = nan: must be a number >= 0$"),
    "unknown option": (lambda: _base().compile(dt=1e-4)[0].with_options(toll=1e-4),
                       r"toll = 0.0001: unknown field \(the fields are: dt, theta, tol, max_iter"),
    "two bad options": (_compile(theta=0.3, tol=-1.0), r"theta = 0.3: must be a number in "
                                                       r"\[0.5, 1\]; tol = -1.0: must be"),
    "missing law wall": (_missing_law, r"no declared law: \('sand', 'wall'\)"),
    "missing law sand": (_missing_sand_sand, r"no declared law: \('sand', 'sand'\)"),
    "unknown group": (_unknown_group, r"unknown group names \['wires'\]"),
    "overlap": (_overlap, r"1 pairs of spheres overlap by more than 1% .*ids \[\[0, 1\]\]"),
    "wall penetration": (_wall_penetration, r"penetrate wall 0 .*ids \[1\]"),
    "fix unknown id": (lambda: _base().fix([7]), r"unknown body ids \[7\]"),
    "pressure on sphere": (lambda: _base().drive(1, pressure=1e3, area=1.0), r"pressure drives apply to planes"),
    "pressure without area": (lambda: _base().drive(0, pressure=1e3, mass=1.0), r"needs area="),
    "force wall without mass": (lambda: _base().drive(0, force=(0, 0, 1)), r"mass must be a number > 0"),
    "two drives": (lambda: _base().drive(1, velocity=(0, 0, 1), force=(0, 0, 1)), r"exactly one of"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_input_raises_value_error(case):
    fn, pattern = BAD[case]
    with pytest.raises(ValueError, match=pattern):
        fn()


def test_numpy_scalars_are_numbers():
    """Strings are refused but numpy's scalars (a value read from an array) are not."""
    model, _ = _base().compile(dt=np.float32(1e-4), max_iter=np.int64(50), tol=np.float64(1e-5))
    assert model.options.max_iter == 50 and model.options.dt == pytest.approx(1e-4, rel=1e-6)


def test_no_spheres_is_an_empty_addition():
    """add_spheres of zero centres (a filter that kept none) adds nothing and returns no ids."""
    s = _base()
    n = s.n_bodies
    for centers, radii in ((np.zeros((0, 3)), 1e-3), (np.zeros((0, 3)), np.zeros(0)),
                           ([], 1e-3)):
        ids = s.add_spheres(centers, radii, density=2650.0)
        assert ids.shape == (0,) and ids.dtype == np.int32
    with pytest.raises(ValueError, match="radii must be finite and > 0 m, got -1"):
        s.add_spheres([], -1, density=2650.0)          # checked with no centre too
    assert s.n_bodies == n


def test_explicit_no_interaction_is_allowed():
    s = Scene()
    s.add_plane(group="wall")
    s.add_spheres([[0, 0, 1e-3], [0, 0, 5e-3]], 1e-3, density=2650.0, group="sand")
    s.interact("sand", "sand", None)
    s.interact("sand", "wall", laws.Coulomb(mu=0.5))
    model, _ = s.compile(dt=1e-4)
    assert model.pair_law[0, 0] == -1 and model.pair_law[0, 1] == 0


def test_overlap_within_tolerance_is_accepted():
    s = Scene()
    s.add_spheres([[0, 0, 0], [2e-3 - 0.5e-5, 0, 0]], 1e-3, density=2650.0)  # 0.5 % overlap
    s.interact("sand", "sand", laws.Coulomb(mu=0.5))
    model, state = s.compile(dt=1e-4)
    assert model.n_spheres == 2


def test_model_arrays_are_read_only_and_in_si():
    model, state = _base().compile(dt=1e-4)
    r = 1e-3
    m = 2650.0 * 4 / 3 * np.pi * r ** 3
    np.testing.assert_allclose(model.body_mass[model.sphere_ids], m, rtol=1e-14)
    np.testing.assert_allclose(model.body_inertia[model.sphere_ids], 0.4 * m * r * r, rtol=1e-14)
    with pytest.raises(ValueError):
        model.body_radius[0] = 1.0
    assert state.velocity.base is state.vel6 and state.spin.base is state.vel6


def test_wires_links_and_contact_exclusion():
    """Links i -> i+1 per wire (and last -> first when closed); linked beads never get a
    contact, other touching beads do."""
    s = Scene(gravity=(0, 0, 0))
    a = 2e-3  # beads of radius 1 mm touching their neighbours
    open_w = s.add_wire([[k * a, 0, 0] for k in range(4)], radius=1e-3, density=1400.0,
                        law=laws.RigidWire())
    ring = [[0.05 + 0.004 * np.cos(t), 0.004 * np.sin(t), 0] for t in np.linspace(0, 2 * np.pi, 13)[:-1]]
    closed_w = s.add_wire(ring, radius=1e-3, density=1400.0, law=laws.ElasticWire(stiffness=1.0),
                          closed=True)
    # a third bead touching the first wire's bead 1 from above: a real contact
    other = s.add_spheres([[a, 0, 2e-3]], 1e-3, density=1400.0, group="sand")
    s.interact("wire", "wire", laws.Coulomb(mu=0.3))
    s.interact("wire", "sand", laws.Coulomb(mu=0.3))
    model, state = s.compile(dt=1e-4)
    li = list(zip(model.link_i.tolist(), model.link_j.tolist()))
    assert li[:3] == [(0, 1), (1, 2), (2, 3)]
    assert len(li) == 3 + 12 and (int(closed_w[-1]), int(closed_w[0])) in li
    assert (int(open_w[-1]), int(closed_w[0])) not in li  # wires are not joined
    step(model, state)
    pairs = {tuple(sorted(p)) for p in zip(state.contacts.i.tolist(), state.contacts.j.tolist())}
    assert not pairs & {tuple(sorted(p)) for p in li}
    assert (int(open_w[1]), int(other[0])) in pairs
    assert len(state.links) == 15 and np.all(state.links.tension == 0.0)


def test_with_drive_packs_the_kernel_rows_as_compile_does():
    """A force-driven lid switched to an imposed velocity by ``Model.with_drive`` gets the
    kernel's packed rows (``body_dyn``: no inverse mass or inertia, no line) that a scene
    compiled with that velocity drive from the start has; the other bodies keep theirs."""
    def scene(lid_velocity):
        s = Scene(gravity=(0, 0, -9.81))
        s.add_spheres(np.array([[0, 0, 1e-3], [3e-3, 0, 1e-3]]), 1e-3, density=2650.0,
                      group="sand")
        lid = s.add_plane(point=(0, 0, 5e-3), normal=(0, 0, -1), group="wall")
        s.add_plane(group="wall")
        if lid_velocity:
            s.drive(lid, velocity=(0, 0, -1e-3))
        else:
            s.drive(lid, force=(0, 0, -1.0), mass=0.1)
        s.interact("sand", "sand", laws.Coulomb(mu=0.5))
        s.interact("sand", "wall", laws.Coulomb(mu=0.5))
        return s.compile(dt=1e-4)[0], lid

    forced, lid = scene(False)
    imposed, _ = scene(True)
    switched = forced.with_drive(lid, velocity=(0, 0, -1e-3))
    assert forced.body_dyn[lid, 0] == 10.0 and forced.body_dyn[lid, 3] == 1.0   # 1/0.1 kg, LINE
    assert np.array_equal(switched.body_dyn, imposed.body_dyn)
    assert np.array_equal(switched.body_dof, imposed.body_dof)
