"""``pliant view TARGET`` and the ``--view`` flag of ``pliant run`` (argparse only; the viewer loads on use)."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from pliant.errors import ConfigError

LOOPBACK = "127.0.0.1"


def _address_arguments(p, prefix: str = "") -> None:
    p.add_argument(f"--{prefix}host", default=LOOPBACK,
                   help="address to serve the page on (default 127.0.0.1, loopback only; 0.0.0.0 exposes it)")
    p.add_argument(f"--{prefix}port", type=int, default=0, help="port (default: a free one)")
    p.add_argument(f"--{prefix}hold", type=float, default=None, metavar="SECONDS",
                   help="keep serving this long, then exit (default: until Ctrl-C)")
    p.add_argument(f"--{prefix}robot-meshes", choices=("collision", "visual"), default="collision",
                   help="a URDF robot's meshes: collision (light, the default) or visual (detailed, slow to draw)")


def add_commands(subparsers) -> None:
    p = subparsers.add_parser("view", help="open a 3-D view of a scene, a run folder or a policy in the browser",
                              description="Serve a local web page (viser) showing TARGET in 3-D: a scene name or "
                                          "file, a pipeline run folder (out/<name>/), or a policy / result JSON "
                                          "file.  The page shows the voxel objects coloured by material, the "
                                          "robot, the planned path, the executed trajectory with a time slider, "
                                          "the belief tree and a Pareto front.")
    p.add_argument("target", help="scene name or TOML, run folder (out/<name>/), or policy / result JSON")
    p.add_argument("--scene", help="the scene of a policy or result file (default: from the run folder's run.json)")
    _address_arguments(p)
    p.add_argument("--export", metavar="FILE.html",
                   help="write a self-contained HTML page of the view (plays the timeline back) and exit")
    p.add_argument("--frames", type=int, default=60, help="poses of the timeline in an export (default 60)")
    p.add_argument("--open", action="store_true", help="open the page in the default browser")
    p.add_argument("--no-cache", action="store_true",
                   help="neither read nor write the run folder's view-cache.npz (kept for articulated robots) nor "
                        "the converted robot meshes (~/.cache/pliant/viewer)")
    p.set_defaults(handler=cmd_view)

    run = subparsers.choices.get("run")
    if run is not None:
        group = run.add_argument_group("live 3-D view (pliant_viewer)")
        group.add_argument("--view", action="store_true",
                           help="stream the execution into a 3-D page as it happens (prints its address)")
        group.add_argument("--view-host", default=LOOPBACK, help="address of the live page (default 127.0.0.1)")
        group.add_argument("--view-port", type=int, default=0, help="port of the live page (default: a free one)")
        group.add_argument("--view-hold", type=float, default=None, metavar="SECONDS",
                           help="after the run, keep serving the finished run this long (default: until Ctrl-C)")
        group.add_argument("--view-robot-meshes", choices=("collision", "visual"), default="collision",
                           help="a URDF robot's meshes in the live page (default collision)")
        original = run.get_default("handler")
        run.set_defaults(handler=lambda args: run_with_view(args, original))


def resolve(target: str, scene_name: str | None):
    """``(scene, run data or None, policy JSON or None)`` for a view target (see the command's help)."""
    import pliant

    from pliant_viewer.content import RunData, read_json, read_run

    path = Path(target)
    if path.is_dir():
        run = read_run(path)
        name = scene_name or run.scene_name
        if not name:
            raise ConfigError("a run folder needs run.json (or --scene)", source=str(path), field="scene")
        return _load_scene(pliant, name, path, None if scene_name else run.scene_variant), run, None
    if path.is_file() and path.suffix == ".json":
        data = read_json(path)
        sibling = read_run(path.parent) if (path.parent / "run.json").is_file() else RunData()
        name = scene_name or sibling.scene_name
        if not name:
            raise ConfigError("name the scene of this file with --scene", source=str(path), field="scene")
        variant = None if scene_name else sibling.scene_variant
        if "nodes" in data:                                    # a policy file
            return _load_scene(pliant, name, path.parent, variant), sibling, data
        if "status" in data:                                   # a result file
            sibling.result = data
            return _load_scene(pliant, name, path.parent, variant), sibling, None
        raise ConfigError("not a policy or result file (no 'nodes' or 'status')", source=str(path), field="target")
    return pliant.load_scene(target), None, None


def _load_scene(pliant, name: str, base: Path, variant: str | None = None):
    candidate = base / name
    if candidate.is_file():
        return pliant.load_scene(candidate, variant=variant)
    return pliant.load_scene(name, variant=variant)


def cmd_view(args) -> int:
    t0 = time.perf_counter()
    _warn_if_exposed(args.host)
    viewer = None
    if not args.export:
        # serve the page first: the browser loads and starts viser's client (~1 s in software WebGL) while the
        # scene and the run are read; the scene's nodes reach it when they are ready
        from pliant_viewer.viewer import Viewer

        viewer = Viewer(host=args.host, port=args.port or None, robot_meshes=args.robot_meshes,
                        use_cache=not args.no_cache)
        print(f"viewer: {viewer.url}  (loading {args.target})", flush=True)
        if args.open:
            import webbrowser

            webbrowser.open(viewer.url)
    try:
        from pliant.geometry.voxelgrid import VoxelGrid

        from pliant_viewer import cache
        from pliant_viewer.content import voxel_objects
        from pliant_viewer.viewer import Viewer, build_content

        scene, run, policy = resolve(args.target, args.scene)
        if viewer is None:
            viewer = Viewer(host=args.host, port=args.port or None, robot_meshes=args.robot_meshes,
                            use_cache=not args.no_cache)
        folder = Path(args.target) if run is not None and Path(args.target).is_dir() else None
        view = cache.load(folder, scene) if folder is not None and not args.no_cache else None
        if view is None:
            # the page can draw the scene's objects while the robot model and the rest are built
            grid = VoxelGrid.from_scene(scene)
            objects = voxel_objects(grid)
            viewer.show_objects(scene, objects)
            view = build_content(scene, run=run, policy=policy, grid=grid, objects=objects)
            viewer.show(view)
            if folder is not None and view.articulated and not args.no_cache:
                cache.save(view, folder)        # the next view of this run needs no robot model
        else:
            viewer.show(view)
        if args.export:
            viewer.robot_drawing.ready.wait(120)
            out = viewer.export_html(Path(args.export), frames=args.frames)
            print(f"exported {out} ({out.stat().st_size / 1e6:.1f} MB)")
            return 0
        print(f"viewer: {viewer.url}  ({scene.name}, ready in {time.perf_counter() - t0:.2f} s; Ctrl-C to stop)",
              flush=True)
        _hold(args.hold)
    finally:
        if viewer is not None:
            viewer.stop()
    return 0


def _warn_if_exposed(host: str) -> None:
    if host not in (LOOPBACK, "::1", "localhost"):
        print(f"note: the page is served on {host}, not only on this machine (no authentication)", file=sys.stderr)


def _hold(seconds: float | None) -> None:
    end = None if seconds is None else time.monotonic() + seconds
    try:
        while end is None or time.monotonic() < end:
            time.sleep(0.2 if end is None else max(0.0, min(0.2, end - time.monotonic())))
    except KeyboardInterrupt:
        pass


def run_with_view(args, original) -> int:
    """``pliant run PIPELINE --view``: the scene in the page first, every execution step streamed into it, then
    the finished run (path, policy, trajectory with the slider) until ``--view-hold`` runs out or Ctrl-C."""
    if not getattr(args, "view", False):
        return original(args)
    from pliant.pipeline import Pipeline

    from pliant_viewer.content import read_run
    from pliant_viewer.viewer import Viewer, build_content, make_robot

    overrides = list(args.set or [])
    if args.output is not None:
        overrides.append(f"output={json.dumps(args.output)}")
    pipeline = Pipeline.from_file(args.pipeline, overrides=overrides)
    scene = pipeline.load_scene()
    spec = pipeline.components.get("robot")
    robot = make_robot(scene, spec.name if spec and spec.name else None, spec.options if spec else None)
    _warn_if_exposed(args.view_host)
    viewer = Viewer(host=args.view_host, port=args.view_port or None, robot_meshes=args.view_robot_meshes)
    try:
        viewer.show(build_content(scene, robot))
        print(f"viewer: {viewer.url}  (live; the execution streams in when it starts)", flush=True)
        args.on_step = viewer.on_step                      # cmd_run hands it to Pipeline.run
        code = original(args)
        folder = pipeline.output
        if (folder / "run.json").is_file():
            viewer.robot_drawing.ready.wait(30)
            viewer.reset()
            viewer.show(build_content(scene, robot, run=read_run(folder)))
        print(f"viewer: {viewer.url}  (the finished run; {len(viewer._live)} steps streamed live; Ctrl-C to stop)",
              flush=True)
        sys.stdout.flush()
        _hold(args.view_hold)
    finally:
        viewer.stop()
    return code
