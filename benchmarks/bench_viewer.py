"""The 3-D viewer (plugins/reports/pliant_viewer) in headless Chromium: time to first frame, frames per second.

1. Time to first frame, baxter-reach with its policy: ``pliant view RUN`` is started as a command (a new Python
   process) while a headless Chromium (Debian's, through selenium; started before, as a user's browser is open)
   opens its address when the command prints it; with ``--no-cache`` (the view built from the run's files, the
   robot's meshes converted with yourdfpy) and "after run": the run folder's view cache as ``pliant run`` writes it
   (the viewer's report hook, called here with the run's robot model) and the converted robot meshes.  First frame =
   the first animation frame in which WebGL has drawn the voxel objects, the planned path and the policy (a probe
   of the page's draw calls, :data:`pliant_viewer.browser.DRAW_PROBE`); also when the robot's meshes are drawn.
   Figure to reach: <= 2 s after the command.
2. A 10,000-node tree: a synthetic belief tree over Baxter's 7 joints (random extensions from the start, 24
   particles a node) on baxter-reach; frames drawn per second while the page is left alone, while the mouse drags
   the view and while the server swings the camera (+-30 degrees, the scene in view), as drawn by default (the
   first 2,000 nodes and every solution's, with their particles) and after the page's "whole tree" switch (10,000
   nodes and edges, 50,000 of the 240,000 particles).  Interactive = at least 10 frames drawn a second while the view
   moves (the mouse dragging it, the server swinging it); the page lightens a moving camera's frames in software
   WebGL (pliant_viewer.page: 0.4 of the pixel ratio, 10,000 of the particles), and the table says when it did.
3. 10 s of a 24-particle execution, live: the Baxter execution of the run streamed through :meth:`Viewer.on_step`
   at its own rate (25 Hz) with 24 particles (the executed configuration plus noise) drawn and trailed every step;
   frames drawn per second during the stream.  ``--parts before-after`` streams it alternately into the page as it
   was before the software-WebGL changes (double-sided voxel faces; multisampling, kept by ``?antialias=1``) and as
   it is now.

    pliant bench viewer [-- --run out/viewer/baxter-policy --repeats 3 --parts first,tree,execution,before-after]

Chromium renders in software here (SwiftShader; no GPU), 1280 x 800, and the machine's other load counts: the load
average is printed before and after.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import pliant
from _common import print_table, write_json
from pliant.execution.loop import ExecutionStep
from pliant.interfaces import Context
from pliant_viewer import browser, cache
from pliant_viewer import viewer as viewer_module
from pliant_viewer.content import read_run
from pliant_viewer.report import write_view_cache
from pliant_viewer.viewer import Viewer, build_content, free_port

SHOTS = Path("out/bench/viewer")
CHILD_ENV = None        # the environment of `pliant view` (None: this one); see --pycache


def signatures(view) -> dict[str, list[str]]:
    """The WebGL draw signatures (:data:`pliant_viewer.browser.DRAW_PROBE`) of the view's nodes: its voxel objects,
    planned path, policy edges, nodes and particles ("scene"), and the robot's meshes ("robot")."""
    sig = {"objects": [browser.mesh_signature(len(o.faces)) for o in view.objects]}
    if view.path_xyz is not None and len(view.path_xyz) > 1:
        sig["path"] = [browser.segments_signature(len(view.path_xyz) - 1)]
    if view.tree is not None:
        n = len(view.tree.edges)
        sig["policy"] = [browser.lines_signature(n) if n > viewer_module.GLB_EDGES else browser.segments_signature(n),
                         browser.points_signature(len(view.tree.nodes)),
                         browser.points_signature(len(view.tree.particles))]
    return sig


def robot_signatures(view, meshes: str = "collision") -> list[str]:
    from pliant_viewer import robot_mesh

    robot = robot_mesh.load_or_convert(view.urdf, meshes)
    return [browser.mesh_signature(len(f)) for _, _, f, _ in robot.meshes]


