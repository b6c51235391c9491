"""The tests' configuration schema (engine/experiments/config.py, issue 32 §1)."""
import inspect

import pytest
from pydantic import ValidationError

from engine import experiments, laws
from engine.checks import InputError
from engine.experiments.config import (CONFIGS, Anderson, BoxConfig, CylinderConfig,
                                       DefaultWire, DepositConfig, HotSweeps, NoWire,
                                       SlopeConfig, Solver, flat_model, spec_of_law, wire_spec)


@pytest.mark.parametrize("test", sorted(CONFIGS))
def test_every_keyword_has_its_default_in_the_schema(test):
    """A default read from the schema is the function's: the keywords of a config are the
    function's, each with the function's default, and the default config gives them back."""
    cls = CONFIGS[test]
    sig = inspect.signature(getattr(experiments, test)).parameters
    keys = cls.keywords()
    assert set(keys) == set(sig)
    for name, (_, default) in keys.items():
        want = sig[name].default
        assert default == (list(want) if isinstance(want, tuple) else want), (test, name)
    got = cls().kwargs()               # the default config is the call without keywords
    assert got == {n: (list(p.default) if isinstance(p.default, tuple) else p.default)
                   for n, p in sig.items()}
    assert cls.from_kwargs() == cls()
    assert cls().solver.acceleration == HotSweeps(sweeps=2)   # hot_sweeps=None: 2


def test_default_acceleration_is_what_the_solver_runs():
    from engine.experiments.common import solver_choice

    s = Solver()
    assert (s.anderson, s.hot_sweeps) == solver_choice(0, None) == (0, 2)
    c = CylinderConfig.from_kwargs(anderson=4)
    assert c.solver.acceleration == Anderson(depth=4)
    assert (c.solver.anderson, c.solver.hot_sweeps) == solver_choice(4, None) == (4, 0)
    assert CylinderConfig.from_kwargs(hot_sweeps=0).solver.acceleration == HotSweeps(sweeps=0)


def test_a_conflicting_acceleration_cannot_be_expressed():
    # one field: a HotSweeps or an Anderson, never both
    with pytest.raises(ValidationError, match="Extra inputs"):
        Solver(acceleration={"kind": "anderson", "depth": 2, "sweeps": 3})
    with pytest.raises(ValidationError):
        Solver(acceleration={"kind": "both"})
    # the keywords that would ask for both are refused on one line, naming the fields
    with pytest.raises(InputError) as e:
        BoxConfig.from_kwargs(anderson=2, hot_sweeps=3)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith("box_triaxial: hot_sweeps = 3 works with the "
                                              "unmixed sweep only")
    # over-relaxation with Anderson: refused by the Solver itself
    with pytest.raises(ValidationError, match="relax = 1.5 > 1"):
        Solver(relax=1.5, acceleration=Anderson(depth=2))


def test_errors_name_the_keyword_value_and_range_on_one_line():
    with pytest.raises(InputError) as e:
        CylinderConfig.from_kwargs(pressure=2e9, dt=-1.0, seed=-1)
    msg = str(e.value)
    assert "\n" not in msg
    for part in ("cylinder_triaxial: ", "pressure = 2000000000.0: must be a number in (0, 1e+09]",
                 "dt = -1.0: must be a number in (0, 0.01]",
                 "seed = -1: must be an integer in [0, 2**63 - 1]"):
        assert part in msg, msg
    with pytest.raises(InputError, match="no parameter 'presure'"):
        CylinderConfig.from_kwargs(presure=1.0)
    # the function refuses the same way, before anything is built
    with pytest.raises(ValueError, match=r"cylinder_triaxial: pressure = 2000000000.0"):
        experiments.cylinder_triaxial(pressure=2e9, progress=False)


@pytest.mark.parametrize("law", [None, laws.RigidRod(), laws.ElasticRod(stiffness=3.0),
                                 laws.RigidWire(prestrain=0.1), laws.ElasticWire(stiffness=0.5),
                                 laws.BrittleElasticWire(stiffness=2.0, max_tension=0.4,
                                                         prestrain=0.05), laws.LooseWire()])
