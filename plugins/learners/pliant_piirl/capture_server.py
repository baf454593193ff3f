"""The capture tool's browser page, served on loopback (``pliant learn capture``).

A standard-library HTTP server (no extra dependency) bound to 127.0.0.1 by default serves one page: a top view
(the horizontal slice of the scene through the target) and a side view (the vertical slice through it), the
objects coloured, the probe drawn from tip to tail, the target and the deformation read-out.  The page sends each
key press to the server, which applies it to a :class:`~pliant_piirl.capture.CaptureSession` and answers with the
new state.  ``Enter`` saves the demonstration (once the tip touches the target) to the demonstrations file.

Endpoints: ``GET /`` the page; ``GET /scene`` the slices; ``GET /state``; ``POST /key`` ``{"key": "i"}``;
``POST /save``.  Errors are JSON ``{"error": ...}`` with status 400.
"""

from __future__ import annotations

import json
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import numpy as np
from pliant.api import ConfigError, PliantError

from pliant_piirl.capture import KEYS, CaptureSession
from pliant_piirl.demonstration import load_demonstrations, save_demonstrations

PAGE = """<!doctype html>
<html><head><meta charset="utf-8"><title>pliant learn capture</title>
<style>body{font-family:sans-serif;margin:1em} canvas{border:1px solid #999;margin-right:1em}
#state{white-space:pre;font-family:monospace}</style></head>
<body><h1>pliant learn capture: __SCENE__</h1>
<p>Touch the red target with the probe's tip. Keys: __KEYS__; Enter saves.</p>
<canvas id="top" width="480" height="480"></canvas><canvas id="side" width="480" height="480"></canvas>
<div id="state">loading...</div>
<script>
let scene = null, state = null;
const colours = ["#4e79a7","#59a14f","#edc948","#e15759","#76b7b2","#b07aa1","#ff9da7","#9c755f"];
async function get(url) { const r = await fetch(url); return r.json(); }
async function post(url, body) {
  const r = await fetch(url, {method: "POST", headers: {"Content-Type": "application/json"},
                              body: JSON.stringify(body || {})});
  return r.json();
}
function draw(id, slice, ax, ay) {
  const c = document.getElementById(id), g = c.getContext("2d"), n = slice.length, m = slice[0].length;
  const s = Math.min(c.width / n, c.height / m);
  g.clearRect(0, 0, c.width, c.height);
  for (let i = 0; i < n; i++) for (let j = 0; j < m; j++) if (slice[i][j] >= 0) {
    g.fillStyle = colours[slice[i][j] % colours.length]; g.fillRect(i * s, c.height - (j + 1) * s, s, s); }
  const px = p => (p[ax] - scene.lower[ax]) / scene.resolution * s;
  const py = p => c.height - (p[ay] - scene.lower[ay]) / scene.resolution * s;
  if (!state) return;
  g.strokeStyle = "#222"; g.lineWidth = Math.max(2, scene.radius / scene.resolution * 2 * s);
  g.beginPath(); g.moveTo(px(state.tip), py(state.tip)); g.lineTo(px(state.tail), py(state.tail)); g.stroke();
  g.fillStyle = "red"; g.beginPath(); g.arc(px(state.target), py(state.target), 4, 0, 7); g.fill();
}
function show() {
  draw("top", scene.top, 0, 1); draw("side", scene.side, 0, 2);
  const d = Object.entries(state.deformation).filter(e => e[1] > 0).map(e => e[0] + " " + e[1]).join(", ");
  const p = Object.entries(state.path_deformation).filter(e => e[1] > 0).map(e => e[0] + " " + e[1]).join(", ");
  document.getElementById("state").textContent =
    "distance to target: " + (state.distance * 1000).toFixed(1) + " mm" + (state.reached ? "  REACHED" : "") +
    "\\ndeforming now: " + (d || "nothing") + "\\nalong the path: " + (p || "nothing") +
    "\\nsteps: " + state.steps + ", refused: " + state.refused + (state.message ? "\\n" + state.message : "");
}
document.addEventListener("keydown", async e => {
  if (e.key === "Enter") {
    const r = await post("/save"); state.message = r.error || ("saved to " + r.saved); show(); return;
  }
  if (e.key.length !== 1) return;
  const r = await post("/key", {key: e.key.toLowerCase()});
  if (!r.error) { state = r; show(); }
});
(async () => { scene = await get("/scene"); state = await get("/state"); show(); window.captureReady = true; })();
</script></body></html>
"""


