"""A small TexSol run writing a history, for the viewer's tests and benchmark.

    python tests/workbench/follow_run.py OUT.h5 [--steps N] [--frames F] [--pause S]

The cylinder of :func:`tests.workbench.scenes.texsol_cylinder` (300 sand grains, a closed
wire ring of 48 beads) settling under gravity, a history record every step and a frame
every ``F`` steps (and of the initial state); ``--pause`` seconds after each frame (a
slow run, for ``nscd view --follow`` to watch).  Prints ``frame K`` after each frame is
flushed (with the wall-clock time, ``time.time()``), and ``done T s`` at the end (T: the
wall time of the run, writing included).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from engine import run  # noqa: E402
from engine.io import History  # noqa: E402
from tests.workbench.scenes import texsol_cylinder  # noqa: E402


class _Pause:
    """A writer that sleeps after each frame (after the history's own write)."""

    def __init__(self, every, pause):
        self.every, self.pause = every, pause

    def trigger(self, step):
        return step % self.every == 0

    def write(self, model, state):
        print(f"frame {state.step // self.every} {time.time():.4f}", flush=True)
        if self.pause:
            time.sleep(self.pause)


def main(argv=None):
    a = argparse.ArgumentParser()
    a.add_argument("out")
    a.add_argument("--steps", type=int, default=200)
    a.add_argument("--frames", type=int, default=20)
    a.add_argument("--pause", type=float, default=0.0)
    a.add_argument("--n-sand", type=int, default=300)
    args = a.parse_args(argv)
    model, state, _ = texsol_cylinder(n_sand=args.n_sand, steps=0, max_iter=1000)
    t0 = time.perf_counter()
    with History(args.out, frames=args.frames,
                 meta={"test": "follow_run", "total_steps": args.steps,
                       "params": {"n_sand": args.n_sand}}) as h:
        h.write(model, state)                    # frame 0: the initial state
        run(model, state, args.steps, writers=[h, _Pause(args.frames, args.pause)],
            progress=False)
    print(f"done {time.perf_counter() - t0:.4f} s", flush=True)


if __name__ == "__main__":
    main()
