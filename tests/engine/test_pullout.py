"""The wire pull-out test (engine/experiments/pullout.py, docs/pullout.md): its sample, its
consolidation under σ_v, a friction fact of the pull, its input checks and its run file."""
import math
import warnings

import numpy as np
import pytest

from engine import Scene, laws
from engine.experiments import PulloutConfig, pullout_test
from engine.prep import pullout_sample
from engine.prep.samples import PULLOUT, pullout_min_scale

#: The smallest scale the test takes (its box 5 mean grain diameters wide): the runs below.
SCALE = 0.1


@pytest.fixture(scope="module")
def short_run(tmp_path_factory):
    """A default pull-out at the smallest scale, pulled 0.1 mm only (the consolidation is
    the default's; about 10 s)."""
    path = tmp_path_factory.mktemp("pullout") / "short.h5"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # (a peak still rising at 0.1 mm; the beads' overlaps)
        return pullout_test(SCALE, pull_distance=1e-4, frames=0, progress=False,
                            history=str(path))


def test_sample_is_a_straight_wire_through_a_box_of_sand():
    """The sand fills the box at the stated solid fraction with no overlap (grains with
    grains and with beads); the wire runs along x at mid-height, every bead inside the box
    but the last, which is just outside the +x face."""
    s = pullout_sample(SCALE, seed=3)
    lo, hi = s.container.bounds()
    rw, chain = s.bead_radius, s.wire[0]
    solid = 4 / 3 * math.pi * np.sum(s.sand_radii ** 3)
    beads_in = (len(chain) - 1) * 4 / 3 * math.pi * rw ** 3
    assert solid / (s.container.volume - beads_in) == pytest.approx(
        PULLOUT["solid_fraction"], rel=0.05)        # (the last grain overshoots the volume)
    c = np.vstack([s.sand_centers, chain])
    r = np.concatenate([s.sand_radii, np.full(len(chain), rw)])
    d = np.linalg.norm(c[:, None] - c[None], axis=-1) - (r[:, None] + r[None])
    np.fill_diagonal(d, np.inf)
    n = len(s.sand_radii)
    assert d[:n].min() > -1e-9 * rw                   # no grain overlaps a grain or a bead
    assert np.allclose(chain[:, 1:], [0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])])
    assert np.allclose(np.diff(chain[:, 0]), 2.2 * rw)
    assert chain[-1, 0] - rw > hi[0] > chain[-2, 0] + rw
    assert np.all(s.sand_centers[:, :2] - s.sand_radii[:, None] >= lo[:2] - 1e-12)
    assert np.all(s.sand_centers[:, :2] + s.sand_radii[:, None] <= hi[:2] + 1e-12)


def test_a_sphere_may_lie_behind_a_wall_its_group_does_not_see():
    """The wire leaves the box through a wall with no law for it: the compile's
    penetration check looks only at the pairs of groups that interact."""
    def scene(law):
        s = Scene()
        s.add_plane(point=(0, 0, 0), normal=(-1, 0, 0), group="front")
        s.add_spheres([[1e-3, 0, 0]], 0.5e-3, density=1400.0, group="wire")
        s.interact("wire", "front", law)
        return s

    scene(None).compile(dt=1e-4)
    with pytest.raises(ValueError, match="penetrate wall 0"):
        scene(laws.Coulomb(mu=0.3)).compile(dt=1e-4)


def test_consolidation_reaches_sigma_v_and_holds_it_through_the_pull(short_run):
    """At the end of stage 1 the top plate's stress is within consolidation_tol (2 %) of
    σ_v and the sand's kinetic energy at most ke_fraction of its peak; the plate, driven by
    the pressure, keeps σ_v within 2 % on average over the pull's records (it is the same
    pressure drive, and a quasi-static pull does not accelerate the sand)."""
    r, c = short_run, short_run.extra["consolidation"]
    assert c["reached"] and r.consolidated
    assert abs(c["stress_end"] / r.sigma_v - 1) < 0.02
    assert c["ke_ratio"] <= 1e-3
    assert abs(np.mean(r.top_stress) / r.sigma_v - 1) < 0.02
    # the history holds the curves (HDF5, read back by its reader)
    from engine.io import read_history

    h = read_history(r.history, frames=False)
    for k in ("force", "displacement", "top_stress", "stage"):
        assert k in h.extra
    pull = h.extra["stage"] == 1
    assert np.allclose(h.extra["force"][pull], r.force)


def test_the_pull_follows_its_drive(short_run):
    """The pulled end moves at pull_velocity: its displacement at each record is v t from
    the pull's start (it is velocity-driven), and it ends at pull_distance; the force is the
    tension of a link pulled from outside, >= 0."""
    r = short_run
    v = r.params["pull_velocity"]
    assert np.allclose(r.displacement, v * (r.time - r.time[0]) + r.displacement[0],
                       atol=1e-12)
    assert r.displacement[-1] == pytest.approx(1e-4, abs=v * 5e-5)
    assert np.all(r.force >= 0)
    assert r.mu_star == pytest.approx(
        r.F_peak / (r.sigma_v * math.pi * r.wire_diameter * r.embedded_length))
    assert r.scalars()["mu_star"] == r.mu_star


