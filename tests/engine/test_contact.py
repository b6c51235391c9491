"""Contact detection: broadphase completeness, buffer growth, frames."""
import numpy as np
import pytest

from engine import Scene, laws, step
from engine.contact import detect, rebuild_pairs, tangent_frame
from engine.integrator import free_velocity


def _cloud(n=400, seed=0):
    rng = np.random.default_rng(seed)
    pts = rng.uniform(0, 0.02, (n, 3))
    radii = rng.uniform(0.2e-3, 0.6e-3, n)
    # thin out overlaps so the scene compiles
    keep = []
    for k in range(n):
        if all(np.linalg.norm(pts[k] - pts[m]) > radii[k] + radii[m] for m in keep):
            keep.append(k)
    return pts[keep], radii[keep]


def test_broadphase_finds_exactly_the_brute_force_pairs():
    pts, radii = _cloud()
    s = Scene()
    s.add_spheres(pts, radii, density=2650.0)
    s.interact("sand", "sand", laws.Coulomb(mu=0.3))
    model, state = s.compile(dt=1e-5, alert=1e-4, skin=2e-4)
    state.pairs = np.zeros((1, 2), np.int32)  # force growth: nothing may be lost
    rebuild_pairs(model, state)
    got = {tuple(p) for p in state.pairs[:state.n_pairs]}
    d = np.linalg.norm(pts[:, None] - pts[None], axis=2) - radii[:, None] - radii[None]
    want = {(i, j) for i in range(len(pts)) for j in range(i + 1, len(pts)) if d[i, j] < 3e-4}
    assert got == want and len(want) > 20


def test_contact_buffer_grows_without_loss():
    pts, radii = _cloud(seed=1)
    s = Scene()
    s.add_spheres(pts, radii, density=2650.0)
    s.interact("sand", "sand", laws.Coulomb(mu=0.3))
    model, state = s.compile(dt=1e-5, alert=2e-4, skin=1e-4)
    state.contacts_buf.allocate(2)
    free_velocity(model, state)
    detect(model, state)
    d = np.linalg.norm(pts[:, None] - pts[None], axis=2) - radii[:, None] - radii[None]
    want = sum(1 for i in range(len(pts)) for j in range(i + 1, len(pts)) if d[i, j] <= 2e-4)
    assert state.contacts_buf.count == want > 2


@pytest.mark.parametrize("n", [(0, 0, 1), (1, 0, 0), (0, -1, 0), (0.3, -0.5, 0.81), (1, 1, 1)])
def test_local_frame_is_orthonormal_and_right_handed(n):
    n = np.asarray(n, float) / np.linalg.norm(n)
    t = np.array(tangent_frame(*n)[:3])
    s = np.array(tangent_frame(*n)[3:])
    frame = np.vstack([n, t, s])
    np.testing.assert_allclose(frame @ frame.T, np.eye(3), atol=1e-15)
    assert np.linalg.det(frame) == pytest.approx(1.0, abs=1e-14)


def test_cylinder_caps_are_optional():
    R, H, r = 0.01, 0.02, 1e-3
    for top in (False, True):
        s = Scene(gravity=(0, 0, 9.81))  # gravity upwards: pushes into the top cap
        s.add_cylinder(radius=R, height=H, bottom=True, top=top)
        s.add_spheres([[0, 0, H - r]], r, density=2650.0)
        s.interact("sand", "wall", laws.Coulomb(mu=0.3))
        model, state = s.compile(dt=1e-4)
        for _ in range(300):
            step(model, state)
        if top:
            assert state.position[1, 2] == pytest.approx(H - r, abs=1e-12)
        else:
            assert state.position[1, 2] > H + 1e-3  # open top: it leaves


# -- contacts a step can close at a large time step -------------------------------------------
R_LATE = 1e-3