def first_frame(run: Path, b: browser.Browser, expect: dict, robot: list[str], extra: tuple[str, ...] = (),
                timeout: float = 120.0, query: str = "") -> dict:
    """Seconds from starting ``pliant view RUN`` to its first frame in the browser (the first animation frame in
    which WebGL has drawn every node of ``expect``: the voxel objects, the planned path and the policy), and to the
    frame that also holds the robot's meshes.  The browser opens the address when the command prints it."""
    d = b.driver
    d.get("about:blank")
    port = free_port()
    url = f"http://127.0.0.1:{port}/"
    exe = shutil.which("pliant") or str(Path(sys.executable).with_name("pliant"))
    t0 = time.time()
    proc = subprocess.Popen([exe, "view", str(run), "--port", str(port), "--hold", "120", *extra],
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=CHILD_ENV)
    try:
        line = proc.stdout.readline()
        if url not in line:
            raise RuntimeError(f"pliant view printed {line!r}")
        t_printed = time.time() - t0
        d.get(url + query)
        nav = d.execute_script("const n = performance.getEntriesByType('navigation')[0];"
                               "return [performance.timeOrigin, n.responseEnd];")
        t_page = (nav[0] + nav[1]) / 1000.0 - t0
        wanted = [s for group in expect.values() for s in group]
        while True:
            draws = browser.first_draws(d)
            if all(s in draws for s in wanted):
                break
            if time.time() - t0 > timeout:
                raise TimeoutError(f"not drawn: {[s for s in wanted if s not in draws]}")
            time.sleep(0.02)
        parts = {k: max(draws[s] for s in group) - t0 for k, group in expect.items()}
        t_first = max(parts.values())
        d.save_screenshot(str(SHOTS / "first-frame.png"))
        while not all(s in draws for s in robot):
            if time.time() - t0 > timeout:
                raise TimeoutError("the robot was not drawn")
            time.sleep(0.02)
            draws = browser.first_draws(d)
        t_robot = max((draws[s] for s in robot), default=t_first + t0) - t0
        time.sleep(1.0)
        browser.dismiss_notifications(d)
        d.save_screenshot(str(SHOTS / "robot-in.png"))
        return {"printed": t_printed, "page": t_page, **{f"{k}_drawn": v for k, v in parts.items()},
                "first_frame": t_first, "robot": t_robot, "lod_engaged": lod_engaged(d)}
    finally:
        proc.terminate()
        proc.wait(10)


def synthetic_tree(scene, nodes: int, particles: int, rng: np.random.Generator) -> dict:
    """A belief tree of ``nodes`` nodes grown by random extensions from the start (steps of 0.15 rad a joint, kept
    in the joints' range) with ``particles`` particles each (the node plus 0.02 rad noise)."""
    d = len(scene.start)
    q = np.empty((nodes, d))
    parent = np.full(nodes, -1)
    q[0] = scene.start
    for i in range(1, nodes):
        parent[i] = rng.integers(0, i)
        q[i] = np.clip(q[parent[i]] + rng.normal(0.0, 0.15, d), -2.5, 2.5)
    out = []
    for i in range(nodes):
        parts = q[i] + rng.normal(0.0, 0.02, (particles, d))
        out.append({"particles": parts.tolist(), "parent": None if i == 0 else int(parent[i]),
                    "expected": q[i].tolist(), "path_probability": float(rng.uniform())})
    return {"nodes": out, "actions": [{"target": q[i].tolist()} for i in range(1, nodes, 10)], "solutions": []}


def open_page(viewer: Viewer, b: browser.Browser, text: str, query: str = "") -> None:
    d = b.driver
    d.get(viewer.url + query)
    browser.wait_for_text(d, text, 120)
    viewer.robot_drawing.ready.wait(120)
    t0 = time.perf_counter()
    while "/robot" not in browser.scene_tree(d) and time.perf_counter() - t0 < 60:
        time.sleep(0.05)
    time.sleep(2.0)
    browser.dismiss_notifications(d)


def turn_camera(viewer: Viewer, seconds: float, rate: float = 30.0, swing: float = 30.0) -> int:
    """Swing the page's camera about its target from the server, ``rate`` times a second for ``seconds``, by up to
    ``swing`` degrees either side of where it looks from (one swing in 4 s): every step is a new view to draw, and the
    scene stays in view.  (A full turn took the camera behind baxter-reach's wall for half of it, where a frame drew 2
    of its 15 nodes.)  Returns the steps sent."""
    client = next(iter(viewer.server.get_clients().values()))
    target = np.asarray(client.camera.look_at, dtype=np.float64)
    offset = np.asarray(client.camera.position, dtype=np.float64) - target
    steps, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        a = np.radians(swing) * np.sin(2 * np.pi * (time.perf_counter() - t0) / 4.0)
        c, s_ = np.cos(a), np.sin(a)
        client.camera.position = tuple(target + [c * offset[0] - s_ * offset[1], s_ * offset[0] + c * offset[1],
                                                 offset[2]])
        steps += 1
        time.sleep(1.0 / rate)
    client.camera.position = tuple(target + offset)
    return steps


