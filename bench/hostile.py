"""A hostile pass over ``nscd``: cases of every class a demanding user (or a bad day) brings,
each run once as its own process, and what came out judged.

    python bench/hostile.py [--only CLASS,...] [--out bench/results/hostile-<date>.json]

Classes: ``disk`` (a full tmpfs at each write), ``readonly`` (a read-only tmpfs), ``damage``
(a copy of a real history with bytes zeroed or flipped, seeded), ``nonfile`` (FIFOs,
devices, folders where a file is asked), ``bounded`` (unreasonable work or input),
``physics`` (runs whose results cannot be physical), ``arguments`` (combinations that cannot
mean what was meant), ``signals`` (Ctrl-C, SIGTERM and SIGKILL at a stage, then a resume).

A case's verdict:

* ``traceback``: "Traceback" on stderr;
* ``hang``: no exit within its time limit;
* ``crash``: killed by a signal it was not sent (exit < 0 or 128 + n, 130 excepted);
* ``silent``: exit 0 where the case must fail, or a result that is wrong with exit 0 (a
  damaged history read as other data than the intact one, a file left half-written under
  a final name, overlaps past the bound with no word);
* ``noisy``: an error message of more than one line or longer than 2 000 characters;
* ``clean``: none of these.

The tmpfs classes need root (mount); they are skipped otherwise, and said so.  The table
(each case: its class, command, exit code, seconds, verdict, the last stderr line) goes to
``--out``; the counts are printed.
"""
from __future__ import annotations

import argparse
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
NSCD = [sys.executable, "-m", "workbench.cli"]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


@dataclass
class Case:
    name: str
    cls: str
    argv: list
    must_fail: bool = True              # exit 0 is a silent result
    timeout: float = 300.0
    setup: object = None                # fn() before the run
    check: object = None                # fn(result) -> problem or None (silent results)
    signal_at: tuple | None = None      # (seconds, signal) sent to the process
    expect_rc: tuple = ()               # exit codes that are right (empty: any but crash)


@dataclass
class Result:
    name: str
    cls: str
    argv: list
    rc: int | None
    seconds: float
    verdict: str
    why: str = ""
    last: str = ""
    extra: dict = field(default_factory=dict)


def run_case(c: Case) -> Result:
    if c.setup:
        c.setup()
    t0 = time.perf_counter()
    p = subprocess.Popen([*NSCD, *c.argv], cwd=WORK, env=ENV, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, start_new_session=True)
    rc, out, err = None, "", ""
    try:
        if c.signal_at:
            try:
                out, err = p.communicate(timeout=c.signal_at[0])
            except subprocess.TimeoutExpired:
                p.send_signal(c.signal_at[1])
        out2, err2 = p.communicate(timeout=c.timeout)
        out, err = out + out2, err + err2
        rc = p.returncode
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        out, err = p.communicate()
    dt = time.perf_counter() - t0
    lines = [ln for ln in err.replace("\r", "\n").splitlines()
             if ln.startswith("nscd") and ": warning:" not in ln]
    last = lines[-1] if lines else ""
    sent = c.signal_at[1] if c.signal_at else None
    if rc is None:
        v, why = "hang", f"no exit in {c.timeout:g} s"
    elif "Traceback" in err:
        v, why = "traceback", err[err.index("Traceback"):][:300]
    elif (rc < 0 and -rc != sent) or (rc > 128 and rc != 130 and rc - 128 != sent):
        v, why = "crash", f"exit {rc}"
    elif rc == 0 and c.must_fail:
        v, why = "silent", "exit 0 where the case must fail"
    elif c.expect_rc and rc not in c.expect_rc:
        v, why = "silent", f"exit {rc}, expected one of {c.expect_rc}"
    elif rc != 0 and (len(lines) > 1 or len(last) > 2000):
        v, why = "noisy", f"{len(lines)} lines, {len(last)} characters"
    else:
        v, why = "clean", ""
        if c.check:
            problem = c.check(rc, out, err)
            if problem:
                v, why = "silent", problem
    return Result(c.name, c.cls, [str(x) for x in c.argv], rc, round(dt, 2), v, why,
                  last[:400])


