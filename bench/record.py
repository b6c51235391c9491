"""What every benchmark JSON says about its run: the machine, the commit, and how busy the
machine was while it ran, measured rather than assumed.

The machine may be shared with other jobs.  The load average lags (it still counts this
benchmark's own previous minute), so it cannot tell a quiet run from a shared one.  Instead
:class:`Busy` reads the kernel's CPU counters (``/proc/stat``) at the start and at the end
and subtracts this process's own CPU time (and that of its waited-for children): what is
left is the CPU that other processes took during the run.  ``steal`` is time the hypervisor
gave to other virtual machines.

Usage::

    busy = Busy()
    ...                       # the measurement
    out = dict(machine=machine(), busy=busy.finish(), ...)
    path = write("scaling", out, quick=a.quick)
"""
from __future__ import annotations

import datetime as _dt
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "bench" / "results"

#: Other processes' CPU below this share of one core: the run is reported as quiet.
QUIET_SHARE = 0.05


def _proc_stat():
    """(busy, steal) CPU seconds of the whole machine since boot, from /proc/stat."""
    try:
        with open("/proc/stat") as f:
            fields = f.readline().split()
    except OSError:
        return None
    hz = os.sysconf("SC_CLK_TCK")
    v = [int(x) for x in fields[1:]]
    # user nice system idle iowait irq softirq steal guest guest_nice (guest is inside user)
    busy = v[0] + v[1] + v[2] + v[5] + v[6]
    steal = v[7] if len(v) > 7 else 0
    return busy / hz, steal / hz


def _own_cpu():
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


class Busy:
    """CPU used by other processes between construction and :meth:`finish`."""

    def __init__(self):
        self.t0 = time.perf_counter()
        self.stat0 = _proc_stat()
        self.own0 = _own_cpu()
        self.load0 = os.getloadavg()

    def finish(self) -> dict:
        wall = time.perf_counter() - self.t0
        own = _own_cpu() - self.own0
        load1 = os.getloadavg()
        out = dict(wall_s=wall, own_cpu_s=own, loadavg_start=list(self.load0),
                   loadavg_end=list(load1), nproc=os.cpu_count())
        stat1 = _proc_stat()
        if self.stat0 is None or stat1 is None:
            out["note"] = "no /proc/stat: the other processes' CPU use is unknown"
            return out
        other = max(stat1[0] - self.stat0[0] - own, 0.0)
        steal = stat1[1] - self.stat0[1]
        share = other / wall if wall > 0 else 0.0
        out.update(other_cpu_s=other, other_cpu_share_of_one_core=share, steal_s=steal,
                   quiet=share < QUIET_SHARE)
        if share < QUIET_SHARE:
            out["note"] = (f"quiet: other processes used {other:.1f} CPU-s in {wall:.0f} s "
                           f"({share:.0%} of one core)")
        else:
            out["note"] = (f"shared: other processes used {other:.1f} CPU-s in {wall:.0f} s "
                           f"({share:.0%} of one core of {os.cpu_count()}); absolute times are "
                           "pessimistic, two-thread figures most of all")
        return out


def git_commit() -> str | None:
    try:
        return subprocess.run(["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True,
                              text=True, timeout=20).stdout.strip() or None
    except (OSError, subprocess.SubprocessError):
        return None


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def machine() -> dict:
    """Platform, CPU, Python and the numerical stack's versions."""
    out = dict(platform=platform.platform(), nproc=os.cpu_count(), cpu_model=_cpu_model(),
               python=platform.python_version())
    for mod in ("numpy", "numba", "llvmlite"):
        m = sys.modules.get(mod)
        if m is not None:
            out[mod] = m.__version__
    return out


def _json_default(o):
    import numpy as np

    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(type(o))


def write(name: str, out: dict, quick: bool = False, latest: bool = False) -> Path:
    """Write ``out`` to ``bench/results/<name>-<YYYYmmdd-HHMM>[-quick].json`` (and to
    ``<name>-latest[-quick].json`` with ``latest``); returns the dated path."""
    RESULTS.mkdir(parents=True, exist_ok=True)
    text = json.dumps(out, indent=1, default=_json_default)
    suffix = "-quick" if quick else ""
    path = RESULTS / f"{name}-{_dt.datetime.now().strftime('%Y%m%d-%H%M')}{suffix}.json"
    path.write_text(text)
    if latest:
        (RESULTS / f"{name}-latest{suffix}.json").write_text(text)
    return path
