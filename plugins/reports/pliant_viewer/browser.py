"""Headless Chromium for the viewer's tests and benchmark: Debian's ``chromium`` and ``chromium-driver`` through
selenium, with the flags that keep it off the network (no background networking, component updates or sync) and a
fresh profile.  selenium is told where chromedriver is, so selenium-manager never downloads anything.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--disable-dev-shm-usage", "--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader")


def missing() -> str | None:
    """Why headless Chromium cannot run here, or ``None`` when it can."""
    for path in (CHROMIUM, CHROMEDRIVER):
        if not Path(path).exists():
            return f"{path} is not installed (Debian: apt-get install chromium chromium-driver; `make install`)"
    try:
        import selenium  # noqa: F401
    except ImportError:
        return "selenium is not installed (pip install selenium; it is in pliant's test extra)"
    return None


class Browser:
    """One headless Chromium window (``width`` x ``height``) driven by selenium; :meth:`quit` ends it and removes
    its profile."""

    def __init__(self, width: int = 1280, height: int = 800) -> None:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service

        self.profile = tempfile.mkdtemp(prefix="pliant-chromium-")
        options = webdriver.ChromeOptions()
        options.binary_location = CHROMIUM
        for flag in FLAGS:
            options.add_argument(flag)
        options.add_argument(f"--user-data-dir={self.profile}")
        options.add_argument(f"--window-size={width},{height}")
        self.driver = webdriver.Chrome(service=Service(executable_path=CHROMEDRIVER), options=options)

    def quit(self) -> None:
        try:
            self.driver.quit()
        finally:
            shutil.rmtree(self.profile, ignore_errors=True)

    def __enter__(self) -> Browser:
        return self

    def __exit__(self, *exc) -> None:
        self.quit()


def wait_for_text(driver, text: str, timeout: float = 60.0) -> float:
    """Seconds until ``text`` shows in the page's body (the viewer's summary arrives after the scene's nodes);
    raises ``TimeoutError``."""
    import time

    from selenium.common.exceptions import WebDriverException

    t0 = time.perf_counter()
    while time.perf_counter() - t0 < timeout:
        try:
            if text in driver.execute_script("return document.body ? document.body.innerText : ''"):
                return time.perf_counter() - t0
        except WebDriverException:
            pass
        time.sleep(0.02)
    raise TimeoutError(f"'{text}' did not appear in the page within {timeout} s")


def scene_tree(driver) -> list[str]:
    """The node names of the client's own scene tree (viser's scene-tree table: one "Edit props for NAME" button
    per node it holds, children listed once their parent is expanded)."""
    labels = driver.execute_script(
        "return Array.from(document.querySelectorAll('[aria-label^=\"Edit props for \"]'))"
        ".map(e => e.getAttribute('aria-label').slice('Edit props for '.length));")
    return list(labels)


def dismiss_notifications(driver) -> None:
    """Close viser's notices (e.g. "Software WebGL rendering detected") so that screenshots show the scene."""
    driver.execute_script(
        "document.querySelectorAll('.mantine-Notification-closeButton, [class*=Notification] button')"
        ".forEach(b => b.click());")


def start_frame_counter(driver) -> None:
    """Count the page's frames from now on (read with :func:`read_frame_counters`): animation frames, and drawn
    frames -- those in which WebGL drew anything.  viser renders on demand: a page left alone draws about one frame a
    second while its animation frames run at the display's rate, so only drawn frames say how smooth a moving view
    is.  Drawn frames need :func:`install_draw_probe` before the page was opened (else they read 0)."""
    driver.execute_script("""
        window.__pliantFrames = 0; window.__pliantDrawn = 0; window.__pliantT0 = performance.now();
        window.__pliantCalls0 = window.__pliantDrawCalls || 0;
        const token = {}; window.__pliantCounter = token;
        let last = window.__pliantDrawCalls;
        (function tick() {
            if (window.__pliantCounter !== token) return;
            window.__pliantFrames++;
            if (window.__pliantDrawCalls !== last) { window.__pliantDrawn++; last = window.__pliantDrawCalls; }
            requestAnimationFrame(tick);
        })();""")


