"""A viewer beside a run: ``nscd run CONFIG --view``.

The viewer is its own process (``nscd view HISTORY --follow``), started as soon as the
run's history holds a frame: the run's process does not share its interpreter (GIL) or
its rendering with the viewer, and the viewer only reads the history (HDF5 SWMR), so the
writer is not slowed by more than the reads' disk and cache traffic (measured in
``bench/bench_view.py``).
"""
from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

__all__ = ["ViewerBeside"]


class ViewerBeside:
    """Start ``nscd view HISTORY --follow`` once ``history`` has a frame; ``announce`` gets
    the URL.  :meth:`close` stops it."""

    def __init__(self, history, *, host: str = "127.0.0.1", port: int = 0,
                 announce=print, poll: float = 0.5, timeout: float = 3600.0):
        self.history = Path(history)
        self.host, self.port = host, int(port)
        self.announce = announce
        self.poll, self.timeout = float(poll), float(timeout)
        self.proc = None
        self.url = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._start_when_ready, daemon=True)

    def start(self) -> "ViewerBeside":
        self._thread.start()
        return self

    def _has_frame(self) -> bool:
        from engine import io

        if not self.history.exists():
            return False
        try:
            return len(io.frame_index(self.history)[0]) > 0
        except (OSError, ValueError):
            return False

    def _start_when_ready(self) -> None:
        t0 = time.time()
        while not self._stop.is_set() and time.time() - t0 < self.timeout:
            if self._has_frame():
                break
            self._stop.wait(self.poll)
        if self._stop.is_set() or not self._has_frame():
            return
        cmd = [sys.executable, "-m", "workbench.cli", "view", str(self.history), "--follow",
               "--host", self.host]
        if self.port:
            cmd += ["--port", str(self.port)]
        self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True,
                                     start_new_session=True)   # our Ctrl-C is the run's
        line = self.proc.stdout.readline()
        m = re.search(r"(http://\S+)", line)
        if m:
            self.url = m.group(1)
            self.announce(f"nscd run: the viewer follows the run at {self.url}")

    def wait(self) -> None:
        """After the run: keep the viewer until Ctrl-C (or until it stops)."""
        self._thread.join(timeout=10)
        if self.proc is None or self.proc.poll() is not None:
            return
        self.announce(f"nscd run: the run is over; the viewer stays at {self.url} until "
                      f"Ctrl-C")
        try:
            self.proc.wait()
        except KeyboardInterrupt:
            pass

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=10)
        if self.proc is not None and self.proc.poll() is None:
            try:
                os.killpg(self.proc.pid, signal.SIGTERM)
            except ProcessLookupError:
                pass
            try:
                self.proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                self.proc.kill()
