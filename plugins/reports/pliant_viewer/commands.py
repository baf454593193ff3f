"""``pliant view TARGET`` and the live view of ``pliant run --view`` (the core's flag; this plugin answers its
``pliant_run_view`` hook).  Argparse only: the viewer loads on use."""

from __future__ import annotations

import errno
import ipaddress
import math
import os
import re
import socket
import sys
import time
from pathlib import Path

from pliant.api import LOOPBACK, ConfigError, add_page_arguments, load_scene

#: the most poses of the timeline an export records (each adds the robot's pose updates to the page)
MAX_FRAMES = 10_000


def add_arguments(p) -> None:
    """The arguments of ``pliant view``."""
    p.add_argument("target", help="scene name or TOML, run folder (out/<name>/), or policy / result JSON")
    p.add_argument("--scene", help="the scene of a policy or result file (default: from the run folder's run.json)")
    add_page_arguments(p)
    p.add_argument("--export", metavar="FILE.html",
                   help="write a self-contained HTML page of the view (plays the timeline back) and exit")
    p.add_argument("--frames", type=int, default=60,
                   help=f"poses of the timeline in an export, 2-{MAX_FRAMES} (default 60)")
    p.add_argument("--open", action="store_true", help="open the page in the default browser")
    p.add_argument("--no-cache", action="store_true",
                   help="neither read nor write the run folder's view-cache.npz (kept for articulated robots) nor "
                        "the converted robot meshes (~/.cache/pliant/viewer)")


def resolve(target: str, scene_name: str | None):
    """``(scene, run data or None, policy JSON or None)`` for a view target (see the command's help)."""

    from pliant_viewer.content import RunData, check_policy, check_result, read_json, read_run

    path = Path(target)
    if path.is_dir():
        run = read_run(path)
        name = scene_name or run.scene_name
        if not name:
            raise ConfigError("a run folder needs run.json (or --scene)", source=str(path), field="scene")
        return _load_scene(name, path, None if scene_name else run.scene_variant), run, None
    if path.is_file() and path.suffix == ".json":
        data = read_json(path)
        sibling = read_run(path.parent) if (path.parent / "run.json").is_file() else RunData()
        name = scene_name or sibling.scene_name
        if not name:
            raise ConfigError("name the scene of this file with --scene", source=str(path), field="scene")
        variant = None if scene_name else sibling.scene_variant
        if "nodes" in data:                                    # a policy file
            return _load_scene(name, path.parent, variant), sibling, check_policy(data, path)
        if "status" in data:                                   # a result file
            sibling.result = check_result(data, path)
            return _load_scene(name, path.parent, variant), sibling, None
        raise ConfigError("not a policy or result file (no 'nodes' or 'status')", source=str(path), field="target")
    return load_scene(target), None, None


def _load_scene(name: str, base: Path, variant: str | None = None):
    candidate = base / name
    if candidate.is_file():
        return load_scene(candidate, variant=variant)
    return load_scene(name, variant=variant)


def check_address(host: str, port: int, prefix: str = "") -> None:
    """Refuse at once a page address the server could not serve on (viser would retry or hang): ``port`` outside
    0-65535 (0: a free one), ``host`` not an address of this machine or not a host at all, ``port`` in use.  Errors
    name ``--{prefix}host`` / ``--{prefix}port`` and the value."""
    host_flag, port_flag = f"--{prefix}host", f"--{prefix}port"
    if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
        raise ConfigError("must be a port number 1-65535 (leave it out for a free one)", field=port_flag, value=port)
    if not isinstance(host, str) or not host.strip():
        raise ConfigError("must name an address of this machine (127.0.0.1: this machine only)", field=host_flag,
                          value=host)
    if re.fullmatch(r"[0-9.]+", host):
        try:
            ipaddress.IPv4Address(host)
        except ValueError:
            raise ConfigError("is not an IPv4 address", field=host_flag, value=host) from None
    try:
        family, kind, proto, _, where = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)[0]
    except (socket.gaierror, UnicodeError) as exc:
        raise ConfigError(f"is not a known host ({getattr(exc, 'strerror', None) or exc})", field=host_flag,
                          value=host) from None
    with socket.socket(family, kind, proto) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)      # as the server binds
        try:
            probe.bind(where)
        except OSError as exc:
            if exc.errno == errno.EADDRINUSE:
                raise ConfigError("is in use (leave it out for a free one)", field=port_flag, value=port) from None
            if exc.errno == errno.EACCES:
                raise ConfigError("needs privileges (ports below 1024); pick one above", field=port_flag,
                                  value=port) from None
            if exc.errno == errno.EADDRNOTAVAIL:
                raise ConfigError("is not an address of this machine", field=host_flag, value=host) from None
            raise ConfigError(f"cannot serve there ({exc.strerror or exc})", field=host_flag, value=host) from None


def check_hold(seconds: float | None, flag: str = "--hold") -> None:
    """``--hold``: None (until Ctrl-C) or seconds >= 0."""
    if seconds is not None and (math.isnan(seconds) or seconds < 0):
        raise ConfigError("must be seconds >= 0 (leave it out to serve until Ctrl-C)", field=flag, value=seconds)