# -- the scene of the pass ----------------------------------------------------------------
WORK = Path(tempfile.mkdtemp(prefix="hostile-"))
DISK = WORK / "disk"
RO = WORK / "ro"


def nscd(*argv, check=True):
    r = subprocess.run([*NSCD, *argv], cwd=WORK, env=ENV, capture_output=True, text=True)
    if check and r.returncode:
        raise SystemExit(f"setup failed: nscd {' '.join(map(str, argv))}: {r.stderr[-500:]}")
    return r


def mount(path: Path, kib: int, readonly=False) -> bool:
    subprocess.run(["umount", "-l", str(path)], capture_output=True)
    path.mkdir(exist_ok=True)
    opts = f"size={kib}k" + (",ro" if readonly else "")
    return subprocess.run(["mount", "-t", "tmpfs", "-o", opts, "tmpfs", str(path)],
                          capture_output=True).returncode == 0


def fill_to(free_kib: int):
    """A setup: the disk emptied, then filled to leave about ``free_kib`` KiB."""
    def setup():
        for p in DISK.iterdir():
            if p.is_dir():
                shutil.rmtree(p)
            else:
                p.unlink()
        total = shutil.disk_usage(DISK).free
        n = max(total - free_kib * 1024, 0)
        with open(DISK / "fill", "wb") as f:
            while n > 0:
                k = min(n, 1 << 20)
                try:
                    f.write(b"\0" * k)
                    f.flush()
                except OSError:
                    break
                n -= k
    return setup


def whole_files(rc, out, err):
    """No temporary or empty file left under the disk; an export that failed leaves no
    .pvd; every PNG left opens."""
    from PIL import Image

    for p in DISK.rglob("*"):
        if not p.is_file() or p.name in ("fill",) or p.name.startswith(".") and (
                p.name.endswith(".lock") or p.name.endswith(".reserve")):
            continue
        if ".part" in p.name or p.stat().st_size == 0:
            return f"{p.name} left ({p.stat().st_size} bytes)"
        if p.suffix == ".png":
            try:
                with Image.open(p) as im:
                    im.load()
            except Exception as e:
                return f"{p.name} does not open ({e})"
        if p.suffix == ".pvd":                   # a series left is the whole history's
            sys.path.insert(0, str(ROOT))
            from workbench.series import read_pvd

            entries = read_pvd(p)
            if len({e["timestep"] for e in entries}) < N_FRAMES.get(p.parent.parent.name,
                                                                    N_FRAMES["box"]) or \
                    not all(e["file"].exists() for e in entries):
                return f"{p.name} left with {len(entries)} entries, not the whole series"
        if p.suffix == ".mp4":                   # a movie left is whole
            import imageio_ffmpeg

            try:
                imageio_ffmpeg.count_frames_and_secs(str(p))
            except Exception as e:
                return f"{p.name} does not read back ({' '.join(str(e).split())[:80]})"
    return None


