"""The curves panel: a run's recorded curves as one Plotly figure (a dict the browser draws).

Panels: the stress–strain curves of a triaxial test (deviator q and mean stress p [kPa]
against the axial strain) and the wire's equivalent stress [kPa]; the kinetic energy [J]
(log scale); the NLGS sweeps per recorded step with the steps that did not converge
marked (red crosses) and the residual.  The current frame is a vertical line on every
panel (:func:`marks`: the page gets the figure when the curves change and only the lines
when the frame does).  Each point carries the index of the frame nearest to it in
``customdata``, so a click on a curve moves to that frame.
"""
from __future__ import annotations

import numpy as np

__all__ = ["figure", "marks", "nearest_frames"]

_LINE = {"deviator": "#1f4e9c", "mean_stress": "#7f7f7f", "wire_equivalent": "#d62728",
         "kinetic_energy": "#2ca02c", "iterations": "#1f4e9c", "residual": "#9467bd"}


def nearest_frames(record_steps, frame_steps) -> np.ndarray:
    """(n,) index of the frame whose step is nearest to each record's step."""
    fs = np.asarray(frame_steps, float)
    rs = np.asarray(record_steps, float)
    if fs.size == 0:
        return np.zeros(rs.shape, int)
    j = np.clip(np.searchsorted(fs, rs), 1, max(fs.size - 1, 1)) if fs.size > 1 else \
        np.zeros(rs.shape, int)
    if fs.size > 1:
        left = fs[j - 1]
        j = np.where(np.abs(rs - left) <= np.abs(fs[j] - rs), j - 1, j)
    return j.astype(int)


def _finite(y):
    y = np.asarray(y, float)
    return np.where(np.isfinite(y), y, None).tolist()


def _panels(curves: dict) -> list[str]:
    return ["stress", "energy", "solver"] if "deviator" in curves else ["energy", "solver"]


def marks(curves: dict, frame_steps, frame_times, frame: int | None) -> list[dict]:
    """The current ``frame``'s vertical line on each panel (Plotly layout shapes): at its
    axial strain on the stress panel (none in the isotropic stage), at its time [s] on the
    others."""
    out = []
    if frame is None:
        return out
    near = nearest_frames(curves["_step"], frame_steps)
    for i, panel in enumerate(_panels(curves)):
        ax = "" if i == 0 else str(i + 1)
        x = None
        if panel == "stress":
            sel = curves["_curve_records"]
            k = np.flatnonzero(near[sel] == frame)
            x = float(curves["deviator"][0][k[0]]) if k.size else None
        elif 0 <= frame < len(frame_times):
            x = float(frame_times[frame])
        if x is not None:
            out.append({"type": "line", "xref": f"x{ax}", "yref": f"y{ax} domain",
                        "x0": x, "x1": x, "y0": 0, "y1": 1,
                        "line": {"color": "#ff7f0e", "width": 2}})
    return out


def figure(curves: dict, frame_steps, frame_times, frame: int | None, *,
           height: int = 300) -> dict:
    """The Plotly figure (``{"data": [...], "layout": {...}}``) of ``curves``
    (:func:`workbench.view.source.curves_of`), the current ``frame`` (an index into
    ``frame_steps`` / ``frame_times`` [s]) marked (:func:`marks`; None: no line)."""
    steps = curves["_step"]
    near = nearest_frames(steps, frame_steps)
    conv = curves["_converged"]
    time = curves["_time"]
    panels = _panels(curves)
    n = len(panels)
    gap = 0.08
    width = (1.0 - gap * (n - 1)) / n
    data, layout = [], {
        "height": height, "margin": {"l": 55, "r": 45, "t": 30, "b": 40},
        "showlegend": True, "legend": {"orientation": "h", "x": 0, "y": 1.0, "yanchor": "bottom",
                                        "font": {"size": 10}},
        "font": {"family": "Arial", "size": 11}, "plot_bgcolor": "white",
        "paper_bgcolor": "white", "hovermode": "x", "clickmode": "event",
        "shapes": marks(curves, frame_steps, frame_times, frame), "annotations": []}
    for i, panel in enumerate(panels):
        ax = "" if i == 0 else str(i + 1)
        x0 = i * (width + gap)
        layout[f"xaxis{ax}"] = {"domain": [x0, x0 + width], "anchor": f"y{ax}",
                                "showline": True, "linecolor": "#444", "ticks": "outside",
                                "gridcolor": "#eee"}
        layout[f"yaxis{ax}"] = {"anchor": f"x{ax}", "showline": True, "linecolor": "#444",
                                "ticks": "outside", "gridcolor": "#eee"}
        xref, yref = f"x{ax}", f"y{ax}"

        def trace(name, x, y, label, idx=None, **kw):
            idx = np.arange(len(x)) if idx is None else idx
            data.append({"type": "scatter", "mode": kw.pop("mode", "lines"), "name": label,
                         "x": _finite(x), "y": _finite(y), "xaxis": xref, "yaxis": yref,
                         "customdata": near[idx].tolist(),
                         "line": {"color": _LINE.get(name, "#333"), "width": 1.5},
                         "hovertemplate": "%{x:.4g}, %{y:.4g}<br>frame %{customdata}"
                                          "<extra></extra>", **kw})

        if panel == "stress":
            sel = curves["_curve_records"]
            for name in ("deviator", "mean_stress", "wire_equivalent"):
                if name in curves:
                    x, y, xl, yl = curves[name]
                    trace(name, x, y, yl.split(" [")[0], sel)
            layout[f"xaxis{ax}"]["title"] = {"text": "axial strain [-]"}
            layout[f"yaxis{ax}"]["title"] = {"text": "stress [kPa]"}
        else:
            t = time
            if panel == "energy":
                trace("kinetic_energy", t, curves["kinetic_energy"][1], "kinetic energy [J]")
                layout[f"yaxis{ax}"].update(type="log", title={"text": "kinetic energy [J]"})
            else:
                trace("iterations", t, curves["iterations"][1], "NLGS sweeps per step")
                bad = np.flatnonzero(~conv)
                if bad.size:
                    trace("bad", t[bad], curves["iterations"][1][bad],
                          f"not converged ({bad.size})", bad, mode="markers",
                          marker={"color": "#d62728", "symbol": "x", "size": 7})
                layout[f"yaxis{ax}"]["title"] = {"text": "NLGS sweeps"}
                # the residual on a right-hand axis of its own
                rax = str(n + 1)
                layout[f"yaxis{rax}"] = {"overlaying": f"y{ax}", "side": "right",
                                         "type": "log", "showgrid": False,
                                         "title": {"text": "residual", "standoff": 2},
                                         "anchor": f"x{ax}"}
                data.append({"type": "scatter", "mode": "lines", "name": "residual",
                             "x": _finite(t), "y": _finite(curves["residual"][1]),
                             "xaxis": xref, "yaxis": f"y{rax}", "customdata": near.tolist(),
                             "line": {"color": _LINE["residual"], "width": 1, "dash": "dot"},
                             "hovertemplate": "%{x:.4g} s, residual %{y:.3g}<br>frame "
                                              "%{customdata}<extra></extra>"})
            layout[f"xaxis{ax}"]["title"] = {"text": "time [s]"}
    return {"data": data, "layout": layout}
