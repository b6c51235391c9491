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
        tube = s.add_cylinder(radius=R, height=H, bottom=True, top=top)
        s.add_spheres([[0, 0, H - r]], r, density=2650.0)
        s.interact("sand", "wall", laws.Coulomb(mu=0.3))
        model, state = s.compile(dt=1e-4)
        for _ in range(300):
            step(model, state)
        if top:
            assert state.position[1, 2] == pytest.approx(H - r, abs=1e-12)
        else:
            assert state.position[1, 2] > H + 1e-3  # open top: it leaves