def lod_engaged(driver) -> int | None:
    """How many times the page has lightened its frames for a moving camera so far (pliant_viewer.page), or None
    when the page has no such script."""
    return driver.execute_script("return window.__pliantLod ? window.__pliantLod.engaged : null")


def view_fps(viewer: Viewer, b: browser.Browser, seconds: float) -> dict:
    """Frames drawn per second left alone, while the mouse drags the view, and while the server turns the camera;
    with how many times the page's motion level of detail engaged in each window."""
    d = b.driver
    out = {}
    for key, action in (("idle", lambda: time.sleep(seconds)), ("orbit", lambda: browser.orbit(d, seconds)),
                        ("turn", lambda: turn_camera(viewer, seconds))):
        if key == "turn":
            time.sleep(1.0)
        before = lod_engaged(d)
        browser.start_frame_counter(d)
        n = action()
        out[key] = browser.read_frame_counters(d)
        after = lod_engaged(d)
        out[key]["lod_engaged"] = None if before is None else after - before
        if key == "orbit":
            out["strokes"] = n
        elif key == "turn":
            out["turns"] = n
    return out


def tree_fps(scene, robot, b: browser.Browser, seconds: float, rng) -> dict:
    t0 = time.perf_counter()
    policy = synthetic_tree(scene, 10_000, 24, rng)
    view = build_content(scene, robot, policy=policy)
    viewer = Viewer()
    try:
        viewer.show(view)
        build = time.perf_counter() - t0
        open_page(viewer, b, "policy: 10000 nodes")
        loaded = time.perf_counter() - t0
        default = view_fps(viewer, b, seconds)
        time.sleep(1.0)                 # at rest: the page draws at full resolution and every particle again
        b.driver.save_screenshot(str(SHOTS / "tree-10000.png"))
        drawn = viewer.tree_drawn
        # the page's "whole tree" switch: every node, edge and (up to 50,000) particles
        labels = b.driver.find_elements("xpath", "//*[contains(text(), 'whole tree')]")
        for label in labels:
            b.driver.execute_script("arguments[0].click();", label)
        t1 = time.perf_counter()
        while viewer.tree_drawn != len(view.tree.nodes) and time.perf_counter() - t1 < 60:
            time.sleep(0.05)
        if viewer.tree_drawn != len(view.tree.nodes):
            raise RuntimeError(f"the page's 'whole tree' switch did not reach the server ({len(labels)} labels)")
        time.sleep(3.0)
        whole = view_fps(viewer, b, seconds)
        time.sleep(1.0)
        b.driver.save_screenshot(str(SHOTS / "tree-10000-whole.png"))
        return {"nodes": len(view.tree.nodes), "nodes_drawn": drawn, "particles_drawn": len(view.tree.particles),
                "build_s": build, "page_s": loaded, "default": default, "whole_nodes_drawn": viewer.tree_drawn,
                "whole": whole}
    finally:
        viewer.stop()