@pytest.mark.slow
def test_wire_friction_raises_the_pull_force(tmp_path):
    """With mu_wire = 0 the wire resists only by its beads pushing grains; friction can only
    add to that: the same sample (seed) pulled with mu_wire = 0.8 needs more force, at its
    peak and on average.  The wire is as thick as a mean grain (r_w = 0.25 mm): the
    paper's 0.27 mm wire sits in the pores of this sand at this scale and a few pinched
    beads carry its load, whose noise hides the friction (docs/pullout.md)."""
    kw = dict(bead_radius=0.25e-3, pull_distance=3e-4, frames=0, progress=False)
    got = {}
    for mw in (0.0, 0.8):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")     # (the overlaps on the beads, docs/pullout.md)
            got[mw] = pullout_test(SCALE, mu_wire=mw, history=str(tmp_path / f"{mw}.h5"), **kw)
    assert got[0.0].F_peak > 0                       # the beads alone resist
    assert got[0.0].F_peak < got[0.8].F_peak
    assert np.mean(got[0.0].force) < np.mean(got[0.8].force)


@pytest.mark.parametrize("kw, says", [
    (dict(pressure=-1.0), "pressure = -1.0: must be a number in (0, 1e+09]"),
    (dict(pull_distance=0.0), "pull_distance = 0.0: must be a number in (0, 0.1]"),
    (dict(scale=0.05), "scale = 0.05: the pull-out box would be 2.21 mm wide and high, 4.0 "
                       "mean grain diameters (at least 5): use scale >= 0.0963"),
    (dict(wire=False), "wire = 'none': the pull-out test pulls on a wire"),
    (dict(wire_law=laws.LooseWire()), "wire = 'loose': the pull-out test pulls on a wire"),
    (dict(pull_velocity=1.0), "pull_velocity = 1.0: inertial number"),
    (dict(bead_radius=0.5e-3), "bead_radius = 0.0005: the wire must be at most a fifth"),
])
def test_bad_input_is_refused_on_one_line_naming_the_field(kw, says, tmp_path):
    with pytest.raises(ValueError) as e:
        pullout_test(**dict(dict(scale=SCALE), **kw), progress=False,
                     history=str(tmp_path / "h.h5"))
    msg = str(e.value)
    assert "\n" not in msg and says in msg, msg
    assert not (tmp_path / "h.h5").exists()          # refused before anything was written


def test_smallest_scale_is_five_grain_diameters():
    assert pullout_min_scale() == pytest.approx((5 * 0.55e-3 / 6e-3) ** 3)
    PulloutConfig.from_kwargs(scale=0.0963)
    with pytest.raises(ValueError, match="use scale >= 0.0963"):
        PulloutConfig.from_kwargs(scale=0.096)


def test_a_run_file_of_the_pullout_test_validates(tmp_path):
    """``test = "pullout_test"`` in a run file: its [parameters] are the config's fields, a
    bad one is refused naming it, and the file gives the config the Python call does; a
    sweep accepts its cases."""
    from workbench import cli
    from workbench.campaign.experiments import EXPERIMENTS, check_paper_cases

    raw = {"test": "pullout_test", "scale": 0.15, "seed": 2,
           "parameters": {"pressure": 20e3, "pull_velocity": 2e-3, "mu_wire": 0.5},
           "wire": {"law": "rigid"}}
    cfg, params = cli.validate_config(raw, "p.toml")
    assert type(params).__name__ == "PulloutParams"
    got = cli.file_config(cfg, params, tmp_path, progress=False)
    want = PulloutConfig.from_kwargs(scale=0.15, seed=2, pressure=20e3, pull_velocity=2e-3,
                                     mu_wire=0.5, wire_law=laws.RigidWire(),
                                     history=str(tmp_path / "run.h5"), progress=False)
    assert got == want and got.neighbour_contact      # left out of [wire]: the test's own
    for bad, says in (({"parameters": {"pull_distance": -1e-3}}, "parameters.pull_distance"),
                      ({"scale": 0.05}, "scale = 0.05: the pull-out box"),
                      ({"wire": {"law": "none"}}, "wire = 'none'")):
        with pytest.raises(cli.ConfigError) as e:
            cli.validate_config({**raw, **bad}, "p.toml")
        assert says in str(e.value)
    assert "pullout_test" in EXPERIMENTS
    check_paper_cases("pullout_test", [dict(scale=0.1, mu_wire=m) for m in (0.0, 0.8)], {})
