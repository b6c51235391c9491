"""The ``nscd`` command: demo end to end, config validation, info/render/export."""
import re
import numpy as np
import pytest

from workbench import cli


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo")
    assert cli.main(["demo", "--out", str(out), "--scale", "0.05", "--strain", "0.02"]) == 0
    return out


def test_demo_writes_what_it_promises(demo):
    from engine import io
    from workbench.series import read_pvd

    for name in ("run.h5", "stress_strain.png", "convergence.png", "beads.png", "wire.png",
                 "forces.png", "torus.png"):
        assert (demo / name).stat().st_size > 1000, name
    h = io.read_history(demo / "run.h5")
    frames = read_pvd(demo / "series" / "cylinder.pvd")
    # one PVD time per history frame, with the history's frame times
    times = sorted({f["timestep"] for f in frames})
    np.testing.assert_array_equal(times, h.frame_time)
    assert h.frame_step[0] == 0 and times[0] == 0.0      # the series starts at the start
    import imageio.v3 as iio                   # the demo's movie: one picture per frame
    movie = iio.imread(demo / "wire.mp4")
    assert movie.shape == (h.n_frames, 600, 800, 3) and movie.std() > 5


def test_info_render_export(demo, tmp_path, capsys):
    assert cli.main(["info", str(demo / "run.h5")]) == 0
    text = capsys.readouterr().out
    assert "history" in text and "frames" in text and "stress" in text
    # the run says what it is: its test, its main parameters and every argument
    assert "  test: cylinder_triaxial\n" in text
    params = re.search(r"  parameters: (.*)\n", text).group(1)
    assert "scale=0.05" in params and "axial_strain=0.02" in params
    density = float(re.search(r"wire_density=([\d.e+]+)", params).group(1))
    assert 1e5 < density < 1e6                    # the sample's own [m/m³], the paper's 250 km
    args = re.search(r"  its arguments: (.*)\n", text).group(1)
    assert "solver.max_overlap=0.5" in args and "loading.axial_strain=0.02" in args
    assert cli.main(["render", str(demo / "run.h5"), "--frame", "0", "--preset", "forces",
                     "--out", str(tmp_path / "f.png")]) == 0
    assert (tmp_path / "f.png").stat().st_size > 1000
    assert cli.main(["export", str(demo / "run.h5"), str(tmp_path / "s")]) == 0
    assert (tmp_path / "s" / "frame.pvd").exists()
    out = capsys.readouterr().out                # says how to open it, and the script is there
    assert f"paraview --script={tmp_path / 's' / 'open_in_paraview.py'}" in out
    assert (tmp_path / "s" / "open_in_paraview.py").exists()


