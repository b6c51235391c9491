"""Faults a run must survive without losing or mixing data (issue 33): a full disk, a second
writer on the same history, a file that is not ours where a run writes, a corrupt history
beside a good checkpoint, files that cannot be read for a reason the message must say.

The full-disk tests mount a small tmpfs (root only; skipped with the reason otherwise); the
lock tests use real processes."""
import dataclasses
import os
import signal
import subprocess
import sys
import textwrap
import time
import warnings
from pathlib import Path

import h5py
import numpy as np
import pytest

from engine import io, run
from engine.step import CallbackWriter, NonConvergenceWarning
from tests.engine.test_io import scene

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


def _run_quiet(model, state, n, writers):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NonConvergenceWarning)
        return run(model, state, n, writers=writers, progress=False)


def _history_run(path, steps=300, writers=(), frames=5):
    model, state = scene()
    h = io.History(path, frames=frames, flush=frames)
    try:
        _run_quiet(model, state, steps, [h, *writers])
    finally:
        h.close()


# -- 1. a full disk -----------------------------------------------------------------------------
def test_a_full_disk_stops_the_history_cleanly_and_keeps_what_was_written(tmp_path,
                                                                         small_disk):
    """The run fills a 1 MiB disk: it stops with one WriteFailed line (ENOSPC) before HDF5
    ever meets the full disk, and the file keeps, complete and bit for bit, the records and
    frames of the same run on a large disk up to its last flush (no frame of zeros)."""
    import errno

    ref = tmp_path / "ref.h5"
    _history_run(ref)
    full = small_disk(1024) / "run.h5"
    with pytest.raises(io.WriteFailed) as e:
        _history_run(full)
    msg = str(e.value)
    assert e.value.errno == errno.ENOSPC and "\n" not in msg
    assert msg.startswith(f"{full}: the history stopped at step ") and "the disk is full" in msg
    a, b = io.read_history(ref), io.read_history(full)
    assert 0 < b.n_frames < a.n_frames and 0 < b.n_records < a.n_records
    assert f"it keeps {b.n_records} records and {b.n_frames} frames" in msg
    for name in ("step", "time", "kinetic_energy", "residual", "wall_force"):
        np.testing.assert_array_equal(getattr(b, name), getattr(a, name)[:b.n_records])
    for name in ("frame_step", "position", "velocity", "link_tension"):
        np.testing.assert_array_equal(getattr(b, name), getattr(a, name)[:b.n_frames])
    assert np.all(np.abs(b.position).sum(axis=(1, 2)) > 0)
    assert not list(full.parent.glob(".run.h5.*"))     # no reserve or lock file left


CHILD_FILLER = textwrap.dedent("""
    import sys, warnings
    from engine import io, run
    from engine.step import CallbackWriter, NonConvergenceWarning
    from tests.engine.test_io import scene

    path, filler = sys.argv[1], sys.argv[2]

    def fill(model, state):          # another program fills the disk at step 100
        try:
            with open(filler, "wb", buffering=0) as f:
                while True:
                    f.write(b"x" * 4096)
        except OSError:
            pass

    model, state = scene()
    h = io.History(path, frames=5, flush=5)
    warnings.simplefilter("ignore", NonConvergenceWarning)
    try:
        run(model, state, 300, writers=[CallbackWriter(fill, lambda s: s == 100), h],
            progress=False)
    except io.WriteFailed as e:
        print(e)
    h.close()
""")