def test_the_wire_union_round_trips_through_json(law):
    wire = law is not None
    c = CylinderConfig.from_kwargs(wire=wire, wire_law=law)
    back = CylinderConfig.model_validate_json(c.model_dump_json())
    assert back == c
    assert type(back.wire) is type(c.wire)
    assert back.kwargs()["wire_law"] == law and back.kwargs()["wire"] is wire
    if law is not None:
        assert type(back.kwargs()["wire_law"]) is type(law)
        assert spec_of_law(law).to_law() == law
    assert CylinderConfig.from_kwargs().wire == DefaultWire()
    assert CylinderConfig.from_kwargs(wire=False).wire == NoWire()


def test_wire_spec_is_the_one_translation():
    assert wire_spec("elastic").to_law() == laws.ElasticWire(stiffness=1.0)
    assert wire_spec("elastic", k="2").to_law() == laws.ElasticWire(stiffness=2.0)
    assert wire_spec(True).to_law() == laws.ElasticWire(stiffness=1.0)
    assert wire_spec("none").to_law() is None and wire_spec(False).to_law() is None
    assert wire_spec("brittle", 1.0, max_tension=0.5).to_law() == laws.BrittleElasticWire(
        stiffness=1.0, max_tension=0.5)
    with pytest.raises(ValueError, match="stiffness = 2.0: the 'rigid' wire has no stiffness"):
        wire_spec("rigid", k=2.0)
    with pytest.raises(ValueError, match="max_tension: required"):
        wire_spec("brittle")
    assert wire_spec("loose").to_law() == laws.LooseWire()
    with pytest.raises(ValueError, match="prestrain = 0.1"):
        wire_spec("loose", prestrain=0.1)
    # the campaign, the paper runner and the run files go through it
    from workbench import cli
    from workbench.campaign.experiments import _law as campaign_law
    from workbench.paper.runner import _law as paper_law

    assert campaign_law("rigid", None) == (True, laws.RigidWire())
    assert paper_law("elastic", 3) == (True, laws.ElasticWire(stiffness=3.0))
    assert cli.WireConfig(law="rigid_rod", prestrain=0.1).wire_law() == laws.RigidRod(prestrain=0.1)


@pytest.mark.parametrize("test", sorted(CONFIGS))
def test_the_run_file_model_is_the_configs_flat_view(test):
    from engine.experiments.params import PARAMS

    flat = flat_model(CONFIGS[test])
    assert PARAMS[test] is flat
    for part in ("solver", "friction", "preparation", "loading", "recording"):
        for name, f in CONFIGS[test].model_fields[part].annotation.model_fields.items():
            if name in flat.model_fields:        # the same field: default, bounds, words
                g = flat.model_fields[name]
                assert (g.default, g.metadata, g.description) == (f.default, f.metadata,
                                                                  f.description)


def test_a_run_file_and_the_python_call_give_the_same_config(tmp_path):
    from workbench import cli

    raw = {"test": "box_triaxial", "scale": 0.03, "seed": 4,
           "parameters": {"pressure": 20e3, "anderson": 3, "mu_wall": 0.1,
                          "compaction_mu": 0.2, "record_every": 5},
           "wire": {"law": "rigid", "prestrain": 0.02, "neighbour_contact": True}}
    cfg, params = cli.validate_config(raw, "f.toml")
    from_file = cli.file_config(cfg, params, tmp_path, progress=False)
    in_python = BoxConfig.from_kwargs(
        scale=0.03, seed=4, pressure=20e3, anderson=3, mu_wall=0.1, compaction_mu=0.2,
        record_every=5, wire_law=laws.RigidWire(prestrain=0.02), neighbour_contact=True,
        history=str(tmp_path / "run.h5"), progress=False)
    assert from_file == in_python
    assert from_file.solver.acceleration == Anderson(depth=3)
    assert from_file.wire.law == "rigid" and from_file.wire.prestrain == 0.02


