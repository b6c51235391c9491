"""Every write on a disk that refuses it (full, or read-only) fails the same way: one line
naming the file, ``nscd`` exit 1, no traceback, nothing half-written under a final name, an
older file of that name kept (engine.files, and each writer that goes through it).

The disks are small tmpfs mounts (root only; skipped with the reason otherwise)."""
from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from engine import files, io
from engine.errors import WriteFailed
from workbench import cli

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def history(tmp_path_factory):
    """A short cylinder test with a wire and its frames (about 0.3 MB a frame exported)."""
    import warnings

    from engine.experiments import cylinder_triaxial

    path = tmp_path_factory.mktemp("disk") / "run.h5"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cylinder_triaxial(0.05, axial_strain=0.01, frames=6, history=str(path),
                          progress=False, iso_max_steps=200, max_nonconverged=1.0)
    return path


def _nscd(argv, capsys) -> tuple[int, list[str]]:
    """``nscd`` in this process: (exit code, the lines of stderr that are not a bar)."""
    capsys.readouterr()
    code = cli.main(argv)
    err = capsys.readouterr().err.replace("\r", "\n")
    return code, [ln for ln in err.splitlines() if ln.startswith("nscd") or "Trace" in ln]


def _files(d: Path) -> list[Path]:
    return sorted(p for p in d.rglob("*") if p.is_file())


def test_replacing_names_the_target_keeps_the_older_file_and_leaves_no_part(small_disk):
    disk = small_disk(64)
    old = disk / "table.json"
    old.write_text("older")
    with pytest.raises(WriteFailed) as e:
        files.write_bytes(old, b"x" * (1 << 20), "the table could not be written")
    assert str(e.value) == (f"{old}: the table could not be written (No space left on device "
                            f"(ENOSPC)); the older file of this name is kept")
    assert old.read_text() == "older" and _files(disk) == [old]
    with pytest.raises(WriteFailed, match="nothing is left under this name"):
        files.write_bytes(disk / "new.bin", b"x" * (1 << 20))
    assert _files(disk) == [old]


