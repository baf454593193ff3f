"""The viewer in a real headless Chromium (Debian's chromium + chromium-driver through selenium): the page loads
from a server on 127.0.0.1, the client's own scene tree holds the nodes the server sent, its WebGL render is not
blank and shows the objects' material colour, moving the time slider in the page moves the robot, and screenshots
are saved (under out/viewer-test/, kept for the docs)."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import numpy as np
import pliant
import pytest
from pliant_viewer import browser, content
from pliant_viewer.viewer import Viewer, build_content

pytestmark = pytest.mark.slow
SHOTS = Path("out/viewer-test")


@pytest.fixture(scope="module")
def chromium():
    reason = browser.missing()
    if reason:
        pytest.skip(reason)
    b = browser.Browser(width=1280, height=800)
    yield b
    b.quit()


@pytest.fixture(scope="module")
def maze_run(tmp_path_factory):
    """A planned and executed run of the maze-slide pipeline (a few seconds), with a small policy tree over it."""
    out = tmp_path_factory.mktemp("maze-slide")
    pipeline = pliant.Pipeline.from_file("maze-slide", overrides=[f'output="{out}"'])
    pipeline.run()
    return out


def _render(viewer, timeout=60.0):
    t0 = time.perf_counter()
    while not viewer.server.get_clients():
        assert time.perf_counter() - t0 < timeout, "no client connected"
        time.sleep(0.05)
    client = next(iter(viewer.server.get_clients().values()))
    return client.get_render(height=400, width=640, transport_format="png", timeout=timeout)[..., :3]


def test_page_shows_the_run_and_the_slider_moves_the_robot(chromium, maze_run):
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    run = content.read_run(maze_run)
    scene = pliant.load_scene(run.scene_name)
    path = run.path
    policy = {"nodes": [{"particles": [list(q)] * 3, "parent": i - 1 if i else None, "expected": list(q),
                         "path_probability": 1.0 - 0.2 * i} for i, q in enumerate(path)],
              "actions": [{"target": list(q)} for q in path[1:]], "solutions": [list(range(len(path)))]}
    view = build_content(scene, run=run, policy=policy)
    viewer = Viewer(host="127.0.0.1")
    try:
        assert viewer.url.startswith("http://127.0.0.1:")
        viewer.show(view)
        d = chromium.driver
        browser.install_draw_probe(d)
        d.get(viewer.url)
        browser.wait_for_text(d, f"pliant -- {scene.name}")
        browser.dismiss_notifications(d)
        # the client's own scene tree: every top-level node the server sent
        t0 = time.perf_counter()
        while not {"/scene", "/robot", "/path", "/policy"} <= set(browser.scene_tree(d)):
            assert time.perf_counter() - t0 < 30, browser.scene_tree(d)
            time.sleep(0.1)
        assert "walls: 1280 voxels" in d.find_element(By.TAG_NAME, "body").text
        # the served page carries the viewer's script: Chromium here renders in software (SwiftShader), so the
        # scene's WebGL context is made without multisampling
        assert viewer.page_patched
        assert d.execute_script("return window.__pliantSoftwareWebGL") is True
        antialias = d.execute_script("return Array.from(document.querySelectorAll('canvas'))"
                                     ".map(c => c.getContext('webgl2')).filter(g => g)"
                                     ".map(g => g.getContextAttributes().antialias)")
        assert antialias and not any(antialias)
        # the policy's few edges are line segments (instanced quads), drawn with the rest
        t0 = time.perf_counter()
        while browser.segments_signature(len(path) - 1) not in browser.first_draws(d):
            assert time.perf_counter() - t0 < 30, browser.first_draws(d)
            time.sleep(0.1)
        # the browser's WebGL render: not blank, with the walls' material colour on screen
        image = _render(viewer)
        assert image.std() > 5 and len(np.unique(image.reshape(-1, 3), axis=0)) > 50, "blank page"
        wall = content.material_colours(np.array([0.0]), np.array([1.0]))[0].astype(int)
        near = np.abs(image.astype(int) - wall).sum(axis=2) < 120      # lit and shaded, but that hue
        assert near.sum() > 200, "the walls are not drawn"
        SHOTS.mkdir(parents=True, exist_ok=True)
        d.save_screenshot(str(SHOTS / "maze-start.png"))
        before = np.asarray(viewer.robot_drawing.frame.position).copy()
        # move the time slider in the page, as a user would (keyboard on the slider's thumb)
        (thumb,) = d.find_elements(By.CSS_SELECTOR, '[role="slider"]')
        thumb.click()
        thumb.send_keys(Keys.END)
        # viser stores the value before its callbacks run (on a thread pool): wait for the move to be drawn
        _, executed = run.trajectory
        t0 = time.perf_counter()
        while (viewer.slider.value < viewer.slider.max - 1e-6 or not viewer.slider_moves
               or not np.allclose(viewer.robot_drawing.frame.position[:2], executed[-1, :2], atol=1e-6)):
            assert time.perf_counter() - t0 < 20, "the slider's move did not reach the server"
            time.sleep(0.05)
        after = np.asarray(viewer.robot_drawing.frame.position)
        np.testing.assert_allclose(after[:2], executed[-1, :2], atol=1e-6)
        assert np.linalg.norm(after - before) > 1.0
        moved = _render(viewer)
        assert np.abs(moved.astype(int) - image.astype(int)).sum(axis=2).astype(bool).sum() > 100
        d.save_screenshot(str(SHOTS / "maze-end.png"))
    finally:
        viewer.stop()


def test_static_export_plays_in_the_browser(chromium, maze_run, tmp_path):
    """``pliant view RUN --export page.html``: one self-contained file that Chromium opens from disk (file://, no
    server) and plays the execution back; the page is not blank."""
    import io

    import matplotlib.image as mpimg
    from pliant.cli import main

    page = tmp_path / "maze.html"
    assert main(["view", str(maze_run), "--export", str(page), "--frames", "20"]) == 0
    d = chromium.driver
    d.get(page.as_uri())
    t0 = time.perf_counter()
    while not d.execute_script("return document.querySelectorAll('canvas').length"):
        assert time.perf_counter() - t0 < 30, "no canvas"
        time.sleep(0.1)
    time.sleep(3.0)
    browser.dismiss_notifications(d)
    shot = mpimg.imread(io.BytesIO(d.get_screenshot_as_png()), format="png")[..., :3]
    assert shot.std() > 0.02 and len(np.unique((shot * 255).astype(np.uint8).reshape(-1, 3), axis=0)) > 50
    SHOTS.mkdir(parents=True, exist_ok=True)
    d.save_screenshot(str(SHOTS / "maze-export.png"))


def test_a_moving_camera_lightens_the_frame_and_rest_restores_it(chromium):
    """On a software WebGL renderer the page's script (pliant_viewer.page) draws at 0.4 of the pixel ratio and at most
    MOTION_POINTS of a large particle cloud while the camera moves -- the prefix of the cloud, which the viewer sends
    in a shuffled order -- and everything at full resolution once the camera rests; a single camera jump (as when the
    page loads) does not count as a move."""
    rng = np.random.default_rng(0)
    centres = rng.uniform(0.2, 0.8, (600, 3))
    policy = {"nodes": [{"particles": (q + rng.normal(0, 0.01, (24, 3))).tolist(), "parent": i - 1 if i else None,
                         "expected": q.tolist(), "path_probability": 0.5} for i, q in enumerate(centres)],
              "actions": [], "solutions": []}
    from test_viewer_content import small_scene

    scene = small_scene()
    viewer = Viewer(host="127.0.0.1")
    script = """
        const m = window.__viserMutable, root = m && m.nodeRefFromName['/policy/particles'];
        let count = null;
        if (root) root.traverse(o => { if (o.isPoints) count = o.geometry.drawRange.count; });
        if (count === Infinity) count = -1;             // all of it (JSON has no Infinity)
        const gl = m && m.canvas;                               // viser's 3-D canvas
        return [window.__pliantLod.moving, window.__pliantLod.engaged, count, gl ? gl.width : 0,
                gl ? Math.round(gl.clientWidth * window.devicePixelRatio) : 0];"""
    try:
        viewer.show(build_content(scene, policy=policy))
        d = chromium.driver
        browser.install_draw_probe(d)
        d.get(viewer.url)
        browser.wait_for_text(d, "policy: 600 nodes")
        # 599 edges: drawn as WebGL lines (one non-instanced call, pliant_viewer.glb), not as instanced quads
        t0 = time.perf_counter()
        while browser.lines_signature(599) not in browser.first_draws(d):
            assert time.perf_counter() - t0 < 30, browser.first_draws(d)
            time.sleep(0.1)
        t0 = time.perf_counter()
        while d.execute_script(script)[2] is None:
            assert time.perf_counter() - t0 < 30, "no particle cloud in the page"
            time.sleep(0.1)
        time.sleep(1.0)
        moving, engaged, count, _, full = d.execute_script(script)
        assert (moving, engaged, count) == (False, 0, -1)               # the page loaded: no move, every point
        client = next(iter(viewer.server.get_clients().values()))
        target = np.asarray(client.camera.look_at, dtype=np.float64)
        offset = np.asarray(client.camera.position, dtype=np.float64) - target
        # the camera swings from a thread of its own, 30 steps a second, whatever the page's frame rate: sampling the
        # page blocks until it has drawn a frame (under software WebGL on a slow or busy machine, 0.3-0.5 s), and a
        # camera set only between samples is a jump per frame, not a move
        swinging = threading.Event()
        swinging.set()

        def swing():
            k = 0
            while swinging.is_set():
                a = 0.3 * np.sin(k / 10.0)
                client.camera.position = tuple(target + [np.cos(a) * offset[0] - np.sin(a) * offset[1],
                                                         np.sin(a) * offset[0] + np.cos(a) * offset[1], offset[2]])
                time.sleep(1 / 30)
                k += 1

        swinger = threading.Thread(target=swing, daemon=True)
        swinger.start()
        seen, t0 = [], time.perf_counter()
        try:
            while time.perf_counter() - t0 < 90:    # until the page says moving (a loaded machine: up to 90 s)
                time.sleep(0.2)
                seen.append(d.execute_script(script))
                if seen[-1][0] and seen[-1][2] is not None and seen[-1][2] >= 0:
                    break
        finally:
            swinging.clear()
            swinger.join(timeout=5)
        assert any(s[0] for s in seen), seen[-15:]
        moving_state = [s for s in seen if s[0]][-1]
        assert moving_state[2] == 10_000, moving_state                  # the cloud's first 10,000 of 14,400 points
        assert moving_state[3] == pytest.approx(0.4 * full, abs=2), (moving_state, full)  # 0.4 of the pixel ratio
        # at rest (0.4 s after the last move; up to 60 s on a loaded machine): every point, and the canvas at the
        # device's pixel ratio (viser's own adaptive ratio may lower it by a quarter at most when frames are slow; it
        # starts again from full after a move)
        t0 = time.perf_counter()
        while True:
            time.sleep(0.5)
            moving, engaged, count, width, full = d.execute_script(script)
            if not moving or time.perf_counter() - t0 > 60:
                break
        assert (moving, count) == (False, -1) and engaged >= 1 and 0.74 * full <= width <= full
    finally:
        viewer.stop()