def test_a_fast_sphere_does_not_pass_through_one_beyond_the_skin():
    """A sphere at 10 m/s towards one at rest 6 mm away, h = 1 ms, θ = 0.5: at the predicted
    configuration (5 mm on) the gap is 1 mm, beyond the fixed candidate margin alert + skin
    = 0.6 mm, and the free velocity would close 10 mm.  The candidate list is then built
    with a margin of 2 h v_max, the pair is a contact, and the Signorini condition
    u_n + g/h >= 0 lets the gap close exactly: after the step the relative velocity is
    g/h = 1 m/s, the momentum is conserved and the spheres do not overlap; the next step's
    plastic impact leaves both at 5 m/s."""
    s = Scene()
    s.add_spheres(np.array([[0.0, 0.0, 0.0], [2 * R_LATE + 6e-3, 0.0, 0.0]]), R_LATE,
                  density=2650.0, velocities=np.array([[10.0, 0, 0], [0, 0, 0]]))
    s.interact("sand", "sand", laws.Coulomb(mu=0.3))
    model, state = s.compile(dt=1e-3, theta=0.5, tol=1e-12, max_iter=100)
    st = step(model, state)
    assert st.n_contacts == 1
    v = state.vel6[:2, 0]
    assert v == pytest.approx([5.5, 4.5], rel=1e-9)
    assert np.linalg.norm(state.position[1] - state.position[0]) >= 2 * R_LATE * (1 - 1e-9)
    step(model, state)
    assert state.vel6[:2, 0] == pytest.approx([5.0, 5.0], rel=1e-9)
    assert np.linalg.norm(state.position[1] - state.position[0]) >= 2 * R_LATE * (1 - 1e-9)


def test_a_grain_stopped_by_the_floor_stops_the_one_falling_on_it():
    """Two spheres falling together at 1 m/s, 0.3 mm apart (beyond the 0.1 mm alert
    distance), the lower one 0.55 mm above the floor, h = 1 ms, θ = 0.5.  Their free
    velocities are equal, so the first narrowphase sees no contact between them; the solve
    stops the lower one on the floor (u_n + g/h >= 0 lets it close its 0.05 mm predicted
    gap).  The step then finds the pair that the solved velocities close (one late
    contact), solves again, and the upper sphere closes its gap to the lower one exactly
    at the next predicted configuration.  Without the second look it would sink 0.7 mm into
    the lower one and stay there (an overlap is held, not pushed out)."""
    gap0, lift = 3e-4, 5.5e-4
    z = np.array([R_LATE + lift, 3 * R_LATE + lift + gap0])
    s = Scene(gravity=(0, 0, -9.81))
    s.add_spheres(np.column_stack([np.zeros(2), np.zeros(2), z]), R_LATE, density=2650.0,
                  velocities=np.array([[0, 0, -1.0], [0, 0, -1.0]]))
    s.add_plane(point=(0, 0, 0), normal=(0, 0, 1), group="wall")
    s.interact("sand", "sand", laws.Coulomb(mu=0.3))
    s.interact("sand", "wall", laws.Coulomb(mu=0.3))
    model, state = s.compile(dt=1e-3, theta=0.5, tol=1e-12, max_iter=200, alert=1e-4)
    st = step(model, state)
    assert st.late_contacts == 1 and st.n_contacts == 2 and st.converged
    h, c = 1e-3, state.contacts_buf
    v = state.vel6[:2, 2]
    # each gap at the predicted configuration closes exactly: v = −g/h, relative for the pair
    g_floor, g_pair = sorted(c.gap[:2], key=lambda g: abs(g - 5e-5))
    assert v[0] == pytest.approx(-g_floor / h, rel=1e-9)
    assert v[1] - v[0] == pytest.approx(-g_pair / h, rel=1e-9)
    for _ in range(5):                                  # then both rest, touching
        st = step(model, state)
        assert st.late_contacts == 0
    x = state.position[:2, 2]
    assert x[0] == pytest.approx(R_LATE, abs=1e-12)
    assert x[1] - x[0] == pytest.approx(2 * R_LATE, abs=1e-12)
    assert state.vel6[:2, 2] == pytest.approx([0.0, 0.0], abs=1e-9)


def test_tangent_frames_are_tangent_frame_row_by_row():
    """The numpy frames of a history's contacts (engine.io) are the kernel's, bit for bit,
    the coordinate axes (each branch of the least-aligned axis) included."""
    from engine.contact.narrowphase import tangent_frame, tangent_frames

    rng = np.random.default_rng(0)
    n = rng.normal(size=(5000, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    n[:6] = np.vstack([np.eye(3), -np.eye(3)])
    got = tangent_frames(n)
    want = np.array([(*x, *tangent_frame(*x)) for x in n])
    assert np.array_equal(got, want)
