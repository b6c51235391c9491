"""Property-based tests (hypothesis) of the inputs a user gives (issue 33): random types and
values in the ``nscd run`` file schema and in the ``Scene`` API.  Each example is either
refused with a ValueError whose lines name the field at fault, or accepted and then within
the bounds the code can honour: no other exception, no traceback of numba, no hang (a
step of an accepted scene runs under a stop request sent by a timer, which ends it within
~40 ms: the step stops or finishes).

The counts of each run (examples tried, refused, accepted) are printed at the end of each
test (``pytest -s``) and checked to be a real mix of both outcomes (at least 20 % refused,
5 % accepted)."""
import math
import signal
import inspect
import time
import warnings

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings, strategies as st  # noqa: E402

from engine import Scene, laws, run, stop  # noqa: E402
from engine.sanity import PhysicsWarning  # noqa: E402
from engine.step import NonConvergenceWarning, SimulationError  # noqa: E402

# -- values a hostile user gives -----------------------------------------------------------------
NUMBERS = st.one_of(
    st.integers(-5, 5), st.integers(-2**70, 2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, -0.0, 1e-300, 1e-12, 1e-5, 5e-5, 1e-3, 0.3, 0.5, 1.0, 2.0, 10.0,
                     1e3, 1e9, 1e20, 1e308]))
ANYTHING = st.one_of(NUMBERS, st.booleans(), st.none(),
                     st.text(max_size=6), st.sampled_from(["1e-4", "yes", "true", "0.3", ""]),
                     st.lists(NUMBERS, max_size=4), st.dictionaries(st.text(max_size=3),
                                                                      NUMBERS, max_size=2))


#: Values that many fields accept (so that examples are accepted often enough to test that
#: side too).
PLAUSIBLE = st.sampled_from([0, 1, 2, 10, 100, 0.02, 0.5, 0.3, 1e-4, 5e-5, True, False])


def _counts():
    return {"tried": 0, "refused": 0, "accepted": 0}


# -- the run file schema ---------------------------------------------------------------------------
def _run_file_tables():
    from workbench import cli

    tests = list(cli._PARAMS)

    @st.composite
    def tables(draw):
        def hostile(p):  # a hostile value with probability p, else a plausible one
            return draw(st.integers(0, 99)) < 100 * p

        test = draw(ANYTHING) if hostile(0.1) else draw(st.sampled_from(tests))
        top = {"test": test}
        if draw(st.booleans()):
            top["scale"] = draw(ANYTHING) if hostile(0.4) else draw(
                st.sampled_from([0.01, 0.02, 0.05, 0.5, 1]))
        if draw(st.booleans()):
            top["seed"] = draw(ANYTHING) if hostile(0.4) else draw(st.integers(0, 2**62))
        if hostile(0.3):
            top["wire"] = draw(st.dictionaries(
                st.sampled_from(["law", "stiffness", "prestrain", "max_tension",
                                 "neighbour_contact", "lw"]),
                st.one_of(PLAUSIBLE, ANYTHING, st.sampled_from(
                    ["elastic", "rigid", "elastic_rod", "rigid_rod", "brittle", "none"])),
                max_size=3))
        cls = cli._PARAMS.get(test) if isinstance(test, str) else None
        names = sorted(cls.model_fields) if cls is not None else ["dt", "steps"]
        keys = draw(st.lists(st.one_of(st.sampled_from(names), st.sampled_from(names),
                                       st.just("dtt")), max_size=3, unique=True))
        params = {}
        for k in keys:
            f = cls.model_fields.get(k) if cls is not None else None
            near = [f.default] if f is not None and f.default is not None else []
            if f is not None and isinstance(f.default, (int, float)) and not isinstance(
                    f.default, bool):
                near += [f.default * 2, f.default / 2 if isinstance(f.default, float) else
                         f.default + 1]
            params[k] = draw(ANYTHING if hostile(0.3) else st.one_of(
                st.sampled_from(near or [1]), PLAUSIBLE))
        return top, params

    return tables()


RUN_FILE_COUNTS = _counts()