def read_frame_counters(driver) -> dict[str, float]:
    """``{"drawn": frames drawn a second, "animation": animation frames a second, "calls": WebGL draw calls per
    drawn frame}`` since :func:`start_frame_counter` (the calls say whether the frames drew the whole scene)."""
    frames, drawn, ms, calls = driver.execute_script(
        "return [window.__pliantFrames, window.__pliantDrawn, performance.now() - window.__pliantT0,"
        " (window.__pliantDrawCalls || 0) - window.__pliantCalls0];")
    return {"drawn": drawn / (ms / 1000.0), "animation": frames / (ms / 1000.0), "calls": calls / max(drawn, 1)}


def orbit(driver, seconds: float) -> int:
    """Drag the 3-D view with the mouse for ``seconds`` (small back-and-forth strokes on the canvas, as a user
    turning the camera); returns the strokes made."""
    import time

    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By

    canvas = driver.find_element(By.TAG_NAME, "canvas")
    strokes, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        dx = 40 if strokes % 2 == 0 else -40
        ActionChains(driver, duration=50).move_to_element_with_offset(canvas, -150, 0).click_and_hold() \
            .move_by_offset(dx, 10).move_by_offset(dx, -10).release().perform()
        strokes += 1
    return strokes


# Every WebGL draw call of the page, by signature "mode:count:instances" (mode 4 triangles, 1 lines, 0 points; count
# the indices or vertices drawn; instances 1 unless instanced), with the time (Date.now(), ms) it was first drawn.  A
# drawn node has its own signature: a mesh of F triangles "4:3F:1", a cloud of N points "0:N:1", S line segments
# "4:18:S" (viser draws them as instanced quads), S segments as WebGL lines (the tree's edges) "1:2S:1".  viser
# renders every animation frame, so a node drawn once is drawn in every frame after it (while in view): the first
# frame holding a set of nodes is the latest of their first draws.
DRAW_PROBE = """
window.__pliantDraws = {};
window.__pliantDrawCalls = 0;
for (const C of [window.WebGL2RenderingContext, window.WebGLRenderingContext]) {
  if (!C) continue;
  const P = C.prototype;
  for (const f of ['drawElements', 'drawArrays', 'drawElementsInstanced', 'drawArraysInstanced']) {
    const orig = P[f];
    if (!orig) continue;
    P[f] = function (...a) {
      const count = f.startsWith('drawElements') ? a[1] : a[2];
      const instances = f.endsWith('Instanced') ? a[a.length - 1] : 1;
      const key = a[0] + ':' + count + ':' + instances;
      if (!(key in window.__pliantDraws)) window.__pliantDraws[key] = Date.now();
      window.__pliantDrawCalls++;
      return orig.apply(this, a);
    };
  }
}
"""


def install_draw_probe(driver) -> None:
    """Record the page's WebGL draw calls (:data:`DRAW_PROBE`) in every page this browser opens from now on."""
    driver.execute_cdp_cmd("Page.addScriptToEvaluateOnNewDocument", {"source": DRAW_PROBE})


def first_draws(driver) -> dict[str, float]:
    """``{signature: seconds since the epoch}`` of the draw calls the current page made (see :data:`DRAW_PROBE`)."""
    draws = driver.execute_script("return window.__pliantDraws || {}")
    return {k: v / 1000.0 for k, v in draws.items()}


def mesh_signature(triangles: int) -> str:
    """The draw-call signature (:data:`DRAW_PROBE`) of a mesh of ``triangles`` triangles."""
    return f"4:{3 * int(triangles)}:1"


def points_signature(n: int) -> str:
    """The draw-call signature (:data:`DRAW_PROBE`) of a cloud of ``n`` points."""
    return f"0:{int(n)}:1"


def segments_signature(n: int) -> str:
    """The draw-call signature (:data:`DRAW_PROBE`) of ``n`` line segments (viser's instanced quads)."""
    return f"4:18:{int(n)}"


def lines_signature(n: int) -> str:
    """``n`` segments drawn as WebGL lines (``gl.LINES``, mode 1: 2n vertices in one call; pliant_viewer.glb)."""
    return f"1:{2 * int(n)}:1"
