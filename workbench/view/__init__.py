"""The interactive workbench: a browser and notebook viewer of runs, live while they run.

::

    nscd view out/demo/run.h5              # a history (or a checkpoint): prints its URL
    nscd view out/sweep_runs/              # a folder of runs: a list picks the run
    nscd view RUN.h5 --follow              # a run still being written: new frames appear
    nscd run CONFIG.toml --view            # a run and its viewer together

    from workbench import view
    view.show("out/demo/run.h5")           # in Jupyter: the same app in the output cell

What it shows and how (docs/view.md): a 3D view rendered with :mod:`workbench.render`'s
pipeline and theme (camera presets of :data:`workbench.render.CAMERAS`), a time slider
with play/pause, the layers of :mod:`workbench.meshes` each toggled (sand beads, wire
beads, wire tension network, force chains, walls, the toroidal map of a cylinder run),
colour by any field with limits fixed over the whole run by default, a clip plane, sand
ghosted, a strong-network threshold, picking, the run's curves (click to move to a frame)
and a screenshot button.

Modules: :mod:`~workbench.view.source` (reading runs: frames, curves, colour limits, a
folder's runs), :mod:`~workbench.view.scene` (the layers in a PyVista plotter, picking),
:mod:`~workbench.view.curves` (the Plotly figure), :mod:`~workbench.view.app` (the trame
app).  trame and PyVista are imported when a viewer is made, not at import.
"""
from __future__ import annotations

import ipaddress
import sys

__all__ = ["show", "serve", "open_viewer", "is_loopback", "MODES", "DEFAULT_MODE"]

#: where the 3D view is drawn: in the browser (vtk.js) or on this machine (images)
MODES = ("server", "client")
#: the mode with the faster frame change at 30 000 beads (bench/results/view-20261203-1217:
#: 0.24 s client, 0.58 s server; the demo's 729 spheres: 0.16 s and 0.14 s)
DEFAULT_MODE = "client"


def is_loopback(host: str) -> bool:
    """Whether ``host`` is a loopback address or ``localhost`` (what the browser of this
    machine only can reach)."""
    if host in ("localhost", "localhost.localdomain"):
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def open_viewer(path, *, follow: bool = False, mode: str = DEFAULT_MODE, shots="out/view",
                name: str | None = None, poll: float = 1.0):
    """A :class:`~workbench.view.app.Viewer` of ``path`` (a history, a checkpoint or a
    folder of runs).  :class:`~workbench.view.source.ViewInputError` (a ValueError, one
    line) for a path it cannot show."""
    from .app import Viewer
    from .source import open_input

    source, runs = open_input(path)
    return Viewer(source, runs, follow=follow, mode=mode, shots=shots, name=name, poll=poll)


def serve(path, *, host: str = "127.0.0.1", port: int = 0, follow: bool = False,
          mode: str = DEFAULT_MODE, shots="out/view", announce=print) -> int:
    """Serve the viewer of ``path`` until Ctrl-C / SIGTERM (blocking); ``announce`` gets
    the URL once the server listens.  Returns the port."""
    from .app import port_free

    if port and not port_free(host, port):
        raise ValueError(f"--port {port}: the port is in use on {host}; choose another or "
                         f"leave --port out for a free one")
    viewer = open_viewer(path, follow=follow, mode=mode, shots=shots)

    def ready(**_):
        announce(f"http://{host if ':' not in host else f'[{host}]'}:{viewer.server.port}/")

    viewer.server.controller.on_server_ready.add(ready)
    argv, sys.argv = sys.argv, sys.argv[:1]   # trame reads its own options from argv
    try:
        viewer.start(host=host, port=port)
    finally:
        sys.argv = argv
        viewer.stop()
    return viewer.server.port


def show(run, *, follow: bool = False, mode: str = DEFAULT_MODE, height: int = 800,
         shots="out/view"):
    """The viewer of ``run`` (a path to a history, checkpoint or folder of runs) inline in a
    Jupyter output cell: starts the app's server on a free port of 127.0.0.1 in the
    notebook's event loop and returns the viewer, whose display is the app in an iframe.
    Call it as the last line of a cell, or ``display(view.show(...))``."""
    import asyncio

    from .app import free_port

    viewer = open_viewer(run, follow=follow, mode=mode, shots=shots)
    port = free_port()
    viewer.server.start(exec_mode="task", port=port, host="127.0.0.1", open_browser=False,
                        show_connection_info=False, disable_logging=True, timeout=0)
    viewer.port = port
    viewer.url = f"http://127.0.0.1:{port}/"
    viewer.height = int(height)
    try:
        asyncio.get_event_loop()
    except RuntimeError:  # pragma: no cover - no loop: not in Jupyter
        pass
    return _Inline(viewer)


class _Inline:
    """A viewer shown in a notebook cell (an iframe to its server)."""

    def __init__(self, viewer):
        self.viewer = viewer
        self.url = viewer.url

    def _repr_html_(self) -> str:
        import html

        u = html.escape(self.url, quote=True)
        return (f'<iframe src="{u}" class="nscd-view" style="width: 100%; height: '
                f'{self.viewer.height}px; border: 1px solid #ddd;"></iframe>'
                f'<div style="font-size: 11px">nscd view: <a href="{u}" target="_blank">{u}</a>'
                f'</div>')

    def __repr__(self) -> str:
        return f"nscd view at {self.url}"