def check_export(target: str, frames: int) -> Path:
    """``--export FILE.html`` and ``--frames``: a file path whose directory exists or can be made and is writable
    (not a directory, not a device or pipe), and 2-:data:`MAX_FRAMES` poses.  Checked before any work, so a bad
    one writes nothing."""
    if isinstance(frames, bool) or not isinstance(frames, int) or not 2 <= frames <= MAX_FRAMES:
        raise ConfigError(f"must be 2-{MAX_FRAMES} poses of the timeline", field="--frames", value=frames)
    if not target.strip() or "\x00" in target:
        raise ConfigError("must name an HTML file to write", field="--export", value=target)
    path = Path(target)
    if path.is_dir():
        raise ConfigError("is a directory; name a file in it (e.g. view.html)", field="--export", value=target)
    if path.exists() and not path.is_file():
        raise ConfigError("is not a regular file", field="--export", value=target)
    parent = path.parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir():
        raise ConfigError(f"cannot be written: {parent} is not a directory", field="--export", value=target)
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ConfigError(f"cannot be written: {parent} is not writable", field="--export", value=target)
    return path


def open_viewer(host: str, port: int, prefix: str = "", **options):
    """A started :class:`~pliant_viewer.viewer.Viewer` on ``host:port`` (0: a free port), the address checked first
    (:func:`check_address`); another server taking the port meanwhile is the same error as a port in use."""
    from pliant_viewer.viewer import Viewer

    check_address(host, port, prefix)
    _warn_if_exposed(host)
    viewer = Viewer(host=host, port=port or None, **options)
    if port and viewer.port != port:
        viewer.stop()
        raise ConfigError("is in use (leave it out for a free one)", field=f"--{prefix}port", value=port)
    return viewer


def cmd_view(args) -> int:
    """Run ``pliant view TARGET``: serve the 3-D page of a scene, run folder or policy file until ``--hold`` runs out or
    Ctrl-C, or write it as a self-contained HTML page (``--export``)."""
    t0 = time.perf_counter()
    check_address(args.host, args.port)
    check_hold(args.hold)
    if args.export is not None:
        check_export(args.export, args.frames)
    viewer = None
    if not args.export:
        # serve the page first: the browser loads and starts viser's client (~1 s in software WebGL) while the
        # scene and the run are read; the scene's nodes reach it when they are ready
        viewer = open_viewer(args.host, args.port, robot_meshes=args.robot_meshes, use_cache=not args.no_cache)
        print(f"viewer: {viewer.url}  (loading {args.target})", flush=True)
        if args.open:
            import webbrowser

            webbrowser.open(viewer.url)
    try:
        from pliant.api import VoxelGrid

        from pliant_viewer import cache
        from pliant_viewer.content import check_dimension, voxel_objects
        from pliant_viewer.viewer import build_content

        scene, run, policy = resolve(args.target, args.scene)
        folder = Path(args.target) if run is not None and Path(args.target).is_dir() else None
        policy_file = args.target if policy is not None else str((folder or Path(".")) / "result.json")
        check_dimension(run, policy if policy is not None else run.policy if run else None, len(scene.start),
                        policy_file)
        if viewer is None:
            viewer = open_viewer(args.host, args.port, robot_meshes=args.robot_meshes, use_cache=not args.no_cache)
        view = cache.load(folder, scene) if folder is not None and not args.no_cache else None
        if view is None:
            # the page can draw the scene's objects while the robot model and the rest are built
            grid = VoxelGrid.from_scene(scene)
            objects = voxel_objects(grid)
            viewer.show_objects(scene, objects)
            try:
                view = build_content(scene, run=run, policy=policy, grid=grid, objects=objects)
            except (KeyError, TypeError, ValueError, IndexError) as exc:
                # the files passed the checks of their form (content.read_run) but their content does not fit
                raise ConfigError(f"its data does not fit the scene '{scene.name}' ({type(exc).__name__}: {exc})",
                                  source=args.target, field="target") from None
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


class LiveView:
    """``pliant run PIPELINE --view`` (the ``pliant_run_view`` hook): the scene in the page first, every execution
    step streamed into it (:meth:`on_step`), then the finished run -- path, policy, trajectory with the slider --
    until ``--view-hold`` runs out or Ctrl-C (:meth:`finish`)."""

    def __init__(self, pipeline, args) -> None:
        from pliant_viewer.viewer import build_content, make_robot

        check_address(args.view_host, args.view_port, "view-")
        check_hold(args.view_hold, "--view-hold")
        self.pipeline, self.hold = pipeline, args.view_hold
        self.scene = pipeline.load_scene()
        spec = pipeline.components.get("robot")
        self.robot = make_robot(self.scene, spec.name if spec and spec.name else None,
                                spec.options if spec else None)
        self.viewer = open_viewer(args.view_host, args.view_port, "view-", robot_meshes=args.view_robot_meshes)
        try:
            self.viewer.show(build_content(self.scene, self.robot))
        except BaseException:
            self.viewer.stop()
            raise
        print(f"viewer: {self.viewer.url}  (live; the execution streams in when it starts)", flush=True)
        self.on_step = self.viewer.on_step

    def finish(self, record) -> None:
        """Show the finished run (if its folder holds one) and serve it until ``--view-hold`` runs out or Ctrl-C."""
        from pliant_viewer.content import read_run
        from pliant_viewer.viewer import build_content

        try:
            if record is None:
                return
            folder = self.pipeline.output
            if (folder / "run.json").is_file():
                self.viewer.robot_drawing.ready.wait(30)
                self.viewer.reset()
                self.viewer.show(build_content(self.scene, self.robot, run=read_run(folder)))
            print(f"viewer: {self.viewer.url}  (the finished run; {len(self.viewer._live)} steps streamed live; "
                  "Ctrl-C to stop)", flush=True)
            sys.stdout.flush()
            _hold(self.hold)
        finally:
            self.viewer.stop()