class CaptureServer:
    """Serves the capture page for ``session`` on ``host:port`` (port 0: any free port); saves to ``output``."""

    def __init__(self, session: CaptureSession, output: str | Path, scene_name: str, *, host: str = "127.0.0.1",
                 port: int = 0) -> None:
        self.session, self.output, self.scene_name = session, Path(output), scene_name
        self.lock = threading.Lock()
        self.saved: Path | None = None
        server = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *args):            # quiet: the page polls nothing, but keep stderr clean
                pass

            def do_GET(self):
                if self.path == "/":
                    self._send(200, server.page().encode(), "text/html; charset=utf-8")
                elif self.path == "/scene":
                    self._json(200, server.scene())
                elif self.path == "/state":
                    with server.lock:
                        self._json(200, server.state(server.session.state()))
                else:
                    self._json(404, {"error": f"no such page {self.path}"})

            def do_POST(self):
                length = int(self.headers.get("Content-Length") or 0)
                try:
                    body = json.loads(self.rfile.read(length) or b"{}") if length <= 65536 else None
                    if not isinstance(body, dict):
                        raise ValueError("the request body must be a JSON object")
                    with server.lock:
                        if self.path == "/key":
                            self._json(200, server.state(server.session.press(str(body.get("key", "")))))
                        elif self.path == "/save":
                            self._json(200, {"saved": str(server.save())})
                        else:
                            self._json(404, {"error": f"no such action {self.path}"})
                except (PliantError, ValueError) as exc:
                    self._json(400, {"error": str(exc)})

            def _json(self, status, data):
                self._send(status, json.dumps(data).encode(), "application/json")

            def _send(self, status, body: bytes, kind: str):
                self.send_response(status)
                self.send_header("Content-Type", kind)
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)

        self.httpd = ThreadingHTTPServer((host, port), Handler)
        self.url = f"http://{host}:{self.httpd.server_address[1]}/"

    def page(self) -> str:
        keys = ", ".join(f"{k} {a}" for k, (a, _) in KEYS.items())
        return PAGE.replace("__SCENE__", self.scene_name).replace("__KEYS__", keys)

    def scene(self) -> dict:
        """The two slices through the target: object index per cell (-1 free), x-major."""
        grid = self.session.features.cost.grid
        index = np.clip(np.floor((self.session.task.target - grid.lower) / grid.resolution).astype(int), 0,
                        np.array(grid.shape) - 1)
        ids = grid.object_id
        _, _, local = self.session.robot.rigid_placement(self.session.configuration[None])
        radius = float(np.max(np.linalg.norm(local[:, :2], axis=1))) if len(local) else 0.0
        return {"lower": grid.lower.tolist(), "resolution": float(grid.resolution), "names": list(grid.object_names),
                "top": ids[:, :, index[2]].tolist(), "side": ids[:, index[1], :].tolist(), "radius": radius}

    def state(self, state: dict) -> dict:
        """The session's state plus the probe's tail (the body point farthest from the tip), for drawing."""
        rot, pos, local = self.session.robot.rigid_placement(self.session.configuration[None])
        far = local[int(np.argmax(np.linalg.norm(local - self.session.tip, axis=1)))]
        tail = rot[0] @ np.array([0.0, 0.0, far[2]]) + pos[0]
        return {**state, "tail": tail.tolist()}

    def save(self) -> Path:
        """Add the recorded demonstration to the output file (created if missing, same scene required)."""
        demonstration = self.session.demonstration()
        existing = []
        if self.output.exists():
            scene, existing = load_demonstrations(self.output)
            if scene != self.scene_name:
                raise ConfigError(f"holds demonstrations of scene {scene!r}, not {self.scene_name!r}",
                                  field="--output", value=str(self.output))
        save_demonstrations(self.output, [*existing, demonstration], self.scene_name)
        self.saved = self.output
        return self.output

    def serve_in_background(self) -> threading.Thread:
        thread = threading.Thread(target=self.httpd.serve_forever, daemon=True)
        thread.start()
        return thread

    def close(self) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()
