"""The page the viewer serves: viser's client with one small script of ours in its head.

The script concerns software WebGL only (SwiftShader, llvmpipe: a browser without a GPU, a headless Chromium).  There
a drawn frame of baxter-reach took 120-200 ms, most of it shading the fragments of the large voxel objects, and
multisampling (the canvas's ``antialias``, on by default in viser's renderer) multiplies that work; without it the
same page drew in about half the time (``docs/plugins/viewer.md``, Figures).  So when the browser's WebGL renderer
is a software one, the script creates WebGL contexts without multisampling; edges are then not smoothed.  With a GPU
nothing changes.  ``?antialias=1`` in the page's address keeps multisampling on a software renderer too.

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
  // pliant viewer: no multisampling on a software WebGL renderer (see pliant_viewer/page.py)
  if (/[?&]antialias=1/.test(location.search)) return;
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
  HTMLCanvasElement.prototype.getContext = function (type, attributes) {
    if ((type === 'webgl2' || type === 'webgl') && isSoftware()) {
      attributes = Object.assign({}, attributes || {}, {antialias: false});
    }
    return getContext.call(this, type, attributes);
  };
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