def test_config_run_is_the_keyword_call(tmp_path):
    """A config runs the function with its keywords: the same result as the call."""
    import numpy as np

    kw = dict(dt=1e-4, steps=5, progress=False, max_nonconverged=1.0, frames=0)
    a = experiments.gravity_deposit(0.02, sample="box", history=str(tmp_path / "a.h5"), **kw)
    c = DepositConfig.from_kwargs(scale=0.02, sample="box", history=str(tmp_path / "b.h5"), **kw)
    b = c.run()
    assert np.array_equal(a.kinetic_energy, b.kinetic_energy)
    assert b.params["config"] == c.model_dump(mode="json")
    assert DepositConfig.model_validate(b.params["config"]) == c
    pa, pb = dict(a.params), dict(b.params)
    pa.pop("config"), pb.pop("config")
    assert pa == pb
    sa, sb = a.scalars(), b.scalars()
    for k in ("steps_wall_time", "history"):        # (the clock and the file differ)
        sa.pop(k, None), sb.pop(k, None)
    assert sa == sb


def test_slope_config_defaults_are_its_own():
    c = SlopeConfig()
    assert (c.scale, c.solver.tol, c.recording.record_every, c.loading.steps) == (0.02, 1e-4, 20, 4000)
    d = DepositConfig()
    assert (d.solver.dt, d.friction.mu_wall, d.preparation.sample) == (1e-4, 0.5, "slope")
    assert BoxConfig().friction.mu_wall == 0.0 and CylinderConfig().friction.mu_wall == 0.5


@pytest.mark.parametrize("test", sorted(CONFIGS))
def test_chain_solve_reaches_the_solver_and_conflicts_are_refused(test, monkeypatch, tmp_path):
    """``chain_solve=True`` is a keyword of every test: it ends in the compiled Options (the
    test's own Scene.compile), with Anderson mixing or two threads as well (since
    2026-12-05), and a conflict of the other options is still refused in one line before
    anything is built."""
    with pytest.raises((InputError, ValueError)) as e:
        getattr(experiments, test)(chain_solve=True, anderson=4, relax=1.5, progress=False,
                                   history=str(tmp_path / "h.h5"))
    assert "relax" in str(e.value) and "\n" not in str(e.value)
    for kw in (dict(anderson=4), dict(threads=2)):
        assert CONFIGS[test].from_kwargs(chain_solve=True, **kw).solver.chain_solve
    assert _compiled_with(test, monkeypatch, tmp_path, "chain_solve", True) is True


@pytest.mark.parametrize("test", sorted(CONFIGS))
def test_contact_compliance_reaches_the_solver_and_refuses_over_relaxation(test, monkeypatch,
                                                                           tmp_path):
    """``contact_compliance`` is a keyword of every test and of the run files' flat
    parameters: it ends in the test's own Scene.compile; with ``relax > 1`` it is refused
    in one line before anything is built."""
    from engine.experiments.config import flat_model

    with pytest.raises((InputError, ValueError)) as e:
        getattr(experiments, test)(contact_compliance=0.01, relax=1.5, progress=False,
                                   history=str(tmp_path / "h.h5"))
    assert "contact_compliance" in str(e.value) and "\n" not in str(e.value)
    assert flat_model(CONFIGS[test])(contact_compliance=0.01).contact_compliance == 0.01
    assert _compiled_with(test, monkeypatch, tmp_path, "contact_compliance", 0.01) == 0.01


#: The scale each test is built at below: 0.05, or the smallest a test takes (the pull-out
#: box is refused below 5 mean grain diameters across, scale 0.0963).
SMALL_SCALE = {"pullout_test": 0.1}


def _compiled_with(test, monkeypatch, tmp_path, key, value):
    """The ``key`` keyword that ``test`` (scale 0.05 or :data:`SMALL_SCALE`, ``key=value``)
    passes to its own Scene.compile, which is stopped there."""
    from engine import Scene

    seen = []

    def compile_(self, *a, **kw):
        seen.append(kw.get(key, "missing"))
        raise RuntimeError("stop after compile")

    monkeypatch.setattr(Scene, "compile", compile_)
    with pytest.raises(RuntimeError, match="stop after compile"):
        getattr(experiments, test)(scale=SMALL_SCALE.get(test, 0.05), progress=False,
                                   history=str(tmp_path / "h.h5"), **{key: value})
    assert seen
    return seen[-1]
