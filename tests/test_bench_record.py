"""bench/record.py: the benchmarks' 'was the machine quiet?' figure counts this process and
its children as its own, and only the rest as other processes' CPU."""
import json
import subprocess
import sys
import time
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parent.parent / "bench"
sys.path.insert(0, str(BENCH))
import record  # noqa: E402

pytestmark = pytest.mark.skipif(not Path("/proc/stat").exists(), reason="needs /proc/stat")

BURN = "import time\nt = time.process_time()\nwhile time.process_time() - t < {s}: pass\n"


def test_own_and_child_cpu_are_not_counted_as_other():
    busy = record.Busy()
    t = time.process_time()
    while time.process_time() - t < 0.3:  # this process
        pass
    subprocess.run([sys.executable, "-c", BURN.format(s=0.3)], check=True)  # a waited child
    out = busy.finish()
    # 0.6 s of CPU were ours; the clock ticks are 10 ms, so allow a few ticks either way
    assert out["own_cpu_s"] >= 0.55
    assert out["other_cpu_s"] >= 0.0
    # whatever else the machine runs, it cannot have used more than all its cores
    assert out["other_cpu_s"] <= out["nproc"] * out["wall_s"] + 0.05
    assert out["other_cpu_share_of_one_core"] == pytest.approx(out["other_cpu_s"] / out["wall_s"])
    assert out["quiet"] == (out["other_cpu_share_of_one_core"] < record.QUIET_SHARE)
    assert out["note"].startswith("quiet" if out["quiet"] else "shared")


def _state(pid):
    return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]


def test_an_unwaited_process_counts_as_other():
    """A process that is not our waited child (here: a child that has exited but is not
    reaped yet, so the kernel has not added its CPU to ours) is 'other processes'."""
    busy = record.Busy()
    p = subprocess.Popen([sys.executable, "-c", BURN.format(s=0.5)])
    try:
        deadline = time.monotonic() + 60
        while _state(p.pid) != "Z":  # exited, not reaped
            assert time.monotonic() < deadline, "the burner did not finish"
            time.sleep(0.02)
        out = busy.finish()
    finally:
        p.wait(timeout=30)
    assert out["other_cpu_s"] >= 0.45  # its 0.5 s (minus a few 10 ms ticks)
    assert out["own_cpu_s"] < out["other_cpu_s"]
    assert not out["quiet"] and out["note"].startswith("shared")


def test_write_names_and_round_trips(tmp_path, monkeypatch):
    import numpy as np

    monkeypatch.setattr(record, "RESULTS", tmp_path)
    path = record.write("probe", {"x": np.float64(1.5), "a": np.arange(3)}, quick=True,
                        latest=True)
    assert path.name.startswith("probe-") and path.name.endswith("-quick.json")
    assert json.loads(path.read_text()) == {"x": 1.5, "a": [0, 1, 2]}
    assert json.loads((tmp_path / "probe-latest-quick.json").read_text())["x"] == 1.5