def test_a_disk_filled_by_another_program_stops_the_run_cleanly(tmp_path, small_disk):
    """Another program takes the whole disk in the middle of the run: the next write of the
    history stops it (one line, no segmentation fault: the process exits 0), and the file
    holds the steps up to its last flush, readable."""
    disk = small_disk(4096)
    script = tmp_path / "child.py"
    script.write_text(CHILD_FILLER)
    r = subprocess.run([sys.executable, str(script), str(disk / "run.h5"), str(disk / "fill")],
                       cwd=ROOT, env=ENV, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "the history stopped at step 10" in r.stdout and "the disk is full" in r.stdout
    assert "Traceback" not in r.stderr
    d = io.read_history(disk / "run.h5")
    assert d.step[-1] == 100 and d.frame_step[-1] == 100
    assert np.all(np.abs(d.position).sum(axis=(1, 2)) > 0)


def test_nscd_run_on_a_full_disk_exits_1_with_one_line(small_disk):
    """``nscd run`` of the paper's gravity deposit (scale 0.02) on a 256 KiB disk: exit code
    1, one line on stderr naming the file and the full disk, no traceback."""
    disk = small_disk(256)
    cfg = disk.parent / "gd.toml"
    cfg.write_text('test = "gravity_deposit"\nscale = 0.02\nseed = 0\n')
    r = subprocess.run([sys.executable, "-m", "workbench.cli", "run", str(cfg), "--out",
                        str(disk / "run")], cwd=ROOT, env=ENV, capture_output=True, text=True,
                       timeout=600)
    lines = [ln for ln in r.stderr.replace("\r", "\n").splitlines()
             if ln.startswith("nscd") or "Error" in ln or "Traceback" in ln]
    assert r.returncode == 1, r.stderr[-2000:]
    assert lines == [lines[0]] and lines[0].startswith(f"nscd run: stopped: {disk}/run/run.h5:")
    assert "the disk is full" in lines[0]


def test_a_frame_written_after_the_last_flush_is_not_read(tmp_path):
    """A frame and records whose rows exist but that no flush marked complete (the data a
    full disk or a kill lost read as zeros) are left out by every reader."""
    path = tmp_path / "run.h5"
    _history_run(path, steps=50)
    d0 = io.read_history(path)
    with h5py.File(path, "a") as f:        # a torn frame and record: rows without the mark
        fg = f["frames"]
        for name in ("step", "time", "position", "velocity", "spin", "link_tension",
                     "link_broken", "contact_start", "contact_count"):
            fg[name].resize(fg[name].shape[0] + 1, axis=0)
        for name in f["records"]:
            if name != "wall_ids":
                f["records"][name].resize(f["records"][name].shape[0] + 1, axis=0)
    d = io.read_history(path)
    assert (d.n_frames, d.n_records) == (d0.n_frames, d0.n_records)
    assert io.frame_index(path)[0].size == d0.n_frames
    np.testing.assert_array_equal(io.read_frame(path, -1).position, d0.position[-1])


# -- 2. one writer per history ------------------------------------------------------------------
CHILD_HOLDER = textwrap.dedent("""
    import sys, time
    from engine import io
    h = io.History(sys.argv[1])
    print("holding", flush=True)
    time.sleep(600)
""")


def test_a_second_writer_is_refused_and_a_killed_ones_lock_does_not_block(tmp_path):
    """A process writes run.h5: a History on the same file in another process is refused
    (RunLocked, naming the holder's pid) and the file is left as it was; once the holder is
    killed (SIGKILL: no cleanup), the next writer gets the lock at once."""
    path = tmp_path / "run.h5"
    script = tmp_path / "holder.py"
    script.write_text(CHILD_HOLDER)
    proc = subprocess.Popen([sys.executable, str(script), str(path)], cwd=ROOT, env=ENV,
                            stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "holding"
        before = path.stat()
        with pytest.raises(io.RunLocked) as e:
            io.History(path)
        assert f"pid {proc.pid} on " in str(e.value) and "\n" not in str(e.value)
        assert path.stat().st_mtime_ns == before.st_mtime_ns
        assert path.stat().st_size == before.st_size
    finally:
        proc.kill()
        proc.wait()
    h = io.History(path)                  # the killed holder's lock is free
    h.close()
    assert not (tmp_path / ".run.h5.lock").exists()


TRY_LOCK = textwrap.dedent("""
    import sys
    from engine import io
    try:
        io.lock_history(sys.argv[1])
        print("got it")
    except io.RunLocked as e:
        print("refused:", e)
""")


def test_lock_history_is_shared_in_a_process_and_held_until_its_last_release(tmp_path):
    """io.lock_history: two holders in this process share one lock; another process is
    refused (one line naming this pid) until the last holder releases it."""
    path = tmp_path / "out" / "run.h5"          # the folder does not exist yet
    script = tmp_path / "try.py"
    script.write_text(TRY_LOCK)

    def other() -> str:
        return subprocess.run([sys.executable, str(script), str(path)], cwd=ROOT, env=ENV,
                              capture_output=True, text=True, timeout=120).stdout.strip()

    a = io.lock_history(path)
    b = io.lock_history(path)
    assert not a.stale
    said = other()
    assert said.startswith(f"refused: {path}: ") and f"pid {os.getpid()} on " in said
    a.release()
    assert other().startswith("refused:")
    b.release()
    assert other() == "got it"
    assert isinstance(io.RunLocked(11, "x", "f"), io.FileProblem)
    assert str(io.WriteFailed("f.h5", 28, "the disk is full")) == "f.h5: the disk is full"


def test_free_bytes_follows_what_is_written_on_the_disk(small_disk):
    """io.free_bytes on a 4 MiB tmpfs: about 4 MiB for a path not created yet (the nearest
    existing folder is looked at), 1 MiB less after a 1 MiB file is written."""
    d = small_disk(4096)
    before = io.free_bytes(d / "not" / "yet" / "run.h5")
    assert 4096 * 1024 - 64 * 1024 <= before <= 4096 * 1024
    (d / "ballast").write_bytes(b"\0" * (1 << 20))
    assert before - io.free_bytes(d) == pytest.approx(1 << 20, abs=8192)


@pytest.mark.slow
def test_a_second_nscd_run_on_the_same_out_is_refused_and_the_first_goes_on(tmp_path):
    """Two ``nscd run`` on one --out: the second (another mu, which would start afresh and
    remove the first's checkpoint) exits 2 naming the other run; the first ends normally
    with its history whole."""
    cfg = tmp_path / "a.toml"
    cfg.write_text('test = "gravity_deposit"\nscale = 0.02\nseed = 0\n'
                   '[parameters]\nsteps = 300\ncheckpoint_every = 100\nmax_nonconverged = 1.0\n')
    other = tmp_path / "b.toml"
    other.write_text(cfg.read_text().replace("[parameters]\n", "[parameters]\nmu = 0.3\n"))
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "workbench.cli", "run", "--out", str(out)]
    first = subprocess.Popen([*cmd, str(cfg)], cwd=ROOT, env=ENV, stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True)
    try:
        t0 = time.monotonic()
        while not (out / "run.h5").exists() and time.monotonic() - t0 < 120:
            time.sleep(0.2)
        second = subprocess.run([*cmd, str(other)], cwd=ROOT, env=ENV, capture_output=True,
                                text=True, timeout=300)
        _, err = first.communicate(timeout=600)
    finally:
        if first.poll() is None:
            first.kill()
            first.wait()
    assert second.returncode == 2, second.stderr[-2000:]
    assert "another run is writing this history" in second.stderr
    assert f"pid {first.pid} " in second.stderr
    assert first.returncode == 0, err[-2000:]
    d = io.read_history(out / "run.h5")
    assert d.step[-1] == 300 and np.array_equal(d.step, np.arange(0, 301, d.step[1]))
    assert io.history_meta(out / "run.h5")["params"]["mu"] == 0.5     # the first run's


# -- 6. nothing replaced that is not ours -------------------------------------------------------
def test_save_and_history_replace_only_their_own_kind(tmp_path):
    """``io.save`` and ``History`` refuse to replace a text file, a foreign HDF5 file or the
    other kind of ours (FileExistsError, one line, the file untouched); they replace their
    own kind, and anything with ``overwrite=True``."""
    model, state = scene()
    text = tmp_path / "notes.txt"
    text.write_text("my notes")
    foreign = tmp_path / "foreign.h5"
    with h5py.File(foreign, "w") as f:
        f["x"] = 1
    hist = tmp_path / "hist.h5"
    io.History(hist).close()
    ckpt = tmp_path / "ckpt.h5"
    io.save(ckpt, model, state)
    for target, writer in ((text, "save"), (foreign, "save"), (hist, "save"),
                           (text, "history"), (foreign, "history"), (ckpt, "history")):
        before = target.read_bytes()
        with pytest.raises(FileExistsError) as e:
            io.save(target, model, state) if writer == "save" else io.History(target)
        assert str(target) in str(e.value) and "overwrite=True" in str(e.value)
        assert "\n" not in str(e.value)
        assert target.read_bytes() == before
    io.save(ckpt, model, state)                       # its own kind
    io.History(hist).close()
    io.save(text, model, state, overwrite=True)
    assert io.file_content(text)[0] == "checkpoint"
    io.History(foreign, overwrite=True).close()
    assert io.file_content(foreign)[0] == "history"


def test_nscd_run_keeps_a_foreign_run_h5_unless_forced(tmp_path):
    from workbench.cli import main

    cfg = tmp_path / "a.toml"
    cfg.write_text('test = "gravity_deposit"\nscale = 0.02\nseed = 0\n'
                   '[parameters]\nsteps = 20\nmax_nonconverged = 1.0\n')
    out = tmp_path / "out"
    out.mkdir()
    (out / "run.h5").write_text("someone's data")
    assert main(["run", str(cfg), "--out", str(out)]) == 2
    assert (out / "run.h5").read_text() == "someone's data"
    assert main(["run", str(cfg), "--out", str(out), "--force"]) == 0
    assert io.read_history(out / "run.h5").step[-1] == 20


def test_nscd_run_keeps_an_earlier_run_under_a_new_name(tmp_path, capsys):
    """A finished run.h5 is never replaced in silence: a second run (with other parameters,
    resume = true or not: there is no checkpoint to go on from) keeps it as run.1.h5,
    then run.2.h5, and says so; --force replaces it."""
    from workbench.cli import main

    cfg = tmp_path / "a.toml"
    out = tmp_path / "out"
    for k, (steps, extra) in enumerate([(20, ""), (30, ""), (40, "resume = true\n")]):
        cfg.write_text('test = "gravity_deposit"\nscale = 0.02\nseed = 0\n[parameters]\n'
                       f'steps = {steps}\nmax_nonconverged = 1.0\n{extra}')
        assert main(["run", str(cfg), "--out", str(out)]) == 0
        said = capsys.readouterr().out
        assert (f"the earlier run.h5 is kept as {out / f'run.{k}.h5'}" in said) == (k > 0)
    assert [io.read_history(out / n).step[-1] for n in ("run.1.h5", "run.2.h5", "run.h5")] \
        == [20, 30, 40]
    assert main(["run", str(cfg), "--out", str(out), "--force"]) == 0
    assert "kept as" not in capsys.readouterr().out
    assert not (out / "run.3.h5").exists()


def test_a_corrupt_history_does_not_remove_a_good_checkpoint(tmp_path, monkeypatch):
    """A deposit stopped by Ctrl-C leaves its checkpoint; its history then gets corrupted:
    the resume refuses (ValueError naming both files) and the checkpoint is kept."""
    from engine.experiments import gravity_deposit
    from tests.helpers import stop_runs_at

    kw = dict(sample="box", progress=False, checkpoint_every=100)
    hist = tmp_path / "b.h5"
    with monkeypatch.context() as mp:
        stop_runs_at(mp, 150, "sigint")
        assert gravity_deposit(0.02, history=str(hist), **kw).convergence["interrupted"]
    ck = tmp_path / "b.resume.h5"
    good = ck.read_bytes()
    with open(hist, "r+b") as f:
        f.truncate(hist.stat().st_size // 3)
    with pytest.raises(ValueError, match="cannot resume") as e:
        gravity_deposit(0.02, history=str(hist), resume=True, **kw)
    assert str(ck) in str(e.value) and "is kept" in str(e.value)
    assert ck.read_bytes() == good


# -- 8. messages that say what happened ---------------------------------------------------------
def test_reading_a_folder_a_text_file_or_a_locked_file_says_so(tmp_path):
    folder = tmp_path / "run.h5"
    folder.mkdir()
    with pytest.raises(IsADirectoryError, match="is a folder, not a file"):
        io.read_history(folder)
    text = tmp_path / "notes.h5"
    text.write_text("hello")
    with pytest.raises(io.FormatError, match=r"not a readable HDF5 file \(its first bytes are "
                                             r"b'hello', not HDF5's signature\)"):
        io.read_history(text)
    locked = tmp_path / "locked.h5"
    with h5py.File(locked, "w") as f:    # a program writing it, HDF5's lock held, no SWMR
        f["x"] = 1
        f.flush()
        r = subprocess.run([sys.executable, "-c", "import sys; from engine import io; "
                            "io.file_content(sys.argv[1])", str(locked)], cwd=ROOT,
                           env={**ENV, "HDF5_USE_FILE_LOCKING": "TRUE"}, capture_output=True,
                           text=True, timeout=120)
    last = r.stderr.strip().splitlines()[-1]
    assert "another program holds HDF5's lock on it" in last, r.stderr[-1500:]


# -- 7. strict types ----------------------------------------------------------------------------
def test_strings_and_bools_for_numbers_and_numbers_for_bools_are_refused_by_name():
    """The issue's instances: a string density, string gravity, True for a radius; in a run
    file resume = "yes", neighbour_contact = 1, a stiffness for the rigid wire; a scale
    beyond what the tests can build."""
    from engine import Scene
    from engine.experiments import gravity_deposit
    from workbench import cli

    cases = {"density": lambda s: s.add_spheres([[0, 0, 1e-3]], 1e-3, density="2650"),
             "radii": lambda s: s.add_spheres([[0, 0, 1e-3]], True, density=2650.0),
             "gravity": lambda s: Scene(gravity=("0", "0", "-9.81")),
             "point": lambda s: s.add_plane(point={}, normal=(0, 0, 1)),
             "velocity": lambda s: s.drive(s.add_plane(), velocity=("0", "0", "1"))}
    for name, fn in cases.items():
        with pytest.raises(ValueError, match=name) as e:
            fn(Scene())
        assert "\n" not in str(e.value)
    bad = {"resume": ({"test": "gravity_deposit", "parameters": {"resume": "yes"}},
                      "parameters.resume = 'yes': must be true or false, not str"),
           "neighbour_contact": ({"test": "gravity_deposit",
                                  "wire": {"neighbour_contact": 1}},
                                 "wire.neighbour_contact = 1: must be true or false, not int"),
           "stiffness": ({"test": "gravity_deposit", "wire": {"law": "rigid", "stiffness": 3.0}},
                         "the 'rigid' wire has no stiffness"),
           "steps": ({"test": "gravity_deposit", "parameters": {"steps": 10**12}},
                     r"parameters.steps = 1000000000000: must be an integer in \[1, 1000000000\]")}
    for name, (raw, says) in bad.items():
        with pytest.raises(cli.ConfigError, match=says):
            cli.validate_config(raw, "f.toml")
    with pytest.raises(ValueError, match=r"scale must be a number in \(0, 10\]"):
        gravity_deposit(1e9)
    with pytest.raises(ValueError, match="scale must be a number"):
        gravity_deposit("0.05")


def test_the_python_tests_refuse_knobs_out_of_range_before_any_work(tmp_path, monkeypatch):
    """Item 3 in Python: the test functions check their arguments against the same models
    as run files and sweep grids (engine.experiments.params), before a sample is built (the
    builders are replaced by a function that fails the test if reached), and name each
    field on one line."""
    from engine import experiments
    from engine.experiments import deposit, slope, triaxial

    def never(*a, **k):
        raise AssertionError("a sample was built before the arguments were checked")

    for mod, name in ((triaxial, "cylinder_sample"), (triaxial, "box_sample"),
                      (slope, "slope_sample"), (deposit, "paper_sample")):
        monkeypatch.setattr(mod, name, never)
    h = str(tmp_path / "h.h5")
    cases = [(experiments.cylinder_triaxial, dict(record_every=10**12),
              r"cylinder_triaxial: record_every = 1000000000000: must be an integer in "
              r"\[1, 1000000000\]"),
             (experiments.cylinder_triaxial, dict(pressure=2e9, seed=2**64),
              r"pressure = 2000000000.0: must be a number in \(0, 1e\+09\]; seed = "
              r"18446744073709551616: must be an integer in \[0, 2\*\*63 - 1\]"),
             (experiments.box_triaxial, dict(frames=-1, strain_rate=1e9),
              r"box_triaxial: .*frames = -1: must be an integer in \[0, 1000000000\]"),
             (experiments.box_triaxial, dict(iso_hold=2.5), "iso_hold = 2.5: must be an integer"),
             (experiments.slope_deposit, dict(steps=2**63), "steps = 9223372036854775808"),
             (experiments.slope_deposit, dict(rubber_radius=1.0), r"rubber_radius = 1.0: "
                                                                   r"must be a number in \(0, 0.1\]"),
             (experiments.gravity_deposit, dict(mu=float("inf")), "mu = inf: must be a number"),
             (experiments.gravity_deposit, dict(sample="sphere"), "sample = 'sphere': must be "
                                                                  "one of 'slope'"),
             (experiments.gravity_deposit, dict(wire=1), "wire = 1: must be true or false"),
             (experiments.gravity_deposit, dict(tol=1.5, max_iter=0), "tol = 1.5.*max_iter = 0")]
    for fn, kw, says in cases:
        with pytest.raises(ValueError, match=says) as e:
            fn(0.05, history=h, progress=False, **kw)
        assert "\n" not in str(e.value), str(e.value)
    assert not os.path.exists(h)


def test_a_tiny_scale_is_reported_as_too_few_grains():
    """Item 8: scale 1e-4 was reported as a wire that cannot fit (or a deposit that placed 2
    of 6 grains); it is a sample of 1-3 grains.  The smallest scale named builds."""
    from engine.prep import paper_sample

    for name, least in (("cylinder", 0.0017), ("box", 0.0016), ("slope", 0.0004)):
        with pytest.raises(ValueError, match=rf"scale 0.0001 gives a {name} sample of \d "
                                             rf"grains .*fewer than 10: use scale >= {least}$"):
            paper_sample(name, 1e-4)
        assert paper_sample(name, least, wire=True).n_beads > 0


# -- 5. physics outside its validity --------------------------------------------------------------
def _lid_scene(speed, **compile_kw):
    from engine import Scene, laws

    s = Scene(gravity=(0, 0, -9.81))
    s.add_spheres([[0, 0, 1.0e-3]], 1e-3, density=2650.0)
    s.add_plane(group="floor")
    lid = s.add_plane(point=(0, 0, 3e-3), normal=(0, 0, -1), group="lid")
    s.drive(lid, velocity=(0, 0, -speed))
    for g in ("floor", "lid"):
        s.interact("sand", g, laws.Coulomb(mu=0.5))
    return s.compile(dt=1e-4, **compile_kw)


def test_overlaps_are_reported_and_past_the_users_bound_stop_the_run(tmp_path):
    """A pile of 300 grains at dt = 10 ms (inside the documented range) ends with overlaps
    of about a fifth of a radius: the summary and a PhysicsWarning say so with the number,
    and the history records each step's largest overlap; the same run with
    ``max_overlap=0.1`` stops with a SimulationError naming the step and the two bodies.
    At dt = 0.2 ms the largest overlap stays under 1 % and nothing is said."""
    from engine import sanity
    from engine.step import SimulationError
    from tests.helpers import box_pile

    model, state, *_ = box_pile(300, 0.02, dt=1e-2, tol=1e-4, max_iter=1000)
    with io.History(tmp_path / "h.h5", frames=0) as h, pytest.warns(sanity.PhysicsWarning,
                                                                  match=r"overlaps up to"):
        summary = run(model, state, 40, writers=[h], progress=False)
    assert 0.1 < summary.max_overlap < 1.0 and "WARNING: overlaps up to" in str(summary)
    d = io.read_history(tmp_path / "h.h5", frames=False)
    assert d.max_overlap.max() == summary.max_overlap and d.units["max_overlap"] == "-"
    model, state, *_ = box_pile(300, 0.02, dt=1e-2, tol=1e-4, max_iter=1000)
    model = dataclasses.replace(model, options=model.options.model_copy(
        update={"max_overlap": 0.1}))
    with pytest.raises(SimulationError, match=r"step \d+ .*bodies \d+ and \d+ overlap by "
                                              r"[\d.]+ % of a radius, past max_overlap = 0.1"):
        run(model, state, 40, progress=False)
    model, state, *_ = box_pile(300, 0.02, dt=2e-4, tol=1e-4, max_iter=1000)
    with warnings.catch_warnings():
        warnings.simplefilter("error", sanity.PhysicsWarning)
        summary = run(model, state, 2000, progress=False)
    assert summary.max_overlap < 0.01 and "WARNING" not in str(summary)


def _wire_box(law):
    from engine import Scene, laws
    from engine.prep import paper_sample

    smp = paper_sample("box", 0.03, wire=True, seed=0)
    sc = Scene(gravity=(0, 0, -9.81))
    smp.add_to(sc, wire_law=law)
    sc.add_box(smp.container.lo, smp.container.hi, group="wall")
    for a, b, mu in (("sand", "sand", 0.5), ("sand", "wall", 0.5), ("wire", "sand", 0.3),
                     ("wire", "wire", 0.3), ("wire", "wall", 0.3)):
        sc.interact(a, b, laws.Coulomb(mu=mu))
    return sc.compile(dt=5e-5, tol=1e-4, max_iter=2000)


@pytest.mark.slow
def test_reactions_never_add_kinetic_energy_and_a_step_that_does_is_reported(tmp_path,
                                                                             monkeypatch):
    """The work of a step's reactions on the free motion, R . (v+ + v_free)/2 (each step's
    StepStats.energy_gain, records/energy_gain), is <= 0 for frictional contacts and rigid
    links whatever the tolerance (sanity.reaction_gain's proof): checked on every step of
    a falling pile at tol 1e-2 and 1e-8 and of a sand + rigid-wire box.  A prestrained
    elastic wire releases stored energy, so such a scene is not checked.  A solve made to
    add energy (one grain given 1 m/s sideways after the real solve) is reported by the summary and
    a PhysicsWarning with the step."""
    from engine import laws, sanity
    from tests.helpers import box_pile

    for tol in (1e-2, 1e-8):
        model, state, *_ = box_pile(300, 0.02, dt=2e-4, tol=tol, max_iter=1000)
        with io.History(tmp_path / f"p{tol}.h5", frames=0) as h:
            summary = run(model, state, 300, writers=[h], progress=False)
        d = io.read_history(tmp_path / f"p{tol}.h5", frames=False)
        assert d.units["energy_gain"] == "J" and (d.energy_gain <= 0).all()
        assert d.energy_gain.min() < -1e-9                # the grains hit the floor
        assert summary.energy_gain == 0.0 and "kinetic energy" not in str(summary)
    model, state = _wire_box(laws.RigidWire())
    assert sanity.energy_sources(model, state) is None
    gains = [sys.modules["engine.step"].step(model, state).energy_gain for _ in range(300)]
    assert max(gains) <= 0.0 and min(gains) < 0.0
    model, state = _wire_box(laws.ElasticWire(stiffness=1.0, prestrain=0.05))
    assert sanity.energy_sources(model, state) == "elastic links"
    assert sanity.energy_sources(*_wire_box(laws.RigidWire(prestrain=0.05))) == \
        "stretched rigid links"
    gains = [sys.modules["engine.step"].step(model, state).energy_gain for _ in range(100)]
    assert max(gains) > 0.0                               # the prestrain's energy, released

    stepmod = sys.modules["engine.step"]
    real = stepmod.solve

    def leaky(model, state, **kw):
        out = real(model, state, **kw)
        if state.step == 149:                             # the solve of step 150
            state.vel6[model.sphere_ids[0], 0] += 1.0
        return out

    monkeypatch.setattr(stepmod, "solve", leaky)
    model, state, *_ = box_pile(300, 0.02, dt=2e-4, tol=1e-4, max_iter=1000)
    with pytest.warns(sanity.PhysicsWarning, match=r"reactions added kinetic energy .*step 150"):
        warnings.filterwarnings("ignore", "overlaps up to", sanity.PhysicsWarning)  # the kick's
        summary = run(model, state, 200, progress=False)
    assert summary.energy_gain_step == 150 and summary.energy_gain > sanity.ENERGY_WARN
    assert "WARNING: the reactions added kinetic energy" in str(summary)


def test_a_lid_driven_through_a_ball_stops_the_run_naming_it():
    """A lid driven at 1000 m/s onto a 1 mm ball: the overlap stops the run at step 1; with
    the overlap bound lifted, the ball found behind a plane (the lid pushed it through the
    floor) does."""
    from engine.step import SimulationError

    model, state = _lid_scene(1000.0)
    with pytest.raises(SimulationError, match=r"step 1 .*bodies 0 and 2 overlap"):
        run(model, state, 20, progress=False)
    model, state = _lid_scene(1000.0, max_overlap=1e3)
    with pytest.raises(SimulationError, match=r"sphere 0 went through plane [12] "):
        run(model, state, 20, progress=False)


def test_a_ball_pushed_through_a_cylinder_stops_the_run_naming_the_wall():
    """A plate driven at 1000 m/s pushes a ball inside a closed-bottom cylinder down through
    its cap, or sideways through its side wall (overlap bound lifted so the crossing itself
    is what stops the run)."""
    from engine import Scene, laws
    from engine.step import SimulationError

    def scene(normal, velocity):
        s = Scene(gravity=(0, 0, -9.81))
        s.add_spheres([[0, 0, 2e-3]], 1e-3, density=2650.0)
        s.add_cylinder(radius=4e-3, height=10e-3, group="mould", bottom=True)
        plate = s.add_plane(point=(0, 0, 2e-3) - 2e-3 * np.asarray(normal), normal=normal,
                            group="plate")
        s.drive(plate, velocity=velocity)
        for g in ("mould", "plate"):
            s.interact("sand", g, laws.Coulomb(mu=0.5))
        return s.compile(dt=1e-4, max_overlap=1e3)

    for normal, velocity, says in (((0, 0, -1), (0, 0, -1000), "the bottom cap of cylinder 1"),
                                   ((-1, 0, 0), (-1000, 0, 0), "sphere 0 is outside cylinder 1 "
                                                               r"\(between its ends")):
        model, state = scene(normal, velocity)
        with pytest.raises(SimulationError, match=r"step 1 .*" + says):
            run(model, state, 20, progress=False)


def test_a_prestrain_that_collapses_the_wire_is_refused():
    """prestrain = 1e6 made the links' reference length g(0)/(1 + 1e6) and pulled the beads
    onto one another; the laws take (-1, 1] (at 1: half the initial length)."""
    from engine import laws

    for cls, kw in ((laws.ElasticWire, dict(stiffness=1.0)), (laws.RigidWire, {}),
                    (laws.ElasticRod, dict(stiffness=1.0)), (laws.RigidRod, {}),
                    (laws.BrittleElasticWire, dict(stiffness=1.0, max_tension=1.0))):
        with pytest.raises(ValueError, match=r"prestrain = 1000000.0: must be a number in "
                                             r"\(-1, 1\]"):
            cls(prestrain=1e6, **kw)
        assert cls(prestrain=1.0, **kw).prestrain == 1.0


def test_densities_and_masses_whose_products_overflow_are_refused():
    from engine import Scene

    for kw, says in ((dict(radii=1e-3, density=1e308), "density = 1e.308: must be at most 1e.08"),
                     (dict(radii=1e40, density=1.0), r"masses outside \[1e-100, 1e\+100\] kg"),
                     (dict(radii=1e-40, density=1.0), r"masses outside")):
        with pytest.raises(ValueError, match=says):
            Scene().add_spheres([[0, 0, 0]], kw["radii"], density=kw["density"])


def test_a_history_written_before_the_overlap_record_reads_it_as_nan(tmp_path):
    path = tmp_path / "old.h5"
    _history_run(path, steps=20)
    with h5py.File(path, "a") as f:
        del f["records/max_overlap"]
        del f["records/energy_gain"]
    d = io.read_history(path, frames=False)
    assert d.n_records == 20 and np.isnan(d.max_overlap).all() and np.isnan(d.energy_gain).all()
