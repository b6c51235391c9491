import os
import subprocess
from pathlib import Path

import pytest


@pytest.fixture(params=[0.5, 1.0], ids=["theta0.5", "theta1"])
def theta(request):
    """Every physics test runs at both ends of the θ range [0.5, 1]."""
    return request.param


@pytest.fixture
def small_disk(tmp_path):
    """``small_disk(kib, readonly=False)``: a folder on a tmpfs of that size, read-only if
    asked (unmounted after the test; root only: skipped with the reason otherwise)."""
    mounts = []

    def make(kib: int, readonly: bool = False) -> Path:
        if os.geteuid() != 0:
            pytest.skip("a small tmpfs can only be mounted by root")
        d = tmp_path / f"disk{len(mounts)}"
        d.mkdir()
        opts = f"size={kib}k" + (",ro" if readonly else "")
        r = subprocess.run(["mount", "-t", "tmpfs", "-o", opts, "tmpfs", str(d)],
                           capture_output=True, text=True)
        if r.returncode:
            pytest.skip(f"cannot mount a tmpfs here: {r.stderr.strip()}")
        mounts.append(d)
        return d

    yield make
    for d in mounts:
        subprocess.run(["umount", "-l", str(d)], capture_output=True)
