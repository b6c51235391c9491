"""Damage anywhere in a history is never read as data (hypothesis): a copy of a real history
with bytes zeroed or flipped at a random place and length is either refused by each reader
with one line naming the file (FormatError, a ValueError, or FileNotFoundError for nothing
else), or read back exactly as the intact file reads.  What was damaged is the reader's to
find: the per-row checksums of the data, HDF5's own of its metadata, the checks of shapes
and values.

The counts (examples, refused, read as intact) are printed at the end (``pytest -s``) and
checked to be a real mix."""
import shutil

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings, strategies as st  # noqa: E402

from engine import io, run  # noqa: E402
from tests.engine.test_io import scene  # noqa: E402

COUNTS = {"examples": 0, "refused": 0, "intact": 0}


@pytest.fixture(scope="module")
def good(tmp_path_factory):
    """(a short history, what its readers give)."""
    model, state = scene()
    path = tmp_path_factory.mktemp("damage") / "good.h5"
    with io.History(path, trigger=5, frames=10) as h:
        run(model, state, 40, writers=[h], progress=False)
    return path, _read_all(path)


def _read_all(path):
    """What every reader gives of ``path``: the records, every frame's state, the model."""
    h = io.read_history(path)
    frames = [io.load(path, frame=k)[1] for k in range(io.frame_count(path))]
    return h, frames, io.load_model(path)


def _same(a, b) -> bool:
    (ha, fa, ma), (hb, fb, mb) = a, b
    if ha.n_records != hb.n_records or len(fa) != len(fb):
        return False
    for x, y in zip([ha.time, ha.kinetic_energy, ha.position, ha.contact_arrays["force"],
                     ma.body_radius, ma.body_mass],
                    [hb.time, hb.kinetic_energy, hb.position, hb.contact_arrays["force"],
                     mb.body_radius, mb.body_mass]):
        if not np.array_equal(x, y, equal_nan=True):
            return False
    return all(np.array_equal(s.position, t.position) and np.array_equal(s.vel6, t.vel6)
               and s.contacts_buf.count == t.contacts_buf.count for s, t in zip(fa, fb))


@settings(max_examples=40, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture,
                                 HealthCheck.too_slow])
@given(where=st.floats(0.0, 1.0), length=st.sampled_from([1, 4, 64, 4096, 65536]),
       flip=st.booleans())
def test_damaged_bytes_are_refused_in_one_line_or_read_as_intact(good, tmp_path, where,
                                                                  length, flip):
    good, intact = good
    p = tmp_path / "damaged.h5"
    shutil.copy(good, p)
    size = p.stat().st_size
    at = int(where * max(size - length, 0))
    with open(p, "r+b") as f:
        f.seek(at)
        old = f.read(length)
        f.seek(at)
        f.write(bytes(b ^ 0xFF for b in old) if flip else bytes(len(old)))
    COUNTS["examples"] += 1
    try:
        got = _read_all(p)
    except (ValueError, OSError) as e:
        msg = str(e)
        assert "\n" not in msg and str(p) in msg and len(msg) < 600, msg
        COUNTS["refused"] += 1
        return
    assert _same(got, intact), f"damage at {at} (+{length}, flip={flip}) read as data"
    COUNTS["intact"] += 1


def test_the_damage_examples_were_a_mix():
    print(f"\ndamaged histories: {COUNTS}")
    if COUNTS["examples"] == 0:
        pytest.skip("the property test did not run first")
    assert COUNTS["refused"] >= 0.2 * COUNTS["examples"]
    assert COUNTS["refused"] + COUNTS["intact"] == COUNTS["examples"]
