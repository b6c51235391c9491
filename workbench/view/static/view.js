// The 3D view of `nscd view` (workbench/view/app.py): picking, and the client-side view
// (`--mode client`).
//
// vtk.js moves the scene's camera lights with the camera when the mouse turns, pans or
// zooms it (its manipulators call the renderer's updateLightsGeometryToFollowCamera), but
// not when the camera is set from the server (a preset button, reset) nor when a scene
// arrives: a preset after a mouse turn then came back lit as the turned view was (seen:
// 7.4 % of the pixels different from the same preset before the turn).  Here a preset is
// set and the lights then follow the camera, as after a turn.
//
// trame-vtk's view component hands out its camera (getCamera / setCamera) but not its
// renderer: that is reached through the component's provided "view" object (Vue's
// internal instance).  If a trame-vtk release moves it, followLights does nothing and
// says so once in the console (the test of the reset button then fails).
(function () {
  "use strict";
  let warned = false;

  function viewOf(ref) {
    const comp = window.trame && window.trame.refs && window.trame.refs[ref];
    const inner = comp && comp.$ && comp.$.provides && comp.$.provides.view;
    return { comp, inner };
  }

  function followLights(ref) {
    const { inner } = viewOf(ref);
    if (!inner || !inner.renderer || !inner.renderer.updateLightsGeometryToFollowCamera) {
      if (!warned) console.warn("nscd view: the lights cannot follow the camera here");
      warned = true;
      return false;
    }
    inner.renderer.updateLightsGeometryToFollowCamera();
    if (inner.render) inner.render();
    return true;
  }

  function setCamera(ref, camera) {
    const { comp } = viewOf(ref);
    if (!comp || !comp.setCamera) return false;
    comp.setCamera(camera);
    return followLights(ref);
  }

  // A drag that turns, pans or zooms the view ends with a click event on the view (the
  // browser fires one whenever the button goes down and up on the same element): that is
  // not a pick, so it does not reach the view's click handler.  Both modes.
  const DRAG_PX = 4;
  let down = null;
  document.addEventListener("mousedown", (e) => {
    down = e.target.closest && e.target.closest("#view3d") ? [e.clientX, e.clientY] : null;
  }, true);
  document.addEventListener("click", (e) => {
    if (!down || !(e.target.closest && e.target.closest("#view3d"))) return;
    const moved = Math.hypot(e.clientX - down[0], e.clientY - down[1]);
    down = null;
    if (moved > DRAG_PX) e.stopPropagation();
  }, true);

  // The view's size in pixels, sent to the server when it changes (client mode: the
  // screenshot button renders the server's copy of the scene at that size, as the view
  // shows it; in server mode the view sizes the server's window itself).
  let sent = "";
  setInterval(() => {
    const cv = document.querySelector("#view3d canvas");
    if (!cv || !window.trame || !window.trame.trigger || !cv.width || !cv.height) return;
    const size = `${cv.width}x${cv.height}`;
    if (size !== sent) {
      sent = size;
      window.trame.trigger("view_size", [cv.width, cv.height]);
    }
  }, 500);

  window.nscdView = { followLights, setCamera };
})();