def cases() -> list[Case]:
    out: list[Case] = []
    H = str(WORK / "box" / "run.h5")
    BOX, GD = str(WORK / "box.toml"), str(WORK / "gd.toml")

    # -- a full disk at each write ----------------------------------------------------------
    if ROOT_OK:
        D = str(DISK)
        for free in (0, 30, 200, 600):
            out.append(Case(f"run box, {free} KiB free", "disk",
                            ["run", BOX, "--out", f"{D}/r"], setup=fill_to(free),
                            check=whole_files, expect_rc=(1,)))
        for free in (1500, 2500, 3400):
            out.append(Case(f"deposit with checkpoints, {free} KiB free", "disk",
                            ["run", GD, "--out", f"{D}/g"], setup=fill_to(free),
                            check=whole_files, expect_rc=(1,)))
        for free in (0, 150, 700, 1800):
            out.append(Case(f"export, {free} KiB free", "disk", ["export", H, f"{D}/e"],
                            setup=fill_to(free), check=whole_files, expect_rc=(1,)))
        for free in (0, 250, 900):
            out.append(Case(f"render all frames, {free} KiB free", "disk",
                            ["render", H, "--frames", "all", "--out", f"{D}/p"],
                            setup=fill_to(free), check=whole_files, expect_rc=(1,)))
        out.append(Case("render one frame, 40 KiB free", "disk",
                        ["render", H, "--out", f"{D}/one.png"], setup=fill_to(40),
                        check=whole_files, expect_rc=(1,)))
        for free, kind in ((0, "mp4"), (40, "mp4"), (120, "mp4"), (0, "gif"), (300, "gif")):
            out.append(Case(f"movie .{kind}, {free} KiB free", "disk",
                            ["render", H, "--movie", f"{D}/m.{kind}"], setup=fill_to(free),
                            check=whole_files, expect_rc=(1,)))
        for free in (0, 2):
            out.append(Case(f"sweep table, {free} KiB free", "disk",
                            ["sweep", "box_triaxial", "--grid", "seed=0", "--grid",
                             "axial_strain=0.001", "--scheduler", "serial", "--out",
                             f"{D}/s.json"], setup=fill_to(free), check=whole_files,
                            expect_rc=(1,)))
        for free in (1000, 2500, 5000):         # (the whole demo takes about 5 MB)
            out.append(Case(f"demo, {free} KiB free", "disk",
                            ["demo", "--scale", "0.05", "--strain", "0.01", "--out",
                             f"{D}/d"], setup=fill_to(free), check=whole_files,
                            must_fail=False))
    # -- a read-only file system --------------------------------------------------------------
    if ROOT_OK:
        R = str(RO)
        for name, argv in (("run", ["run", BOX, "--out", f"{R}/r"]),
                           ("export", ["export", H, f"{R}/e"]),
                           ("render", ["render", H, "--out", f"{R}/p.png"]),
                           ("render all", ["render", H, "--frames", "all", "--out", f"{R}/p"]),
                           ("movie", ["render", H, "--movie", f"{R}/m.mp4"]),
                           ("sweep", ["sweep", "box_triaxial", "--grid", "seed=0",
                                      "--scheduler", "serial", "--out", f"{R}/s.json"]),
                           ("demo", ["demo", "--scale", "0.05", "--out", f"{R}/d"])):
            out.append(Case(f"{name} on a read-only disk", "readonly", argv, expect_rc=(1,)))
    # -- damaged copies of a real history -----------------------------------------------------
    rng = random.Random(20261208)
    size = os.path.getsize(H)
    for k in range(30):
        length = rng.choice([1, 4, 16, 512, 4096, 65536, 163840])
        at = rng.randrange(0, max(size - length, 1))
        flip = rng.random() < 0.5
        reader = ["info", "render", "export"][k % 3]
        p = WORK / f"damaged{k}.h5"

        def setup(p=p, at=at, length=length, flip=flip):
            shutil.copy(H, p)
            with open(p, "r+b") as f:
                f.seek(at)
                b = f.read(length)
                f.seek(at)
                f.write(bytes(x ^ 0xFF for x in b) if flip else bytes(len(b)))
        argv = {"info": ["info", str(p)],
                "render": ["render", str(p), "--frames", "all", "--out", str(WORK / f"dr{k}")],
                "export": ["export", str(p), str(WORK / f"de{k}")]}[reader]
        out.append(Case(f"{reader} of a history {'flipped' if flip else 'zeroed'} at {at} "
                        f"(+{length} B)", "damage", argv, must_fail=False, setup=setup,
                        check=same_as_intact(reader, k), expect_rc=(0, 2)))
    # -- inputs that are not regular files --------------------------------------------------
    fifo = WORK / "fifo.h5"
    fifo_toml = WORK / "fifo.toml"
    for cmd, path in ((["info"], fifo), (["render"], fifo), (["export"], fifo),
                      (["view"], fifo), (["run"], fifo_toml), (["run"], Path("/dev/zero")),
                      (["info"], Path("/dev/urandom")), (["info"], WORK),
                      (["render"], Path("/dev/null")), (["run"], WORK)):
        argv = [*cmd, str(path)] + ([str(WORK / "ex")] if cmd == ["export"] else [])
        out.append(Case(f"{cmd[0]} of {path.name or path}", "nonfile", argv, timeout=60,
                        expect_rc=(2,)))
    sample_fifo = WORK / "sample_fifo.toml"
    sample_fifo.write_text(f'test = "box_triaxial"\nscale = 0.05\n[parameters]\n'
                           f'sample = "{fifo}"\n')
    out.append(Case("a FIFO as a run's sample", "nonfile", ["run", str(sample_fifo)],
                    timeout=60, expect_rc=(2,)))
    # -- bounded work and messages ----------------------------------------------------------
    big = WORK / "big.toml"
    big.write_text('test = "box_triaxial"\n[parameters]\nmu = [' + ", ".join(["0.5"] * 200000)
                   + "]\n")
    deep = WORK / "deep.toml"
    deep.write_text('test = "box_triaxial"\na = ' + "[" * 5000 + "]" * 5000 + "\n")
    longkey = WORK / "longkey.toml"
    longkey.write_text('test = "box_triaxial"\n[parameters]\n' + "k" * 100000 + " = 1\n")
    huge = WORK / "huge.toml"
    huge.write_bytes(b'test = "box_triaxial"\n#' + b"x" * (3 << 20) + b"\n")
    seeds = ",".join(map(str, range(1000)))
    mus = ",".join(f"{0.1 + i * 1e-4:.4f}" for i in range(1000))
    for name, argv in (
            ("a grid of 10^6 cases", ["sweep", "box_triaxial", "--grid", f"seed={seeds}",
                                      "--grid", f"mu={mus}", "--scheduler", "serial"]),
            ("a run-file value of 200 000 numbers", ["run", str(big)]),
            ("a TOML nested 5 000 deep", ["run", str(deep)]),
            ("a 100 000-character key", ["run", str(longkey)]),
            ("a 3 MB run file", ["run", str(huge)]),
            ("a bad --cluster-option", ["sweep", "box_triaxial", "--grid", "seed=0",
                                        "--cluster", "local", "--cluster-option", "foo=1"]),
            ("--cluster-option without --cluster", ["sweep", "box_triaxial", "--grid",
                                                    "seed=0", "--cluster-option", "cores=2"]),
            ("--window-size of a billion pixels", ["render", H, "--window-size",
                                                   "100000x100000"]),
            ("a seed of 2**64", ["sweep", "box_triaxial", "--grid",
                                 f"seed={2 ** 64}", "--scheduler", "serial"]),
            ("a scale of 1e-9", ["demo", "--scale", "1e-9", "--out", str(WORK / "tiny")]),
            ("max_iter of 10^12", ["run", str(_toml("maxiter", "max_iter = 1000000000000"))]),
            ("--port of 70000", ["view", H, "--port", "70000"])):
        out.append(Case(name, "bounded", argv, timeout=120, expect_rc=(2,)))
    out.append(Case("--frames 0:10^12 (a slice: taken as far as the history goes)",
                    "bounded", ["render", H, "--frames", "0:1000000000000", "--out",
                                str(WORK / "slice")], must_fail=False, expect_rc=(0,),
                    check=lambda rc, o, e: None if f"{N_FRAMES['box']} frames" in o
                    else f"said {o!r}"))
    # -- results that cannot be physical ----------------------------------------------------
    for name, line in (("dt = 0.01 s", "dt = 0.01"),
                       ("dt = 0.005 s", "dt = 0.005"),
                       ("a pressure of 1 GPa", "pressure = 1e9"),
                       ("mu = 10", "mu = 10"),
                       ("tol = 0.9", "tol = 0.9"),
                       ("theta = 1 with dt = 0.002", "theta = 1.0\ndt = 0.002")):
        out.append(Case(name, "physics", ["run", str(_toml(name, line)), "--out",
                                          str(WORK / f"ph_{abs(hash(name))}")],
                        must_fail=False, check=physical(WORK / f"ph_{abs(hash(name))}")))
    for name, wire in (("prestrain 1.0", "prestrain = 1.0"),
                       ("prestrain -0.99", "prestrain = -0.99")):
        out.append(Case(name, "physics", ["run", str(_toml(name, "", wire)), "--out",
                                          str(WORK / f"pw_{abs(hash(name))}")],
                        must_fail=False, check=physical(WORK / f"pw_{abs(hash(name))}")))
    # -- arguments that cannot mean what was meant ------------------------------------------
    (WORK / "afile").write_text("x")
    for name, argv in (
            ("several frames into a .png", ["render", H, "--frames", "all", "--out",
                                            str(WORK / "many.png")]),
            ("an export into a .pvd", ["export", H, str(WORK / "s.pvd")]),
            ("a run's folder named run.h5", ["run", BOX, "--out", str(WORK / "o.h5")]),
            ("--fps without a movie", ["render", H, "--fps", "3"]),
            ("--clim on beads by kind", ["render", H, "--clim", "0,1"]),
            ("--color-by on the wire", ["render", H, "--preset", "wire", "--color-by",
                                        "speed"]),
            ("a movie with --out", ["render", H, "--movie", str(WORK / "m.mp4"), "--out",
                                    str(WORK / "x")]),
            ("an export over a file", ["export", H, str(WORK / "afile")]),
            ("a grid key twice", ["sweep", "box_triaxial", "--grid", "seed=0", "--grid",
                                  "seed=1", "--scheduler", "serial"]),
            ("stiffness on sand only", ["sweep", "box_triaxial", "--grid", "wire=none",
                                        "--grid", "k=2", "--scheduler", "serial"])):
        out.append(Case(name, "arguments", argv, timeout=120, expect_rc=(2,)))
    # -- signals at a stage, then a resume --------------------------------------------------
    for name, at, sig in (("Ctrl-C after 8 s", 8, signal.SIGINT),
                          ("SIGTERM after 8 s", 8, signal.SIGTERM),
                          ("Ctrl-C after 20 s", 20, signal.SIGINT)):
        d = WORK / f"sig_{at}_{int(sig)}"
        out.append(Case(f"deposit, {name}", "signals", ["run", GD, "--out", str(d)],
                        signal_at=(at, sig), expect_rc=(130,), must_fail=True,
                        check=readable(d)))
        out.append(Case(f"deposit resumed after {name}", "signals", ["run", GD, "--out",
                                                                       str(d)],
                        must_fail=False, expect_rc=(0,), check=readable(d), timeout=900))
    d = WORK / "sig_kill"
    out.append(Case("deposit, SIGKILL after 10 s", "signals", ["run", GD, "--out", str(d)],
                    signal_at=(10, signal.SIGKILL), must_fail=True))
    out.append(Case("deposit resumed after SIGKILL", "signals", ["run", GD, "--out", str(d)],
                    must_fail=False, expect_rc=(0,), check=readable(d), timeout=900))
    return out