@pytest.mark.parametrize("toml, expected", [
    ('test = "cylinder_triaxial"\nscale = 0.05\ncolour = "red"\n', "colour"),
    ('test = "cylinder_triaxial"\n[parameters]\npressure = -5.0\n',
     "parameters.pressure = -5.0: must be a number in (0, 1e+09]"),
    ('test = "box_triaxial"\n[parameters]\naxial_strain = "a lot"\n', "parameters.axial_strain"),
    ('test = "triaxial"\n', "test"),
    ('test = "slope_deposit"\nscale = 0\n', "scale = 0: must be a number in (0, 1]"),
    ('test = "slope_deposit"\n[parameters]\nmax_iter = 9223372036854775807\n',
     "parameters.max_iter = 9223372036854775807: must be an integer in [1, 1000000000]"),
    ('test = "slope_deposit"\n[wire]\nlaw = "rope"\n',
     "wire.law = 'rope': must be one of 'elastic', 'rigid', 'elastic_rod', 'rigid_rod', 'brittle', 'loose', 'none'"),
    ('test = "box_triaxial"\nsede = 1\n[parameters]\npresure = 1e4\ndt = -1\n',
     "3 problem(s) (box_triaxial)\n  sede = 1: unknown field (the fields are: test, scale, seed"),
    ('test = = 1', "not valid TOML"),
    ('test = "slope_deposit"\n[parameters]\nanderson = 4\nhot_sweeps = 2\n',
     "hot_sweeps = 2 works with the unmixed sweep only: set anderson=0 (got 4)"),
])
def test_bad_config_gives_one_clear_message(tmp_path, capsys, toml, expected):
    p = tmp_path / "c.toml"
    p.write_text(toml)
    assert cli.main(["run", str(p), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert expected in err
    assert "Traceback" not in err
    assert not (tmp_path / "o").exists()            # nothing ran


def test_good_config_runs(tmp_path):
    p = tmp_path / "c.toml"
    p.write_text('test = "box_triaxial"\nscale = 0.02\n[parameters]\naxial_strain = 0.004\n'
                 'iso_max_steps = 400\n[wire]\nlaw = "rigid"\n')
    assert cli.main(["run", str(p), "--out", str(tmp_path / "o")]) == 0
    assert (tmp_path / "o" / "run.h5").exists() and (tmp_path / "o" / "stress_strain.png").exists()


def test_deposit_config_runs_and_writes_its_convergence(tmp_path, capsys):
    """The Fig. 7 deposit from a run file (the box sample, ~100 grains): its history and
    the solver's convergence figure (no stress-strain curve: it has none).  The wire's
    ``neighbour_contact`` reaches the scene: no linked pair is left without contact."""
    from engine.io import load_model

    p = tmp_path / "d.toml"
    p.write_text('test = "gravity_deposit"\nscale = 0.02\n[parameters]\nsample = "box"\n'
                 '[wire]\nneighbour_contact = true\n')
    assert cli.main(["run", str(p), "--out", str(tmp_path / "o")]) == 0
    m = load_model(str(tmp_path / "o" / "run.h5"))
    assert m.n_links > 0 and (m.body_next == -1).all()
    out = capsys.readouterr().out
    assert "gravity_deposit: at rest after" in out and "tortuosity" in out
    assert (tmp_path / "o" / "convergence.png").exists()
    assert not (tmp_path / "o" / "stress_strain.png").exists()


def test_a_failed_run_is_one_line_with_exit_code_1(tmp_path, capsys):
    """A run that stops on non-convergence (2 sweeps per step cannot reach tol) exits 1 with
    the engine's message and where its history is, not a traceback."""
    p = tmp_path / "c.toml"
    p.write_text('test = "box_triaxial"\nscale = 0.02\n[parameters]\naxial_strain = 0.002\n'
                 'max_iter = 2\ntol = 1e-12\nmax_nonconverged = 0.1\niso_max_steps = 50\n')
    assert cli.main(["run", str(p), "--out", str(tmp_path / "o")]) == 1
    err = capsys.readouterr().err
    assert "nscd run: the run failed: box_triaxial: " in err and "hit max_iter" in err
    assert str(tmp_path / "o" / "run.h5") in err and "Traceback" not in err
    # the isotropic stage it did not finish is said on one line too
    assert "nscd run: warning: the isotropic stage did not reach" in err


def test_a_run_whose_overlaps_are_not_physical_fails_unless_asked_to_go_on(tmp_path, capsys):
    """dt = 10 ms (inside the documented range) lets the box test's grains sink into each
    other: the run stops with exit 1 past ``max_overlap`` (0.5 of the smaller radius), and
    the advice is a time step that would do, since the two bodies moved most of a radius
    against each other in one step (the advice used to offer "lower tol").  With
    ``max_overlap = 1000`` the user goes on past that step."""
    from engine.model import MAX_OVERLAP

    assert MAX_OVERLAP == 0.5
    p = tmp_path / "dt.toml"
    body = 'test = "box_triaxial"\nscale = 0.02\n[parameters]\ndt = 0.01\n' \
           'axial_strain = 0.002\niso_max_steps = 20\n'
    p.write_text(body)
    assert cli.main(["run", str(p), "--out", str(tmp_path / "a")]) == 1
    err = capsys.readouterr().err
    m = re.search(r"nscd run: the run failed: step (\d+) .* overlap by ([\d.]+) % of a radius, "
                  r"past max_overlap = 0\.5 \(results beyond it are not physical; "
                  r"max_overlap = 1000 goes on anyway\); the two bodies move ([\d.]+) % of a "
                  r"radius against each other in one step of dt = 0\.01 s: lower dt to "
                  r"([\d.e-]+) s or less", err)
    assert m, err[-800:]
    assert float(m.group(2)) > 50 and float(m.group(3)) > 5
    assert float(m.group(4)) == pytest.approx(0.01 * 5 / float(m.group(3)), rel=0.05)
    p.write_text(body + "max_overlap = 1000\n")
    assert cli.main(["run", str(p), "--out", str(tmp_path / "b")]) == 0
    err = capsys.readouterr().err
    assert "past max_overlap" not in err
    warned = re.findall(r"warning: overlaps up to ([\d.]+) % of a radius \(step (\d+)\), "
                        r"above 5 %: the two bodies move [\d.]+ % of a radius against each "
                        r"other in one step of dt = 0\.01 s: lower dt to", err)
    assert warned and max(float(w[0]) for w in warned) > 50


def test_an_interrupted_run_keeps_its_figures_and_exits_130(tmp_path, capsys, monkeypatch):
    """Ctrl-C at step 30 of the failing run above: no failure (the steps not run are not
    judged), the figures of the 30 steps, and the shell's code for SIGINT."""
    from tests.helpers import stop_runs_at

    stop_runs_at(monkeypatch, 30)
    p = tmp_path / "c.toml"
    p.write_text('test = "box_triaxial"\nscale = 0.02\n[parameters]\naxial_strain = 0.002\n'
                 'max_iter = 2\ntol = 1e-12\nmax_nonconverged = 0.1\n')
    assert cli.main(["run", str(p), "--out", str(tmp_path / "o")]) == cli.INTERRUPTED == 130
    out, err = capsys.readouterr()
    assert "30 steps, INTERRUPTED" in out and (tmp_path / "o" / "convergence.png").exists()
    assert "nscd run: interrupted after 30 steps" in err and "Traceback" not in err


def test_ctrl_c_outside_the_steps_is_one_line_with_exit_code_130(capsys, monkeypatch):
    def building(a):
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "cmd_info", building)
    assert cli.main(["info", "x.h5"]) == 130
    assert capsys.readouterr().err == "nscd info: interrupted\n"


def test_paths_that_cannot_be_used_are_one_line_with_exit_code_2(demo, tmp_path, capsys):
    (tmp_path / "afile").write_text("x")
    (tmp_path / "adir.toml").mkdir()
    for args, says in ((["export", str(demo / "run.h5"), str(tmp_path / "afile")],
                        f"nscd export: OUTDIR {tmp_path / 'afile'}: a file is there, and OUTDIR "
                        f"is a folder"),
                       (["run", str(tmp_path / "adir.toml")], "is a directory, not a TOML file"),
                       (["demo", "--scale", "-1", "--strain", "0.7", "--out", str(tmp_path / "d")],
                        "nscd demo: --scale = -1.0: must be a number in (0, 1]; --strain = 0.7: "
                        "must be a number in (0, 0.5]")):
        assert cli.main(args) == 2
        err = capsys.readouterr().err
        assert says in err and "Traceback" not in err
    assert not (tmp_path / "d").exists()              # the demo refused before writing


def test_arguments_that_cannot_mean_what_was_meant_are_refused(demo, tmp_path, capsys):
    """Output paths and options that would be taken otherwise than meant: a folder argument
    named like a file (a folder ``many.png`` of PNGs, a folder ``series.pvd``, a run's
    folder ``run.h5``), ``--fps`` without a movie, ``--clim`` on a picture with no colour
    scale.  Each is one line, exit 2, nothing written; a folder given for one picture
    receives it under the default name."""
    run = str(demo / "run.h5")
    cfg = tmp_path / "c.toml"
    cfg.write_text('test = "box_triaxial"\nscale = 0.02\n')
    for args, says in (
            (["render", run, "--frames", "all", "--out", str(tmp_path / "many.png")],
             "--out " + str(tmp_path / "many.png") + ": names a .png file, and --out is a "
             "folder (several frames go into it as frame_NNNN.png): give a folder name"),
            (["export", run, str(tmp_path / "series.pvd")], "names a .pvd file, and OUTDIR is "
                                                            "a folder"),
            (["run", str(cfg), "--out", str(tmp_path / "run.h5")], "names a .h5 file, and "
                                                                   "--out is a folder"),
            (["render", run, "--fps", "5", "--out", str(tmp_path / "a.png")],
             "--fps 5: frames per second are for --movie"),
            (["render", run, "--clim", "0,1", "--out", str(tmp_path / "b.png")],
             "--preset beads colours by kind, which has no scale: add --color-by speed")):
        assert cli.main(args) == 2, args
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and says in err[0], err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.toml"]
    (tmp_path / "pics").mkdir()
    assert cli.main(["render", run, "--out", str(tmp_path / "pics")]) == 0
    assert [p.name for p in (tmp_path / "pics").iterdir()] == ["run_beads.png"]


def test_an_internal_error_is_one_line_and_its_traceback_on_demand(demo, capsys,
                                                                    monkeypatch):
    def broken(a):
        {}["missing"]

    monkeypatch.setattr(cli, "cmd_info", broken)
    assert cli.main(["info", str(demo / "run.h5")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("nscd info: internal error (KeyError at "
                                               "test_cli.py:") and "NSCD_TRACEBACK=1" in err[0]
    monkeypatch.setenv("NSCD_TRACEBACK", "1")
    with pytest.raises(KeyError):
        cli.main(["info", str(demo / "run.h5")])


def test_a_scene_refuses_a_pair_declared_twice_and_a_closed_wire_of_two_beads():
    from engine import Scene, laws

    s = Scene()
    s.add_spheres([[0, 0, 0], [0.003, 0, 0]], 0.001, 2650.0)
    s.add_wire([[0, 0.01, 0], [0.0012, 0.01, 0], [0.0024, 0.01, 0]], 0.0005, 1400.0,
               law=laws.ElasticWire(stiffness=1.0))
    s.interact("sand", "wire", laws.Coulomb(mu=0.3))
    s.interact("wire", "sand", laws.Coulomb(mu=0.3))          # the same: fine
    with pytest.raises(ValueError, match=r"interact\('wire', 'sand'\): the pair has a law "
                                         r"already \(Coulomb\(mu=0.3\); either order is the "
                                         r"same pair\): pass replace=True"):
        s.interact("wire", "sand", laws.Coulomb(mu=0.5))
    s.interact("wire", "sand", laws.Coulomb(mu=0.5), replace=True)
    with pytest.raises(ValueError, match="a closed wire needs at least 3 beads, got 2"):
        s.add_wire([[0, 0.02, 0], [0.0012, 0.02, 0]], 0.0005, 1400.0,
                   law=laws.ElasticWire(stiffness=1.0), closed=True)


def test_inputs_that_are_not_regular_files_are_refused_before_they_are_opened(tmp_path,
                                                                               capsys):
    """A FIFO (opening it would block until a writer comes), a device (/dev/zero would be
    read until memory runs out) and an oversized run file are refused on one line with exit
    code 2, for every command that reads a path and for a run file's ``sample``."""
    import os

    fifo = tmp_path / "f.h5"
    os.mkfifo(fifo)
    os.mkfifo(tmp_path / "f.toml")
    (tmp_path / "s.toml").write_text(f'test = "cylinder_triaxial"\nscale = 0.05\n'
                                     f'[parameters]\nsample = "{fifo}"\n')
    (tmp_path / "big.toml").write_text("#" * (cli.RUN_FILE_MAX_BYTES + 1))
    for args, says in ((["info", str(fifo)], "a FIFO, not a regular file"),
                       (["render", str(fifo)], "a FIFO, not a regular file"),
                       (["export", str(fifo), str(tmp_path / "o")], "a FIFO, not a regular"),
                       (["run", str(tmp_path / "f.toml")], "a FIFO, not a regular file"),
                       (["run", str(tmp_path / "s.toml")], "a FIFO, not a regular file"),
                       (["run", "/dev/zero"], "a device, not a regular file"),
                       (["info", "/dev/zero"], "a device, not a regular file"),
                       (["run", str(tmp_path / "big.toml")], "more than the 1048576")):
        assert cli.main(args) == 2, args
        err = capsys.readouterr().err
        assert says in err and "Traceback" not in err and err.count("\n") == 1, (args, err)


def test_unreasonable_work_and_input_are_refused_up_front_in_bounded_lines(tmp_path, capsys):
    """A run file nested 5 000 deep (RecursionError in the TOML reader), a list of 40 000
    strains (the message shows 80 characters of it and says how long it is; the run does
    not start) and a sweep of 10⁶ cases (refused with its size and the override, before
    any case runs): one bounded message each, exit code 2."""
    head = 'test = "cylinder_triaxial"\nscale = 0.05\n[parameters]\n'
    (tmp_path / "deep.toml").write_text(head + "x = " + "[" * 5000 + "]" * 5000 + "\n")
    (tmp_path / "long.toml").write_text(head + "torus_strains = [" + ",".join(["0.01"] * 40000)
                                        + "]\n")
    grid = ["--grid", "seed=" + ",".join(map(str, range(1000))),
            "--grid", "mu=" + ",".join(str(0.001 * k) for k in range(1, 1001))]
    for args, says in ((["run", str(tmp_path / "deep.toml")], "nested too deep"),
                       (["run", str(tmp_path / "long.toml")],
                        "(240000 characters, 40000 items): list should have at most 100 items"),
                       (["sweep", "cylinder_triaxial", *grid, "--scheduler", "serial",
                         "--out", str(tmp_path / "s.json")],
                        "the grid has 1000000 cases (seed 1000 × mu 1000), more than "
                        "--max-cases 1000")):
        assert cli.main(args) == 2, args
        err = capsys.readouterr().err
        assert says in err and "Traceback" not in err, (args, err[:300])
        assert max(len(line) for line in err.splitlines()) <= cli.MESSAGE_MAX + 60
    assert not (tmp_path / "s.json").exists()
    assert cli.bounded("x" * 1000, 10) == "x" * 10 + "… (990 more characters)"


def test_run_help_lists_every_parameter_with_its_range(capsys):
    with pytest.raises(SystemExit):
        cli.main(["run", "--help"])
    out = capsys.readouterr().out
    for line in ("scale: default None; a number in (0, 1] — sample size (1: the paper's); "
                 "default: the test function's own (cylinder_triaxial 0.05, box_triaxial "
                 "0.05, slope_deposit 0.02, gravity_deposit 0.05, pullout_test 0.2)",
                 "law: default 'elastic'; one of 'elastic', 'rigid', 'elastic_rod', 'rigid_rod', "
                 "'brittle', 'loose', 'none' — elastic: ElasticWire",
                 "[parameters] of slope_deposit:", "theta: default 0.5; a number in [0.5, 1]",
                 "pressure: default 15000.0; a number in (0, 1e+09] — [Pa]",
                 "strain_rate: default None; a number in (0, 1000] — [1/s]"):
        assert line in out, line
    for name in cli.CylinderParams.model_fields:
        assert f"  {name}: " in out


#: keywords of the test functions a run file does not set: the outputs, the wire (its
#: [wire] table) and the sample size and seed (top level)
NOT_IN_PARAMETERS = {"scale", "seed", "wire", "wire_law", "neighbour_contact", "history",
                     "progress"}


@pytest.mark.parametrize("test", sorted(cli._PARAMS))
def test_run_file_defaults_are_the_test_functions(test):
    """A key left out of a run file runs with the Python function's default: every keyword
    of the test function is a [parameters] key (or set elsewhere in the file), with the
    same default, and that default is inside the key's own range."""
    import inspect

    from engine import experiments

    sig = inspect.signature(getattr(experiments, test)).parameters
    cls = cli._PARAMS[test]
    assert set(cls.model_fields) == set(sig) - NOT_IN_PARAMETERS
    for name, f in cls.model_fields.items():
        want = sig[name].default
        got = f.default
        assert (list(got) if isinstance(got, (list, tuple)) else got) == \
            (list(want) if isinstance(want, (list, tuple)) else want), (test, name, got, want)
    cls(**{n: f.default for n, f in cls.model_fields.items()})   # validated, unlike defaults
    assert sig["seed"].default == cli.RunConfig.model_fields["seed"].default
    from engine.experiments.common import DEFAULT_WIRE_STIFFNESS
    assert cli.WireConfig.model_fields["stiffness"].default == DEFAULT_WIRE_STIFFNESS


def test_run_file_numbers_are_not_strings(tmp_path, capsys):
    cfg = tmp_path / "s.toml"
    cfg.write_text('test = "slope_deposit"\nscale = "0.02"\n[parameters]\ndt = "1e-5"\n'
                   'steps = true\n')
    assert cli.main(["run", str(cfg), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    for line in ("scale = '0.02': must be a number in (0, 1], not a string",
                 "parameters.dt = '1e-5': must be a number in (0, 0.01], not a string",
                 "parameters.steps = True: must be an integer in [1, 1000000000], not a bool"):
        assert line in err, (line, err)


def test_render_camera_choices_are_the_presets(capsys):
    from workbench.render import CAMERAS

    with pytest.raises(SystemExit):
        cli.main(["render", "--help"])
    out = capsys.readouterr().out
    assert "{" + ",".join(CAMERAS) + "}" in out


def test_help_on_every_command(capsys):
    for cmd in ([], ["demo"], ["run"], ["render"], ["export"], ["info"]):
        with pytest.raises(SystemExit) as e:
            cli.main([*cmd, "--help"])
        assert e.value.code == 0
        assert "usage: nscd" in capsys.readouterr().out


@pytest.mark.parametrize("command", ["info", "render", "export"])
def test_commands_refuse_a_file_that_is_not_ours(command, tmp_path, capsys):
    """A text file, an HDF5 file of someone else's, a missing file: exit code 2 and one
    line naming the file, not a traceback."""
    import h5py

    text = tmp_path / "notes.h5"
    text.write_text("not HDF5")
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f["x"] = [1.0]
    for path, says in ((text, "not a readable HDF5 file"), (other, "not an nscd-workbench"),
                       (tmp_path / "missing.h5", "no such file")):
        args = [command, str(path)] + ([str(tmp_path / "out")] if command == "export" else [])
        assert cli.main(args) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"nscd {command}: ") and says in err and str(path) in err
        assert "Traceback" not in err


def test_run_files_know_every_wire_law(tmp_path):
    """[wire] law is any law of the engine, with its stiffness, prestrain and max_tension;
    the run gets that law object; a parameter the law has not is refused by name."""
    from engine import laws

    ok = {"elastic": ({}, laws.ElasticWire(stiffness=1.0)),
          "rigid": ({"prestrain": 0.01}, laws.RigidWire(prestrain=0.01)),
          "elastic_rod": ({"stiffness": 5.0}, laws.ElasticRod(stiffness=5.0)),
          "rigid_rod": ({}, laws.RigidRod()),
          "brittle": ({"stiffness": 2.0, "max_tension": 0.5},
                      laws.BrittleElasticWire(stiffness=2.0, max_tension=0.5)),
          "loose": ({}, laws.LooseWire()),
          "none": ({}, None)}
    for law, (kw, want) in ok.items():
        cfg, _ = cli.validate_config({"test": "gravity_deposit", "wire": {"law": law, **kw}})
        assert cfg.wire.wire_law() == want, law
    for wire, says in (({"law": "brittle"}, "max_tension: required by the 'brittle' wire"),
                       ({"law": "rigid_rod", "stiffness": 2.0}, "the 'rigid_rod' wire has no "
                                                                "stiffness"),
                       ({"law": "elastic", "max_tension": 1.0}, "has no max_tension"),
                       ({"law": "loose", "stiffness": 1.0}, "the 'loose' wire has no stiffness"),
                       ({"law": "elastic", "prestrain": 2.0},
                        r"wire.prestrain = 2.0: must be a number in \(-1, 1\]")):
        with pytest.raises(cli.ConfigError, match=says):
            cli.validate_config({"test": "gravity_deposit", "wire": wire})


@pytest.mark.slow
def test_a_run_file_starts_from_a_deposits_end_state(tmp_path):
    """``sample = "DEPOSIT.h5"`` in [parameters]: the test starts from the file's last state
    with its wire's own law (the same run as in Python); a [wire] law beside it is refused
    at validation, naming both."""
    from engine.experiments import cylinder_triaxial, gravity_deposit
    from engine.prep import cylinder_sample

    dep = gravity_deposit(sample=cylinder_sample(0.05, seed=0), dt=5e-5, tol=3e-4,
                          steps=300, history=str(tmp_path / "dep.h5"), progress=False)
    raw = {"test": "cylinder_triaxial", "scale": 0.05,
           "parameters": {"sample": dep.history, "axial_strain": 0.003}}
    cfg, params = cli.validate_config(raw)
    res = cli.run_config(cfg, params, tmp_path / "run", progress=False)
    ref = cylinder_triaxial(sample=dep.history, axial_strain=0.003, progress=False,
                            history=str(tmp_path / "ref.h5"))
    assert res.params["sample"] == f"the end state of {dep.history}"
    assert np.array_equal(res.deviator, ref.deviator)
    with pytest.raises(cli.ConfigError, match="wire: a \\[wire\\] law with parameters.sample"):
        cli.validate_config(dict(raw, wire={"law": "rigid"}))
    cli.validate_config(dict(raw, wire={"law": "none"}))       # accepted: a sand-only check


def test_sweep_and_paper_take_a_cluster_by_name(tmp_path, capsys, monkeypatch):
    """``--cluster NAME --cluster-option K=V ... --workers N`` of ``nscd sweep`` and ``nscd
    paper`` reach the campaign as a ClusterSpec (``--scheduler`` as before); a name not
    in workbench.campaign.CLUSTERS, an option not NAME=VALUE, an option of the cluster's class that
    does not exist or both --scheduler and --cluster are one line and exit code 2."""
    from workbench import campaign
    import workbench.paper as wp
    from workbench.campaign import ClusterSpec

    assert cli.parse_cluster_options(["cores=2", "memory=4GB", "walltime=01:00:00",
                                      "job_script_prologue=[\"module load x\"]"]) == {
        "cores": 2, "memory": "4GB", "walltime": "01:00:00",
        "job_script_prologue": ["module load x"]}
    got = []
    monkeypatch.setattr(campaign, "sweep", lambda test, grid, where, **kw: got.append(where)
                        or campaign.SweepTable())
    monkeypatch.setattr(wp, "build_report", lambda *a, **kw: got.append(kw["scheduler"])
                        or (_ for _ in ()).throw(ValueError("stop here")))
    base = ["sweep", "box_triaxial", "--grid", "seed=0", "--out", str(tmp_path / "t.json")]
    assert cli.main(base + ["--cluster", "slurm", "--cluster-option", "cores=2",
                            "--cluster-option", "memory=4GB", "--workers", "8"]) == 0
    assert got[-1] == ClusterSpec("slurm", {"cores": 2, "memory": "4GB"}, 8)
    assert cli.main(base) == 0 and got[-1] is None                 # a LocalCluster of 2
    assert cli.main(base + ["--scheduler", "serial"]) == 0 and got[-1] == "serial"
    assert cli.main(["paper", "--scale", "tiny", "--cluster", "jobqueue-local",
                     "--cluster-option", "cores=1", "--out", str(tmp_path / "p")]) == 2
    assert got[-1] == ClusterSpec("jobqueue-local", {"cores": 1}, 2)
    capsys.readouterr()
    for args, says in ((["--cluster-option", "cores"], "--cluster-option 'cores': expected "
                                                       "NAME=VALUE"),
                       (["--scheduler", "tcp://h:8786", "--cluster", "pbs"],
                        "--scheduler and --cluster / --cluster-option: give one of them"),
                       (["--cluster", "local", "--workers", "0"],
                        r"n_workers \(--workers\) must be an integer in \[1, 1024\], got 0")):
        assert cli.main(base + args) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and re.search(says, err), err
    with pytest.raises(SystemExit):
        cli.main(base + ["--cluster", "slurmx"])
    err = capsys.readouterr().err
    assert "--cluster: invalid choice: 'slurmx'" in err and "slurm" in err and "pbs" in err


def test_the_example_run_files_validate_and_the_controls_are_twins():
    """Every run file of examples/runs/ is accepted as it is (one per test), and the
    loose-bead control differs from its TexSol run in the wire law alone."""
    from pathlib import Path

    files = sorted((Path(__file__).resolve().parents[2] / "examples" / "runs").glob("*.toml"))
    loaded = {f.stem: cli.load_config(f) for f in files}
    assert {c.test for c, _ in loaded.values()} == {
        "cylinder_triaxial", "box_triaxial", "slope_deposit", "gravity_deposit", "pullout_test"}
    (a, pa), (b, pb) = loaded["cylinder_triaxial"], loaded["cylinder_controls"]
    assert a.model_dump(exclude={"wire"}) == b.model_dump(exclude={"wire"})
    assert pa.model_dump() == pb.model_dump()
    assert (a.wire.law, b.wire.law) == ("elastic", "loose")


def test_a_run_file_with_a_byte_order_mark_reads_as_without(tmp_path):
    """Some editors start a UTF-8 file with a byte-order mark; TOML read it as an invalid
    statement at line 1, column 1."""
    text = 'test = "box_triaxial"\nscale = 0.05\n[parameters]\npressure = 2e3\n'
    p = tmp_path / "bom.toml"
    p.write_bytes("\ufeff".encode() + text.encode())
    q = tmp_path / "plain.toml"
    q.write_text(text)
    assert cli.load_config(p)[1] == cli.load_config(q)[1]
    assert cli.load_config(p)[1].pressure == 2e3


def test_sweep_out_a_folder_puts_the_table_inside_it(tmp_path, monkeypatch, capsys):
    """--out DIR (an existing folder) writes DIR/sweep_<test>.json and the runs beside it
    inside DIR (it wrote DIR.json beside the folder); a table path not ending in .json is
    refused in one line."""
    from workbench import campaign

    got = []
    monkeypatch.setattr(campaign, "sweep", lambda test, grid, where, **kw: got.append(kw)
                        or campaign.SweepTable())
    d = tmp_path / "results"
    d.mkdir()
    assert cli.main(["sweep", "box_triaxial", "--grid", "seed=0", "--out", str(d)]) == 0
    assert got[-1]["out"] == d / "sweep_box_triaxial.json"
    assert got[-1]["fixed"]["history_dir"] == str(d / "sweep_box_triaxial_runs")
    capsys.readouterr()
    assert cli.main(["sweep", "box_triaxial", "--grid", "seed=0", "--out",
                     str(tmp_path / "t.csv")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "the sweep's table is a JSON file" in err
