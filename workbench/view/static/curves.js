// The curves panel of `nscd view` (workbench/view/app.py): the server sends the figure
// (state `curves_fig`: Plotly's {data, layout}) when the curves change and the current
// frame's vertical lines (state `curves_marks`: layout shapes) when the frame changes.
//
// plotly.js (4.6 MB) is loaded here, on demand, once the 3D view shows its first picture:
// loaded with the page it cost about 1 s before that picture on this project's machine
// (bench/bench_view.py), and the 3D view is what a user opens the page for.
(function () {
  "use strict";
  const VIEW_WAIT_MS = 3000;      // load anyway after this long without a picture
  let loading = null;             // the promise of window.Plotly
  const latest = {};              // element id -> {fig, marks, onClick}

  function viewShown() {
    // the server's image (an <img> in the view) decoded, or the client view's canvas drawn
    const t0 = performance.now();
    return new Promise((resolve) => {
      (function poll() {
        const img = document.querySelector("#view3d img");
        const shown = img && img.complete && img.naturalWidth > 0;
        const client = !img && document.querySelector("#view3d canvas");
        if (shown || performance.now() - t0 > VIEW_WAIT_MS ||
            (client && performance.now() - t0 > 1000)) {
          requestAnimationFrame(() => setTimeout(resolve, 0));
          return;
        }
        setTimeout(poll, 50);
      })();
    });
  }

  function plotly() {
    if (window.Plotly) return Promise.resolve(window.Plotly);
    if (!loading) {
      loading = viewShown().then(() => new Promise((resolve, reject) => {
        const s = document.createElement("script");
        s.src = window.nscdCurves.src;
        s.async = true;
        s.onload = () => resolve(window.Plotly);
        s.onerror = () => reject(new Error("cannot load " + s.src));
        document.head.appendChild(s);
      }));
    }
    return loading;
  }

  function draw(id) {
    const el = document.getElementById(id);
    const want = latest[id];
    if (!el || !want || !want.fig || !window.Plotly) return;
    const layout = Object.assign({}, want.fig.layout, {shapes: want.marks || []});
    window.Plotly.react(el, want.fig.data, layout,
                        {displayModeBar: false, responsive: true}).then(() => {
      if (!el.__nscdClick) {
        el.__nscdClick = true;
        el.on("plotly_click", (ev) => {
          const p = ev && ev.points && ev.points[0];
          const cb = latest[id] && latest[id].onClick;
          if (p && p.customdata !== undefined && p.customdata !== null && cb) cb(p.customdata);
        });
      }
    });
  }

  window.nscdCurves = {
    src: "__nscd_plotly/plotly.min.js",
    show(id, fig, marks, onClick) {
      latest[id] = {fig, marks, onClick};
      if (!fig || !fig.data) return;
      plotly().then(() => draw(id), (e) => console.error(e));
    },
    mark(id, marks) {
      const want = latest[id];
      if (!want) return;
      want.marks = marks;
      const el = document.getElementById(id);
      if (window.Plotly && el && el.data) window.Plotly.relayout(el, {shapes: marks || []});
    },
    resize(id) {
      const el = document.getElementById(id);
      if (window.Plotly && el && el.data) window.Plotly.Plots.resize(el);
    },
  };
})();