def _toml(name, params: str, wire: str = "") -> Path:
    p = WORK / f"t_{abs(hash((name, params, wire)))}.toml"
    p.write_text(f'test = "box_triaxial"\nscale = 0.05\nseed = 0\n[parameters]\n'
                 f'axial_strain = 0.005\niso_max_steps = 400\n{params}\n'
                 + (f"[wire]\n{wire}\n" if wire else ""))
    return p


INTACT: dict = {}
#: frames of the histories whose series a case may leave (by the folder above the series)
N_FRAMES: dict = {}


def same_as_intact(reader, k):
    """A damaged history read with exit 0 must give what the intact one gives."""
    def check(rc, out, err):
        if rc != 0:
            return None
        if reader == "info":                    # (the first line names the file read)
            same = out.split("\n", 1)[-1] == INTACT["info"].split("\n", 1)[-1]
            return None if same else "info of a damaged history differs"
        if reader == "render":
            d = WORK / f"dr{k}"
            for p in sorted(INTACT["render"].iterdir()):
                q = d / p.name
                if not q.exists() or q.read_bytes() != p.read_bytes():
                    return f"render: {p.name} differs from the intact history's"
            return None
        d = WORK / f"de{k}"
        for p in sorted(INTACT["export"].glob("*.vtu")):
            q = d / p.name
            if not q.exists() or q.read_bytes() != p.read_bytes():
                return f"export: {p.name} differs from the intact history's"
        return None
    return check


