"""The page the viewer serves: viser's client with one small script of ours in its head.

The script concerns software WebGL only (SwiftShader, llvmpipe: a browser without a GPU, a headless Chromium).  There
a drawn frame of baxter-reach took 120-200 ms, most of it shading the fragments of the large voxel objects, and
multisampling (the canvas's ``antialias``, on by default in viser's renderer) multiplies that work; without it the
same page drew in about half the time (``docs/plugins/viewer.md``, Figures).  So when the browser's WebGL renderer
is a software one, the script creates WebGL contexts without multisampling; edges are then not smoothed.  With a GPU
nothing changes.  ``?antialias=1`` in the page's address keeps multisampling on a software renderer too.

It also lightens the frames of a moving camera there (level of detail): from the first drag or wheel event on the
canvas, or once the camera has changed in 3 animation frames in a row (a camera set once, as when the page loads, is
not a move), the page draws at 0.4 of its pixel ratio (viser's own ``fixedDpr`` setting) and only the first 10,000
points of ``/policy/particles`` (three.js's draw range; the viewer sends them shuffled, so they are an even sample);
0.4 s after the camera stops, everything at full resolution again.  Every node and edge is drawn in every frame.
It reaches viser's client through the objects it exposes (``window.__viserMutable``, ``window.__viserTestpoints``);
without them it does nothing.  ``?lod=0`` turns it off; ``window.__pliantLod`` holds its state and settings.

viser serves its client from one directory (``http_server_root``, its package's ``client/build``) chosen when its
server is created; :func:`start_server` points it at a copy of that ``index.html`` with the script added, written
once into the user's cache (``$XDG_CACHE_HOME/pliant/viewer``, else a temporary directory).  Should viser change
how it builds its server, the page is served unpatched (logged) and everything else works as before.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import logging
import os
import tempfile
import threading
from pathlib import Path

log = logging.getLogger(__name__)
_SWAP = threading.Lock()        # one server built at a time while viser's WebsockServer is substituted

SOFTWARE_WEBGL = """<script>
(function () {
  // pliant viewer (see pliant_viewer/page.py): on a software WebGL renderer, no multisampling, and a lighter frame
  // while the camera moves (0.4 of the pixel ratio, at most MOTION_POINTS points of the clouds named in LOD_NODES);
  // everything at full resolution again once the camera has rested REST_MS
  var MOTION_SCALE = 0.4, MOTION_POINTS = 10000, MOTION_TICKS = 3, REST_MS = 400, LOD_NODES = ['/policy/particles'];
  var search = location.search;
  var getContext = HTMLCanvasElement.prototype.getContext, software = null;
  function isSoftware() {
    if (software !== null) return software;
    software = false;
    var t0 = performance.now();
    try {
      var gl = getContext.call(document.createElement('canvas'), 'webgl');
      if (gl) {
        var info = gl.getExtension('WEBGL_debug_renderer_info');
        var name = String(gl.getParameter(info ? info.UNMASKED_RENDERER_WEBGL : gl.RENDERER));
        software = /swiftshader|llvmpipe|softpipe|software/i.test(name);
        var lose = gl.getExtension('WEBGL_lose_context');
        if (lose) lose.loseContext();
      }
    } catch (e) { software = false; }
    window.__pliantSoftwareWebGL = software;
    window.__pliantProbeMs = performance.now() - t0;
    return software;
  }
  if (!/[?&]antialias=1/.test(search)) {
    HTMLCanvasElement.prototype.getContext = function (type, attributes) {
      if ((type === 'webgl2' || type === 'webgl') && isSoftware()) {
        attributes = Object.assign({}, attributes || {}, {antialias: false});
      }
      return getContext.call(this, type, attributes);
    };
  }
  // viser's client exposes its scene (window.__viserMutable) and its settings store (window.__viserTestpoints);
  // without them nothing here happens
  var lod = {moving: false, engaged: 0, since: -1e9, saved: null, run: 0, changed: false, scale: MOTION_SCALE,
             points: MOTION_POINTS};
  window.__pliantLod = lod;
  function reduce(on) {
    var m = window.__viserMutable, t = window.__viserTestpoints, dirty = on !== lod.moving;
    if (!m) return;
    LOD_NODES.forEach(function (name) {
      var root = m.nodeRefFromName && m.nodeRefFromName[name];
      if (!root) return;
      root.traverse(function (o) {
        var g = o.isPoints && o.geometry, n = g && g.attributes.position ? g.attributes.position.count : 0;
        var count = on && n > lod.points ? lod.points : Infinity;
        if (g && g.drawRange.count !== count) { g.setDrawRange(0, count); dirty = true; }
      });
    });
    if (on !== lod.moving && t && t.devSettings) {
      if (on) {
        lod.saved = t.devSettings.get().fixedDpr;
        t.devSettings.set({fixedDpr: lod.scale * (lod.saved || window.devicePixelRatio || 1)});
      } else {
        t.devSettings.set({fixedDpr: lod.saved});
      }
    }
    if (on && !lod.moving) lod.engaged++;
    lod.moving = on;
    if (dirty && m.requestRender) m.requestRender();
  }
  var last = [];
  function tick(now) {
    requestAnimationFrame(tick);
    var m = window.__viserMutable, camera = m && m.camera;
    if (!camera || !isSoftware()) return;
    var pose = camera.position.toArray().concat(camera.quaternion.toArray(), [camera.fov, camera.zoom]);
    var changed = last.length > 0 && pose.some(function (v, i) { return v !== last[i]; });
    var lastChanged = lod.changed;
    lod.changed = changed;
    last = pose;
    if (changed) {
      // a move, not a jump: the camera changed in MOTION_TICKS animation frames in a row, or less than 120 ms
      // apart (a camera set once, as the initial camera is when the page loads, changes nothing)
      lod.run = lastChanged || now - lod.since < 120 ? lod.run + 1 : 1;
      lod.since = now;
      if (lod.moving || lod.run >= MOTION_TICKS) reduce(true);
    } else if (lod.moving && now - lod.since > REST_MS) {
      reduce(false);
    }
  }
  function drag(e) {
    // a drag or a wheel turn on the 3-D canvas moves the camera: lighten the frame from its first event on
    if ((e.type === 'wheel' || e.buttons) && e.target && e.target.tagName === 'CANVAS' && isSoftware()) {
      lod.since = performance.now();
      reduce(true);
    }
  }
  if (!/[?&]lod=0/.test(search)) {
    requestAnimationFrame(tick);
    window.addEventListener('pointermove', drag, true);
    window.addEventListener('wheel', drag, true);
  }
})();
</script>"""


def patch(html: str) -> str:
    """viser's client page with :data:`SOFTWARE_WEBGL` as the first thing in its head (before viser's script)."""
    head = html.index("<head>") + len("<head>")
    return html[:head] + SOFTWARE_WEBGL + html[head:]


def client_root() -> Path | None:
    """A directory holding viser's ``index.html`` patched by :func:`patch` (written once, keyed by the original's
    bytes and the script), or ``None`` when viser's page is not where it was expected."""
    import viser

    original = Path(viser.__file__).resolve().parent / "client" / "build" / "index.html"
    if not original.is_file():
        return None
    data = original.read_bytes()
    digest = hashlib.sha256(data + SOFTWARE_WEBGL.encode()).hexdigest()[:16]
    from pliant_viewer.robot_mesh import cache_dir

    user = getattr(os, "getuid", lambda: "user")()
    for base in (cache_dir(), Path(tempfile.gettempdir()) / f"pliant-viewer-{user}"):
        root = base / f"client-{digest}"
        page = root / "index.html"
        if page.is_file():
            return root
        try:
            root.mkdir(parents=True, exist_ok=True)
            tmp = root / f".index.{os.getpid()}.tmp"
            tmp.write_text(patch(data.decode("utf-8")), encoding="utf-8")
            os.replace(tmp, page)
            return root
        except OSError as exc:
            log.info("patched client page not written to %s: %s", root, exc)
    return None


def start_server(host: str, port: int):
    """``(server, patched)``: a started ``viser.ViserServer`` on ``host:port``, and whether it serves the patched page
    (:func:`client_root`) -- viser's own page when the patch cannot be applied."""
    import viser
    from viser import infra

    root = None
    try:
        root = client_root()
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        log.info("serving viser's own page: %s", exc)
    used = []

    def websock_server(*args, **kwargs):
        if root is not None and "http_server_root" in kwargs:
            kwargs["http_server_root"] = root
            used.append(root)
        return original(*args, **kwargs)

    with _SWAP:
        original = infra.WebsockServer
        infra.WebsockServer = websock_server
        try:
            with contextlib.redirect_stdout(io.StringIO()):      # viser's banner; the commands print the address
                server = viser.ViserServer(host=host, port=port, verbose=False)
        finally:
            infra.WebsockServer = original
    if root is not None and not used:
        log.info("viser built its server differently; serving its own page")
    return server, bool(used)