def execution_fps(scene, robot, run, b: browser.Browser, rng, seconds: float = 10.0, rate: float = 25.0,
                  live_rate: float | None = None, before: bool = False) -> dict:
    """Stream ``seconds`` of the execution at ``rate`` steps a second, each with 24 particles, into a page that
    draws at most ``live_rate`` updates a second (the viewer's default when ``None``).  ``before``: the page as
    drawn before the software-WebGL changes (double-sided voxel faces, multisampling kept by ``?antialias=1``)."""
    from pliant_viewer import viewer as viewer_module

    view = build_content(scene, robot)
    viewer = Viewer() if live_rate is None else Viewer(live_rate=live_rate)
    try:
        side = viewer_module.VOXEL_SIDE
        viewer_module.VOXEL_SIDE = "double" if before else side
        try:
            viewer.show(view)
        finally:
            viewer_module.VOXEL_SIDE = side
        open_page(viewer, b, f"pliant -- {scene.name}", query="?antialias=1" if before else "")
        if run is not None and run.trajectory is not None:
            _, executed = run.trajectory
        else:
            executed = np.linspace(scene.start, scene.goal, int(seconds * rate))
        steps = int(seconds * rate)
        idx = np.minimum(np.arange(steps) * len(executed) // steps, len(executed) - 1)
        offsets = rng.normal(0.0, 0.03, (24, len(scene.start)))
        browser.start_frame_counter(b.driver)
        time.sleep(3.0)
        idle = browser.read_frame_counters(b.driver)
        browser.start_frame_counter(b.driver)
        t0 = time.perf_counter()
        late = 0.0
        for k in range(steps):
            q = executed[idx[k]]
            viewer.on_step(ExecutionStep(k / rate, q, np.zeros(len(q)), q, False, {}))
            viewer.show_particles(q + offsets)
            wait = t0 + (k + 1) / rate - time.perf_counter()
            if wait > 0:
                time.sleep(wait)
            else:
                late = max(late, -wait)
        wall = time.perf_counter() - t0
        fps = browser.read_frame_counters(b.driver)
        b.driver.save_screenshot(str(SHOTS / "execution-24.png"))
        return {"steps": steps, "particles": 24, "stream_s": wall, "max_lag_s": late, "fps": fps, "fps_idle": idle,
                "live_rate": viewer.live_rate, "updates": viewer.live_updates, "before": before}
    finally:
        viewer.stop()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--run", default=None,
                        help="run folder of baxter-reach with a policy (default: out/viewer/baxter-policy, else "
                             "out/baxter-policy; make one with `pliant run baxter-policy`)")
    parser.add_argument("--repeats", type=int, default=3, help="time-to-first-frame repeats (default 3)")
    parser.add_argument("--seconds", type=float, default=5.0, help="fps measuring window (default 5 s)")
    parser.add_argument("--parts", default="first,tree,execution",
                        help="what to measure, comma-separated: first (time to first frame), tree, execution, "
                             "before-after (the live stream with the page as before the software-WebGL changes and "
                             "as now, alternately, --repeats times each)")
    parser.add_argument("--pycache", action="store_true",
                        help="run `pliant view` with Python's bytecode cache (PYTHONDONTWRITEBYTECODE unset, the cache "
                             "in out/bench/pycache), as on a machine where pliant's modules were imported before")
    args = parser.parse_args()
    global CHILD_ENV
    if args.pycache:
        CHILD_ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
        CHILD_ENV["PYTHONPYCACHEPREFIX"] = str(Path("out/bench/pycache").resolve())
    parts = set(args.parts.split(","))
    reason = browser.missing()
    if reason:
        print(f"skipped: {reason}")
        return
    candidates = [Path(args.run)] if args.run else [Path("out/viewer/baxter-policy"), Path("out/baxter-policy"),
                                                      Path("out/viewer/baxter-contact")]
    run_dir = next((c for c in candidates if (c / "result.json").is_file() and read_run(c).policy), None)
    if run_dir is None:
        print(f"no baxter-reach run with a policy in {', '.join(map(str, candidates))}: "
              "run `pliant run baxter-policy` first")
        return
    SHOTS.mkdir(parents=True, exist_ok=True)
    run = read_run(run_dir)
    scene = pliant.load_scene(run.scene_name)
    rng = np.random.default_rng(0)
    results: dict = {"load_before": os.getloadavg(), "run": str(run_dir), "pycache": args.pycache,
                     "dont_write_bytecode": os.environ.get("PYTHONDONTWRITEBYTECODE"),
                     "policy_nodes": len(run.policy["nodes"]),
                     "result_status": (run.result or {}).get("status")}
    from pliant_viewer.viewer import build_content, make_robot

    robot = make_robot(scene)
    view = build_content(scene, robot, run=run)
    expect, robot_sigs = signatures(view), robot_signatures(view)
    results["signatures"] = {"scene": expect, "robot": robot_sigs}
    with browser.Browser(1280, 800) as b:
        browser.install_draw_probe(b.driver)
        if "first" in parts:
            if args.pycache:        # one view, not measured, writes the bytecode of every module a view imports
                first_frame(run_dir, b, expect, robot_sigs, ("--no-cache",))
            cold = [first_frame(run_dir, b, expect, robot_sigs, ("--no-cache",)) for _ in range(args.repeats)]
            # the view cache as `pliant run` leaves it: written by the viewer's report hook with the run's robot model
            (run_dir / cache.NAME).unlink(missing_ok=True)
            t0 = time.perf_counter()
            written = write_view_cache(SimpleNamespace(context=Context(scene=scene, robot=robot)), run_dir)
            results["report_hook_s"] = time.perf_counter() - t0
            if written is None:
                raise RuntimeError("the report hook wrote no view cache")
            ttff = [first_frame(run_dir, b, expect, robot_sigs) for _ in range(args.repeats)]
            results["first_frame_cold"] = cold
            results["first_frame"] = ttff
        if "tree" in parts:
            results["tree"] = tree_fps(scene, robot, b, args.seconds, rng)
        if "execution" in parts:
            results["execution"] = execution_fps(scene, robot, run, b, rng)
            results["execution_every_step"] = execution_fps(scene, robot, run, b, rng, live_rate=25.0)
        if "before-after" in parts:
            # the live stream with the page as before the software-WebGL changes and as now, alternately
            results["execution_before_after"] = [execution_fps(scene, robot, run, b, rng, before=k % 2 == 0)
                                                 for k in range(2 * args.repeats)]
    if "first" in parts:
        rows = []
        measures = [("printed", "address printed", ""), ("page", "page loaded", ""),
                    ("objects_drawn", "voxel objects drawn", ""), ("path_drawn", "planned path drawn", ""),
                    ("policy_drawn", "policy drawn", ""),
                    ("first_frame", "first frame (objects, path, policy)", "<= 2 s"),
                    ("robot", "robot meshes drawn", "")]
        for label, runs in (("--no-cache", results["first_frame_cold"]), ("after run", results["first_frame"])):
            for key, text, target in measures:
                values = [r[key] for r in runs if key in r]
                if values:
                    rows.append((label, text, f"{statistics.median(values):.2f}",
                                 " ".join(f"{v:.2f}" for v in values), target))
        print_table(f"time to first frame: pliant view {run_dir} (baxter-reach, {results['policy_nodes']}-node "
                    f"policy), median of {args.repeats}, headless Chromium 1280x800 (software WebGL)",
                    ("view", "measure", "seconds", "runs", "target"), rows)
        print(f"after run: the view cache as `pliant run` writes it (the viewer's report hook, "
              f"{results['report_hook_s']:.2f} s here) and the converted robot meshes; --no-cache: neither")
        bytecode = ("Python's bytecode cache (--pycache)" if args.pycache else
                    "PYTHONDONTWRITEBYTECODE=1: every pliant module compiled at each start" if
                    os.environ.get("PYTHONDONTWRITEBYTECODE") else "Python's default bytecode cache")
        print(f"pliant view ran with {bytecode}")
        loads = results["first_frame_cold"] + results["first_frame"]
        print(f"the page lightened its frames for a moving camera (pliant_viewer.page) while loading in "
              f"{sum(1 for r in loads if r.get('lod_engaged'))} of {len(loads)} loads")
    rows = []

    def fps(x: dict) -> str:
        lod = " lod" if x.get("lod_engaged") else ""
        return f"{x['drawn']:.1f} ({x['animation']:.0f}; {x['calls']:.0f} calls{lod})"

    if "tree" in parts:
        t = results["tree"]
        for key, what in (("default", f"first {t['nodes_drawn']} nodes and the solutions (default)"),
                          ("whole", f"whole: {t['whole_nodes_drawn']} nodes, {t['particles_drawn']} particles")):
            x = t[key]
            rows += [(f"10,000-node tree, {what}", "left alone", fps(x["idle"]), ""),
                     ("", f"mouse dragging the view ({x['strokes']} strokes)", fps(x["orbit"]), ">= 10"),
                     ("", f"camera swung by the server ({x['turns']} steps)", fps(x["turn"]), ">= 10")]
    if "execution" in parts:
        for x in (results["execution"], results["execution_every_step"]):
            rows += [("24-particle execution, live", f"{x['steps']} steps at 25 Hz in {x['stream_s']:.1f} s, "
                      f"{x['updates']} updates (at most {x['live_rate']:.0f}/s)", fps(x["fps"]), ">= 10"),
                     ("", "the same page left alone before", fps(x["fps_idle"]), "")]
    if "before-after" in parts:
        for x in results["execution_before_after"]:
            page = "before (double-sided faces, multisampling)" if x["before"] else "now"
            rows.append((f"24-particle execution, live, page {page}", f"{x['updates']} updates (at most "
                         f"{x['live_rate']:.0f}/s)", fps(x["fps"]), ""))
    if rows:
        print_table("interactivity in headless Chromium: frames drawn per second (animation frames per second; "
                    "WebGL draw calls per drawn frame; lod: the page lightened its frames for the moving camera); "
                    "interactive = at least 10 frames drawn a second while the view moves",
                    ("case", "while", "fps", "target"), rows)
    if "tree" in parts:
        print(f"\ntree: built in {t['build_s']:.1f} s, in the page after {t['page_s']:.1f} s; screenshots in {SHOTS}/")
    results["load_after"] = os.getloadavg()
    print("load average before: {:.2f} {:.2f} {:.2f}; after: {:.2f} {:.2f} {:.2f}".format(*results["load_before"],
                                                                                         *results["load_after"]))
    write_json("viewer", results)


if __name__ == "__main__":
    main()