def test_a_checkpoint_on_a_full_disk_fails_in_one_line_and_the_process_lives(small_disk):
    """HDF5 met a full disk in the old save: 74 dealloc tracebacks, then SIGSEGV.  The
    checkpoint is now built in memory: the save raises WriteFailed, the process goes on and
    exits normally, an older checkpoint is kept bit for bit."""
    disk = small_disk(256)
    script = disk.parent / "save.py"
    script.write_text(textwrap.dedent(f"""
        import numpy as np
        from engine import Scene, io, laws
        from engine.errors import WriteFailed
        grid = np.mgrid[0:30, 0:30, 0:30].reshape(3, -1).T * 0.03   # 27 000 sites
        s = Scene()
        s.add_spheres(grid[:200], 0.01, 2650.0)
        s.interact("sand", "sand", laws.Coulomb(mu=0.5))
        m, st = s.compile(1e-4)
        io.save({str(disk / "ck.h5")!r}, m, st)
        before = open({str(disk / "ck.h5")!r}, "rb").read()
        s.add_spheres(grid[200:], 0.01, 2650.0)
        m, st = s.compile(1e-4)
        try:
            io.save({str(disk / "ck.h5")!r}, m, st)
        except WriteFailed as e:
            print(e)
        assert open({str(disk / "ck.h5")!r}, "rb").read() == before
    """))
    r = subprocess.run([sys.executable, str(script)], cwd=ROOT, capture_output=True,
                       text=True, timeout=300, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stderr == ""
    assert r.stdout.strip().startswith(f"{disk / 'ck.h5'}: the checkpoint could not be "
                                       f"written (No space left on device (ENOSPC))")
    assert sorted(p.name for p in disk.iterdir()) == ["ck.h5"]


def test_an_export_that_fills_the_disk_leaves_no_series(history, small_disk, capsys):
    disk = small_disk(768)               # a frame or two, not seven
    code, lines = _nscd(["export", str(history), str(disk / "series")], capsys)
    assert code == 1 and len(lines) == 1, lines
    assert lines[0].startswith(f"nscd export: stopped: {disk}/series/")
    assert "No space left on device" in lines[0] and "the export stopped at frame" in lines[0]
    assert _files(disk) == []


def test_frames_on_a_full_disk_are_whole_or_absent_and_the_count_is_said(history, small_disk,
                                                                         capsys):
    from PIL import Image

    disk = small_disk(512)
    code, lines = _nscd(["render", str(history), "--frames", "all", "--out",
                         str(disk / "png")], capsys)
    assert code == 1 and len(lines) == 1, lines
    left = _files(disk)
    assert f"{len(left)} of the {io.frame_count(history)} frames were written before it" \
        in lines[0]
    for p in left:                        # every PNG left is a whole picture
        with Image.open(p) as im:
            im.load()
        assert p.name.startswith("frame_")


@pytest.mark.parametrize("readonly, kind", [(False, "mp4"), (True, "mp4"), (False, "gif")],
                         ids=["full", "read-only", "gif-full"])
def test_a_movie_that_cannot_be_written_leaves_nothing(history, small_disk, capsys, readonly,
                                                       kind):
    """ffmpeg, whose end could not be written, exits with an error imageio does not look
    at: the movie is read back (its frame count) before it takes its name.  A GIF is built
    in memory and written in one go."""
    disk = small_disk(48, readonly)
    code, lines = _nscd(["render", str(history), "--movie", str(disk / f"m.{kind}"),
                         "--frames", "0:6"], capsys)
    assert code == 1 and len(lines) == 1, lines
    assert lines[0].startswith(f"nscd render: stopped: {disk}/m.{kind}: the movie could not "
                               f"be written")
    assert ("Read-only file system" if readonly else "No space left on device") in lines[0]
    assert _files(disk) == []


def test_a_sweep_table_on_a_full_disk_keeps_the_older_table(small_disk):
    from workbench.campaign.table import SweepTable, load_table, write_hdf5, write_json

    disk = small_disk(64)
    path = disk / "sweep.json"
    write_json(SweepTable(rows=[]), path, {"experiment": "x"})
    older = path.read_bytes()
    rows = [{"id": f"c{i}", "status": "done", "params": {"seed": i}, "result": {"q": 1.0},
             "errors": [], "attempts": 1, "elapsed": 1.0, "experiment": "x"}
            for i in range(2000)]
    with pytest.raises(WriteFailed, match=f"^{path}: the sweep table could not be written"):
        write_json(SweepTable(rows=rows), path, {"experiment": "x"})
    assert path.read_bytes() == older and load_table(path).rows == []
    with pytest.raises(WriteFailed, match="sweep.h5: the sweep table could not be written"):
        write_hdf5(SweepTable(rows=rows * 10), disk / "sweep.h5")
    assert _files(disk) == [path]


def test_a_run_whose_history_cannot_start_leaves_no_file_and_no_lock(small_disk, capsys):
    """A disk too full for the history's start, and one too full for its lock's note: one
    line each, exit 1, the folder as it was."""
    for kib in (4, 128):
        disk = small_disk(kib)
        fill = disk / "fill"
        fill.write_bytes(b"\0" * (max(kib - 8, 0) * 1024))
        while True:                       # fill the last blocks too
            try:
                with open(fill, "ab") as f:
                    f.write(b"\0" * 4096)
            except OSError:
                break
        cfg = disk.parent / "gd.toml"
        cfg.write_text('test = "gravity_deposit"\nscale = 0.02\nseed = 0\n')
        code, lines = _nscd(["run", str(cfg), "--out", str(disk / "r")], capsys)
        assert code == 1 and len(lines) == 1, lines
        assert lines[0].startswith(f"nscd run: stopped: {disk}/r/run.h5: the ")
        assert [p for p in _files(disk) if p != fill] == []


def test_write_errors_are_told_apart_from_bad_paths():
    import errno

    assert files.is_write_error(OSError(errno.ENOSPC, "full"))
    assert files.is_write_error(RuntimeError("Can't close (file write failed: errno = 28, "
                                             "error message = 'No space left')"))
    assert not files.is_write_error(FileNotFoundError(errno.ENOENT, "no"))
    assert not files.is_write_error(RuntimeError("no errno here"))
    assert np.isfinite(files.free_bytes(ROOT / "not" / "yet"))
