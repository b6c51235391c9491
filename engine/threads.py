"""numba's thread count for one parallel stage (``Options.threads``)."""
from __future__ import annotations

from contextlib import contextmanager

import numba


@contextmanager
def numba_threads(T: int):
    """Run the block on min(T, NUMBA_NUM_THREADS) numba threads, then restore the count."""
    prev = numba.get_num_threads()
    want = min(int(T), numba.config.NUMBA_NUM_THREADS)
    if want != prev:
        numba.set_num_threads(want)
    try:
        yield want
    finally:
        if want != prev:
            numba.set_num_threads(prev)