def physical(d: Path):
    """Exit 0 only with overlaps within the stopping bound (0.5 of a radius) or a warning
    about them."""
    def check(rc, out, err):
        if rc != 0:
            return None
        sys.path.insert(0, str(ROOT))
        from engine import io

        h = io.read_history(d / "run.h5", frames=False)
        ov = float(h.max_overlap.max()) if h.n_records else 0.0
        if ov > 0.5:
            return f"exit 0 with overlaps up to {100 * ov:.3g} %"
        if ov > 0.05 and "overlaps up to" not in err:
            return f"overlaps up to {100 * ov:.3g} % with no warning"
        return None
    return check


def readable(d: Path):
    def check(rc, out, err):
        sys.path.insert(0, str(ROOT))
        from engine import io

        try:
            io.read_history(d / "run.h5", frames=False)
        except Exception as e:
            return f"the history does not read: {e}"
        return None
    return check


def main() -> int:
    global ROOT_OK
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", help="comma-separated classes")
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    ROOT_OK = os.geteuid() == 0 and mount(DISK, 8192) and mount(RO, 1024, readonly=True)
    if not ROOT_OK:
        print("hostile: not root (or no tmpfs here): the disk and readonly classes are "
              "skipped")
    (WORK / "box.toml").write_text('test = "box_triaxial"\nscale = 0.05\nseed = 0\n'
                                   '[parameters]\naxial_strain = 0.01\n')
    (WORK / "gd.toml").write_text('test = "gravity_deposit"\nscale = 0.05\nseed = 0\n'
                                  '[parameters]\nresume = true\ncheckpoint_every = 50\n')
    os.mkfifo(WORK / "fifo.h5")
    os.mkfifo(WORK / "fifo.toml")
    print(f"hostile: work folder {WORK}; making the history the cases read")
    nscd("run", "box.toml", "--out", str(WORK / "box"))
    INTACT["info"] = nscd("info", str(WORK / "box" / "run.h5")).stdout
    INTACT["render"] = WORK / "intact_render"
    nscd("render", str(WORK / "box" / "run.h5"), "--frames", "all", "--out",
         str(INTACT["render"]))
    sys.path.insert(0, str(ROOT))
    from engine import io

    N_FRAMES["box"] = io.frame_count(WORK / "box" / "run.h5")
    N_FRAMES["d"] = 12                  # the demo's at scale 0.05 to 1 % strain
    INTACT["export"] = WORK / "intact_export"
    nscd("export", str(WORK / "box" / "run.h5"), str(INTACT["export"]))
    todo = cases()
    if a.only:
        keep = set(a.only.split(","))
        todo = [c for c in todo if c.cls in keep]
    results = []
    for k, c in enumerate(todo):
        r = run_case(c)
        results.append(r)
        print(f"[{k + 1:3d}/{len(todo)}] {r.verdict:9s} {r.cls:9s} rc={r.rc} {r.seconds:6.1f} s "
              f"{c.name}{': ' + r.why[:150] if r.why else ''}", flush=True)
    counts = {}
    for r in results:
        counts[r.verdict] = counts.get(r.verdict, 0) + 1
    by_class = {}
    for r in results:
        by_class.setdefault(r.cls, {}).setdefault(r.verdict, 0)
        by_class[r.cls][r.verdict] += 1
    stamp = time.strftime("%Y%m%d-%H%M")
    path = Path(a.out or ROOT / "bench" / "results" / f"hostile-{stamp}.json")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({"date": stamp, "cases": len(results), "counts": counts,
                                "by_class": by_class, "root": ROOT_OK,
                                "results": [asdict(r) for r in results]}, indent=1))
    print(f"hostile: {len(results)} cases: {counts}; {path}")
    for m in (DISK, RO):
        subprocess.run(["umount", "-l", str(m)], capture_output=True)
    return 0 if set(counts) <= {"clean"} else 1


ROOT_OK = False

if __name__ == "__main__":
    sys.exit(main())