@settings(max_examples=400, deadline=2000, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(_run_file_tables())
def _run_file_property(tables):
    from workbench import cli

    top, params = tables
    raw = dict(top)
    if params:
        raw["parameters"] = params
    RUN_FILE_COUNTS["tried"] += 1
    try:
        cfg, p = cli.validate_config(raw, "f.toml")
    except cli.ConfigError as e:
        RUN_FILE_COUNTS["refused"] += 1
        head, *lines = str(e).splitlines()
        assert head.startswith("f.toml: ") and "problem(s)" in head
        assert lines and all(ln.startswith("  ") and (" = " in ln or ": required" in ln)
                             for ln in lines), str(e)
        return
    RUN_FILE_COUNTS["accepted"] += 1
    # accepted: exact types, finite numbers within the declared bounds, arguments the
    # test function takes
    assert cfg.test in cli._PARAMS and type(cfg.seed) is int and 0 <= cfg.seed < 2**63
    assert cfg.scale is None or (type(cfg.scale) is float and 0 < cfg.scale <= 1)
    assert type(cfg.wire.neighbour_contact) is bool
    from engine import laws
    law = cfg.wire.wire_law()                     # every accepted [wire] builds its law
    assert law is None if cfg.wire.law == "none" else type(law) is laws.WIRE_LAWS[cfg.wire.law]
    for name, v in p.model_dump().items():
        ann = type(p).model_fields[name].annotation
        if v is None:
            continue
        if ann in (int, bool):
            assert type(v) is ann, (name, v)
        if isinstance(v, float):
            assert math.isfinite(v), (name, v)
        if isinstance(v, int) and not isinstance(v, bool):
            assert abs(v) <= cli.STEP_LIMIT or name == "max_iter", (name, v)
    from engine import experiments

    inspect.signature(getattr(experiments, cfg.test)).bind(cfg.scale, **p.model_dump())


def _mix(counts: dict, what: str, run_examples) -> None:
    """Run a property's examples, print its counts, and check both outcomes were seen."""
    counts.update(_counts())
    run_examples()
    print(f"\n{what}: {counts}")
    assert counts["refused"] >= 0.2 * counts["tried"], counts
    assert counts["accepted"] >= 0.05 * counts["tried"], counts


def test_a_run_file_is_refused_field_by_field_or_accepted_within_its_bounds():
    _mix(RUN_FILE_COUNTS, "run-file schema", _run_file_property)


# -- the Scene API --------------------------------------------------------------------------------
def _scene_inputs():
    good = {"centers": [[0.0, 0.0, 1.2e-3], [0.0, 0.0, 3.5e-3]], "radii": 1e-3,
            "density": 2650.0, "gravity": (0.0, 0.0, -9.81), "mu": 0.5, "lid_velocity": None,
            "dt": 1e-4, "tol": 1e-4, "max_iter": 100, "theta": 0.5}
    hostile = {
        "centers": st.one_of(st.lists(st.lists(NUMBERS, min_size=3, max_size=3), min_size=1,
                                      max_size=3), ANYTHING),
        "radii": st.one_of(NUMBERS, st.booleans(), st.text(max_size=3),
                           st.lists(NUMBERS, min_size=1, max_size=3)),
        "gravity": st.one_of(st.tuples(NUMBERS, NUMBERS, NUMBERS), ANYTHING),
        "lid_velocity": st.one_of(st.tuples(NUMBERS, NUMBERS, NUMBERS), ANYTHING),
        "max_iter": st.one_of(ANYTHING, st.just(10**9)),
    }

    @st.composite
    def inputs(draw):
        x = dict(good)
        for k in good:      # each input hostile with probability 0.08 (about half the scenes
            if draw(st.integers(0, 99)) < 8:          # have one or more)
                x[k] = draw(hostile.get(k, ANYTHING))
        return x

    return inputs()


SCENE_COUNTS = _counts()


class _Timer:
    """A stop request after ``seconds`` (SIGALRM): run() then ends within a chunk."""

    def __init__(self, seconds):
        self.seconds = seconds

    def __enter__(self):
        self.old = signal.signal(signal.SIGALRM, lambda *a: stop.request())
        signal.setitimer(signal.ITIMER_REAL, self.seconds)

    def __exit__(self, *exc):
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, self.old)
        stop.clear()


@pytest.fixture(scope="module")
def warm():
    """Numba's kernels loaded once (the first step of a process loads its cache)."""
    s = Scene(gravity=(0, 0, -9.81))
    s.add_spheres([[0, 0, 1.2e-3]], 1e-3, density=2650.0)
    s.add_plane(point=(0, 0, 0), normal=(0, 0, 1), group="floor")
    s.interact("sand", "floor", laws.Coulomb(mu=0.5))
    m, st_ = s.compile(dt=1e-4)
    run(m, st_, 3, progress=False)


@settings(max_examples=300, deadline=5000, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(_scene_inputs())
def _scene_property(x):
    SCENE_COUNTS["tried"] += 1
    try:
        s = Scene(gravity=x["gravity"])
        ids = s.add_spheres(x["centers"], x["radii"], density=x["density"])
        floor = s.add_plane(point=(0, 0, 0), normal=(0, 0, 1), group="floor")
        lid = s.add_plane(point=(0, 0, 0.02), normal=(0, 0, -1), group="lid")
        if x["lid_velocity"] is not None:
            s.drive(lid, velocity=x["lid_velocity"])
        s.interact("sand", "sand", laws.Coulomb(mu=x["mu"]))
        s.interact("sand", "floor", laws.Coulomb(mu=0.5))
        s.interact("sand", "lid", laws.Coulomb(mu=0.0))
        model, state = s.compile(dt=x["dt"], tol=x["tol"], max_iter=x["max_iter"],
                                 theta=x["theta"])
    except ValueError as e:
        SCENE_COUNTS["refused"] += 1
        msg = str(e)
        assert msg and "Traceback" not in msg and "numba" not in msg.lower(), msg
        assert any(k in msg for k in ("centers", "radii", "density", "gravity", "mu", "velocity",
                                      "dt", "tol", "max_iter", "theta", "overlap", "sphere",
                                      "alert", "skin")), msg
        return
    SCENE_COUNTS["accepted"] += 1
    assert np.isfinite(model.body_mass[ids]).all() and (model.body_mass[ids] > 0).all()
    assert 0 < model.options.dt < math.inf and 1 <= model.options.max_iter <= 10**9
    t0 = time.monotonic()
    with _Timer(1.0), warnings.catch_warnings():
        warnings.simplefilter("ignore", NonConvergenceWarning)
        warnings.simplefilter("ignore", PhysicsWarning)       # said, and tested elsewhere
        try:
            summary = run(model, state, 5, progress=False)
        except SimulationError as e:          # a clean error naming the step
            assert "step" in str(e)
            return
    assert time.monotonic() - t0 < 3.0
    assert summary.steps == 5 or summary.interrupted
    assert np.isfinite(state.position).all()


def test_a_scene_is_refused_by_name_or_runs_bounded(warm):
    _mix(SCENE_COUNTS, "Scene API", _scene_property)
