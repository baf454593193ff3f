"""The 3-D viewer: a viser server (a local web page) showing a scene, its robot and what a run produced.

Scene graph (the names the page's scene tree shows and the tests look for):

- ``/scene/objects/<name>``   each voxel object, its surface voxels as instanced cubes coloured by material
- ``/scene/start``, ``/scene/goal``   the task's ends (at the robot's tip for an articulated robot)
- ``/robot``                  the robot: URDF meshes (PR2, Baxter, iiwa) or the rigid body's voxels
- ``/path/planned``           the planned path (orange); ``/path/executed`` the executed trajectory (blue) and
                              ``/path/now`` where the robot is at the slider's time
- ``/policy/edges``, ``/policy/nodes``, ``/policy/particles``, ``/policy/actions``   the belief tree / policy
- ``/pareto/<i>``             the Pareto-optimal paths of an ``astar-pareto`` sweep

The GUI has a summary, layer switches and a time slider (with play) over the executed trajectory -- or the
planned path when nothing was executed.  :meth:`Viewer.on_step` takes execution steps as they happen (the
execution loop's per-step hook) and moves the robot and the trail live.
"""

from __future__ import annotations

import contextlib
import io
import itertools
import logging
import socket
import threading
import time
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path as FilePath

import numpy as np
from pliant.geometry.voxelgrid import VoxelGrid
from pliant.interfaces import Context

from pliant_viewer import content

log = logging.getLogger(__name__)

DEFAULT_ROBOT = {"rigid": "rigid", "urdf": "pinocchio"}


def free_port(host: str = "127.0.0.1") -> int:
    """A TCP port nothing listens on at ``host`` now."""
    with socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET) as s:
        s.bind((host, 0))
        return s.getsockname()[1]


def _cube(size: float) -> tuple[np.ndarray, np.ndarray]:
    h = size / 2.0
    v = np.array([[x, y, z] for x in (-h, h) for y in (-h, h) for z in (-h, h)], dtype=np.float32)
    f = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                  [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]], dtype=np.uint32)
    return v, f


@dataclass
class Timeline:
    """Configurations over time for the slider: ``times`` ``(k,)`` s and ``configurations`` ``(k, d)``."""

    times: np.ndarray
    configurations: np.ndarray
    label: str = "execution"

    def index(self, t: float) -> int:
        return int(np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, len(self.times) - 1))

    def at(self, t: float) -> np.ndarray:
        return self.configurations[self.index(t)]


@dataclass
class ViewContent:
    """Everything one view draws, built by :func:`build_content` (no viser involved), with every configuration
    already placed in 3-D (``ends``: start and goal, ``path_xyz``, ``timeline_xyz``), so that a view read back from
    a cache (:mod:`pliant_viewer.cache`, ``robot`` and ``tracer`` then ``None``) draws without the robot model."""

    scene: object
    robot: object
    tracer: content.Tracer | None
    objects: list[content.VoxelObject]
    path: np.ndarray | None = None                 # (k, d) planned configurations
    trajectory: Timeline | None = None
    tree: content.Tree | None = None
    pareto: list[dict] = field(default_factory=list)
    title: str = ""
    notes: list[str] = field(default_factory=list)
    ends: np.ndarray | None = None                 # (2, 3)
    path_xyz: np.ndarray | None = None
    timeline_xyz: np.ndarray | None = None
    articulated: bool = False
    urdf: object = None                            # the robot's UrdfDescription, or None


def make_robot(scene, robot_name: str | None = None, robot_options: dict | None = None):
    """The scene's robot model through the registry (the pipeline's robot when named, else the scene's default)."""
    from pliant.registry import create

    name = robot_name or DEFAULT_ROBOT[scene.robot.kind]
    return create("robot", name, Context(scene=scene), **(robot_options or {}))


def make_tracer(scene, robot) -> content.Tracer:
    space = robot.space
    kind = space.kind
    articulated = robot.urdf_description() is not None
    if kind == "rn" and space.dim == 3 and not articulated:
        kind = "r3"
    z = float((scene.lower[2] + scene.upper[2]) / 2.0)
    return content.Tracer(kind, robot, scene.start, scene.goal, z=z)


def build_content(scene, robot=None, *, run: content.RunData | None = None, policy: dict | None = None,
                  grid: VoxelGrid | None = None, max_particles: int = 50_000) -> ViewContent:
    """Translate a scene (and a run's path / policy / execution, or a policy file's JSON) into what is drawn."""
    robot = robot if robot is not None else make_robot(scene, run.robot_name if run else None)
    grid = grid if grid is not None else VoxelGrid.from_scene(scene)
    tracer = make_tracer(scene, robot)
    view = ViewContent(scene, robot, tracer, content.voxel_objects(grid), title=scene.name)
    if run is not None:
        view.path = run.path
        if run.trajectory is not None:
            times, q = run.trajectory
            view.trajectory = Timeline(times, q)
        policy = policy if policy is not None else run.policy
        stats = (run.result or {}).get("statistics") or {}
        if stats.get("pareto"):
            view.pareto = content.pareto_paths(stats, grid.lower, grid.resolution)
        if run.result:
            view.notes.append(f"result: {run.result.get('status')} (planner {run.result.get('planner')})")
        if run.execution:
            view.notes.append(f"execution: {run.execution.get('outcome')} in {run.execution.get('world')}")
    if policy is not None and policy.get("nodes"):
        view.tree = content.policy_tree(policy, tracer, max_particles=max_particles)
    if view.trajectory is None and view.path is not None and len(view.path) > 1:
        # no execution: the slider walks the planned path (one waypoint per second)
        view.trajectory = Timeline(np.arange(len(view.path), dtype=np.float64), view.path, label="planned path")
    view.ends = tracer.points(np.stack([scene.start, scene.goal]))
    view.path_xyz = tracer.points(view.path) if view.path is not None else None
    view.timeline_xyz = tracer.points(view.trajectory.configurations) if view.trajectory is not None else None
    view.urdf = robot.urdf_description()
    view.articulated = tracer.tip is not None
    return view


class RobotDrawing:
    """The robot in the page: a URDF's meshes posed by joint values, or a rigid body's voxels posed as one frame."""

    def __init__(self, server, robot, q0: np.ndarray, resolution: float, meshes: str = "collision",
                 description=None) -> None:
        self.server = server
        self.robot = robot
        self.meshes = meshes
        self.urdf = None
        self.ready = threading.Event()
        self.error: BaseException | None = None
        self._q = np.asarray(q0, dtype=np.float64)
        self._set_lock = threading.Lock()
        description = description if robot is None else robot.urdf_description()
        if description is not None:
            # meshes take seconds to parse (yourdfpy, trimesh): the rest of the scene is drawn meanwhile
            self.thread = threading.Thread(target=self._load_urdf_safely, args=(description,), daemon=True)
            self.thread.start()
            return
        else:
            self.frame = server.scene.add_frame("/robot", show_axes=False)
            placement = robot.rigid_placement(np.asarray(q0)[None])
            if placement is not None:
                local = placement[2]
                self._rigid = True
            else:
                local = robot.body_points(np.asarray(q0)[None])[0]
                self._rigid = False
            v, f = _cube(resolution * 0.9)
            mats = robot.point_materials()
            colours = content.material_colours(mats[:, 0], mats[:, 1]) // 2 + np.array([127, 60, 0], np.uint8)
            self.body = server.scene.add_batched_meshes_simple(
                "/robot/body", v, f, batched_wxyzs=np.tile([1.0, 0, 0, 0], (len(local), 1)),
                batched_positions=local.astype(np.float32), batched_colors=colours, lod="off")
        self.ready.set()
        self.set(q0)

    def _load_urdf_safely(self, description) -> None:
        try:
            self._load_urdf(description)
        except Exception as exc:  # the page keeps everything else; the summary says why the robot is missing
            log.warning("robot meshes not loaded: %s: %s", type(exc).__name__, exc)
            self.error = exc
        finally:
            with self._set_lock:
                if self.urdf is not None:
                    self._apply(self._q)
                self.ready.set()

    def _load_urdf(self, description) -> None:
        import yourdfpy
        from viser.extras import ViserUrdf

        dirs = [FilePath(d) for d in description.package_dirs]

        def handler(fname: str) -> str:
            if fname.startswith("package://"):
                rest = fname[len("package://"):]
                for d in dirs:
                    for candidate in (d / rest, d.parent / rest):
                        if candidate.exists():
                            return str(candidate)
            return yourdfpy.filename_handler_magic(fname, dir=FilePath(description.urdf).parent)

        # collision meshes by default: Baxter's visual meshes are 412,633 triangles in 59 pieces (2.6 s to parse, under
        # 1 frame/s in software WebGL), its collision meshes 18,955 in 37 (0.3 s)
        visual = self.meshes == "visual"
        urdf = yourdfpy.URDF.load(str(description.urdf), build_scene_graph=visual, load_meshes=visual,
                                  build_collision_scene_graph=not visual, load_collision_meshes=not visual,
                                  filename_handler=handler)
        self.urdf = ViserUrdf(self.server, urdf, root_node_name="/robot", load_meshes=visual,
                              load_collision_meshes=not visual, collision_mesh_color_override=(0.75, 0.22, 0.2))
        self.joint_names = list(self.urdf.get_actuated_joint_names())
        base = np.zeros(len(self.joint_names))
        for i, name in enumerate(self.joint_names):
            base[i] = description.posture.get(name, 0.0)
        self.base = base
        self.slots = [self.joint_names.index(n) if n in self.joint_names else -1 for n in description.joint_names]

    def set(self, q: np.ndarray) -> None:
        q = np.asarray(q, dtype=np.float64)
        self._q = q
        if not self.ready.is_set():
            return                          # applied when the meshes are in
        with self._set_lock:
            self._apply(q)

    def _apply(self, q: np.ndarray) -> None:
        if self.urdf is not None:
            cfg = self.base.copy()
            for i, slot in enumerate(self.slots):
                if slot >= 0:
                    cfg[slot] = q[i]
            self.urdf.update_cfg(cfg)
        elif self.error is not None or not hasattr(self, "_rigid"):
            return
        elif self._rigid:
            R, t, _ = self.robot.rigid_placement(q[None])
            self.frame.wxyz = _wxyz(R[0])
            self.frame.position = t[0]
        else:
            self.body.batched_positions = self.robot.body_points(q[None])[0].astype(np.float32)


def _wxyz(R: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(R).as_quat()
    return np.array([w, x, y, z])


class Viewer:
    """A viser server drawing one :class:`ViewContent`; ``host`` is loopback unless asked otherwise."""

    def __init__(self, host: str = "127.0.0.1", port: int | None = None, robot_meshes: str = "collision",
                 tree_limit: int = 2000) -> None:
        import viser

        self.robot_meshes = robot_meshes
        self.tree_limit = tree_limit
        self.tree_drawn = 0
        self.host = host
        self.port = port or free_port(host)
        with contextlib.redirect_stdout(io.StringIO()):      # viser's banner; the commands print the address
            self.server = viser.ViserServer(host=host, port=self.port, verbose=False)
        # no share button: viser's share links tunnel through an outside server; the page stays on this machine
        self.server.gui.configure_theme(control_width="medium", show_share_button=False)
        # No image-based lighting and no shadows: in software WebGL (headless Chromium, SwiftShader) viser's default
        # HDRI environment map held the page at 0.2-2 frames/s for many seconds after loading (baxter-reach with its
        # policy; 46 without it) and delayed every later message; shadows cost 42 -> 30 fps on triple-wall.  A
        # hemisphere and an ambient light keep the faces that look away from the default lights readable.
        self.server.scene.configure_environment_map(hdri=None)
        self.server.scene.configure_default_lights(True, cast_shadow=False)
        self.server.scene.add_light_hemisphere("/lights/sky", sky_color=(255, 255, 255), ground_color=(90, 90, 110),
                                               intensity=1.2)
        self.server.scene.add_light_ambient("/lights/ambient", intensity=0.6)
        self.nodes: dict[str, object] = {}
        self.view: ViewContent | None = None
        self.robot_drawing: RobotDrawing | None = None
        self.slider = None
        self.slider_moves = 0                   # how many times the slider's value arrived from the page
        self._live: list[np.ndarray] = []
        self._live_sent = 0.0
        self._lock = threading.Lock()
        self.created = time.perf_counter()

    @property
    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{host}:{self.port}/"

    def stop(self) -> None:
        with contextlib.redirect_stdout(io.StringIO()):
            self.server.stop()

    # --- drawing ----------------------------------------------------------------------------------------------

    def _add(self, name: str, handle) -> None:
        self.nodes[name] = handle

    def show_objects(self, scene, objects: list[content.VoxelObject]) -> None:
        """Draw the scene's voxel objects and aim the camera (the first thing a page shows; :meth:`show` then adds
        the rest without drawing them again)."""
        with self.server.atomic():
            centre = (scene.lower + scene.upper) / 2.0
            extent = float(np.max(scene.upper - scene.lower))
            self.server.initial_camera.position = tuple(centre + np.array([-0.45, -0.85, 0.6]) * extent)
            self.server.initial_camera.look_at = tuple(centre)
            self.server.initial_camera.up = (0.0, 0.0, 1.0)
            self.server.scene.set_up_direction("+z")
            for obj in objects:
                self._add(f"/scene/objects/{obj.name}", self._voxel_mesh(f"/scene/objects/{obj.name}", obj))

    def show(self, view: ViewContent) -> None:
        """Draw ``view`` (its objects unless :meth:`show_objects` drew them)."""
        s = self.server.scene
        self.view = view
        scene = view.scene
        if not any(n.startswith("/scene/objects/") for n in self.nodes):
            self.show_objects(scene, view.objects)
        extent = float(np.max(scene.upper - scene.lower))
        with self.server.atomic():
            ends = view.ends
            radius = max(scene.resolution, 0.01 * extent)
            if view.articulated:
                # an arm in a large workspace: frame the base and the task rather than the whole grid
                focus = (ends[0] + ends[1]) / 2.0
                reach = max(float(np.max(np.linalg.norm(ends, axis=1))), 0.3)
                direction = np.array([-0.3, -0.9, 0.35]) / np.linalg.norm([-0.3, -0.9, 0.35])
                self.server.initial_camera.position = tuple(focus + direction * 1.9 * reach)
                self.server.initial_camera.look_at = tuple(focus * 0.75)
            self._add("/scene/start", s.add_icosphere("/scene/start", radius=radius, color=(40, 200, 60),
                                                      position=ends[0]))
            self._add("/scene/goal", s.add_icosphere("/scene/goal", radius=radius, color=(220, 40, 200),
                                                     position=ends[1]))
            self.robot_drawing = RobotDrawing(self.server, view.robot, scene.start, scene.resolution,
                                              meshes=self.robot_meshes, description=view.urdf)
            self._add("/robot", self.robot_drawing)
            if view.path is not None and len(view.path) > 1:
                self._polyline("/path/planned", view.path_xyz, content.PATH_COLOUR, 4.0)
            if view.trajectory is not None and view.trajectory.label == "execution":
                self._polyline("/path/executed", view.timeline_xyz,
                               content.TRAJECTORY_COLOUR, 3.0)
            if view.tree is not None:
                self._draw_tree(view.tree, radius)
            colours = content.front_colours(len(view.pareto))
            for i, front in enumerate(view.pareto):
                self._polyline(f"/pareto/{i}", front["points"], tuple(int(c) for c in colours[i]), 3.0)
        self._gui(view)

    def _voxel_mesh(self, name: str, obj: content.VoxelObject):
        """One mesh of the object's exposed voxel faces: one colour (``add_mesh_simple``), or per-voxel materials
        as vertex colours (through trimesh, which viser sends as GLB)."""
        colours = np.unique(obj.vertex_colours, axis=0)
        if len(colours) <= 1:
            colour = tuple(int(c) for c in (colours[0] if len(colours) else obj.colours[0]))
            return self.server.scene.add_mesh_simple(name, obj.vertices.astype(np.float32), obj.faces,
                                                     color=colour, side="double", flat_shading=True,
                                                     cast_shadow=False, receive_shadow=False)
        import trimesh

        mesh = trimesh.Trimesh(obj.vertices, obj.faces, vertex_colors=obj.vertex_colours, process=False)
        return self.server.scene.add_mesh_trimesh(name, mesh, cast_shadow=False, receive_shadow=False)

    def _polyline(self, name: str, points: np.ndarray, colour, width: float) -> None:
        pts = np.asarray(points, dtype=np.float32)
        segments = np.stack([pts[:-1], pts[1:]], axis=1)
        self._add(name, self.server.scene.add_line_segments(name, segments, colors=colour, thickness=width,
                                                                         thickness_units="screen"))

    def _draw_tree(self, tree: content.Tree, radius: float, whole: bool = False) -> None:
        """Draw the tree; beyond ``tree_limit`` nodes only its first ``tree_limit`` nodes (the tree as it was when it
        had that many: a connected subtree from the root) and every solution's nodes, unless ``whole``."""
        s = self.server.scene
        n = len(tree.nodes)
        keep = np.ones(n, dtype=bool)
        if not whole and n > self.tree_limit:
            keep[:] = False
            keep[: self.tree_limit] = True
            keep[tree.solution_nodes[tree.solution_nodes < n]] = True
        self.tree_drawn = int(keep.sum())
        edges = tree.edges[keep[tree.edges[:, 0]] & keep[tree.edges[:, 1]]] if len(tree.edges) else tree.edges
        if len(edges):
            # line segments: in headless Chromium (software WebGL) 10,000 of them drew at 35 frames/s where the same
            # edges as a mesh of crossed ribbons drew at 2
            segments = np.stack([tree.nodes[edges[:, 0]], tree.nodes[edges[:, 1]]], axis=1)
            self._add("/policy/edges", s.add_line_segments("/policy/edges", segments.astype(np.float32),
                                                           colors=content.TREE_COLOUR, thickness=1.0,
                                                           thickness_units="screen"))
        node_colours = content.probability_colours(tree.probability)
        self._add("/policy/nodes", s.add_point_cloud("/policy/nodes", tree.nodes[keep].astype(np.float32),
                                                     colors=node_colours[keep], point_size=radius * 0.8,
                                                     point_shape="circle"))
        parts = keep[tree.particle_node] if len(tree.particles) else np.zeros(0, dtype=bool)
        if parts.any():
            self._add("/policy/particles", s.add_point_cloud(
                "/policy/particles", tree.particles[parts].astype(np.float32),
                colors=node_colours[tree.particle_node[parts]], point_size=radius * 0.35, point_shape="square"))
        if len(tree.action_targets):
            self._add("/policy/actions", s.add_point_cloud("/policy/actions", tree.action_targets.astype(np.float32),
                                                           colors=(30, 30, 30), point_size=radius * 0.5,
                                                           point_shape="diamond"))

    def _whole_tree(self, event) -> None:
        radius = max(self.view.scene.resolution, 0.01 * float(np.max(self.view.scene.upper - self.view.scene.lower)))
        for name in [k for k in self.nodes if k.startswith("/policy/")]:
            self.nodes.pop(name).remove()
        self._draw_tree(self.view.tree, radius, whole=event.target.value)

    def _gui(self, view: ViewContent) -> None:
        g = self.server.gui
        lines = [f"**pliant** -- {view.title}", ""]
        lines += [f"- {o.name}: {o.total} voxels (deformability {o.deformability:.2f})" for o in view.objects]
        if view.path is not None:
            lines.append(f"- planned path: {len(view.path)} waypoints")
        if view.tree is not None:
            lines.append(f"- policy: {len(view.tree.nodes)} nodes, {len(view.tree.particles)} particles"
                         + (f" ({self.tree_drawn} nodes drawn)" if self.tree_drawn < len(view.tree.nodes) else ""))
        if view.pareto:
            lines.append(f"- Pareto front: {len(view.pareto)} paths")
            lines += [f"  - {i}: length {p['length_voxels']:.1f} voxels, deformation {p['deformation']:.4g}"
                      for i, p in enumerate(view.pareto)]
        lines += [f"- {n}" for n in view.notes]
        self.summary = g.add_markdown("\n".join(lines))
        with g.add_folder("layers"):
            for prefix in ("/scene/objects", "/robot", "/path", "/policy", "/pareto"):
                names = [n for n in self.nodes if n == prefix or n.startswith(prefix + "/")]
                if not names:
                    continue
                box = g.add_checkbox(prefix.strip("/").replace("/", " "), initial_value=True)
                box.on_update(partial(self._toggle, names))
        if view.tree is not None and len(view.tree.nodes) > self.tree_limit:
            whole = g.add_checkbox(f"whole tree ({len(view.tree.nodes)} nodes)", initial_value=False)
            whole.on_update(self._whole_tree)
        if view.trajectory is not None and len(view.trajectory.times) > 1:
            tl = view.trajectory
            step = round(float(np.median(np.diff(tl.times))), 3) or 0.01
            self.slider = g.add_slider(f"time (s), {tl.label}", min=round(float(tl.times[0]), 3),
                                       max=round(float(tl.times[-1]), 3), step=step,
                                       initial_value=round(float(tl.times[0]), 3))
            self.play = g.add_checkbox("play", initial_value=False)
            self.slider.on_update(self._on_slider)
            self.play.on_update(self._on_play)
            self._now = self.server.scene.add_icosphere("/path/now", radius=max(view.scene.resolution, 0.008),
                                                        color=(20, 20, 20),
                                                        position=view.timeline_xyz[0])
            self._add("/path/now", self._now)

    def _toggle(self, names, event) -> None:
        for n in names:
            handle = self.nodes[n]
            if isinstance(handle, RobotDrawing):
                if handle.urdf is not None and handle.meshes == "visual":
                    handle.urdf.show_visual = event.target.value
                elif handle.urdf is not None:
                    handle.urdf.show_collision = event.target.value
                elif hasattr(handle, "frame"):
                    handle.frame.visible = event.target.value
            else:
                handle.visible = event.target.value

    def set_time(self, t: float) -> None:
        tl = self.view.trajectory
        i = tl.index(t)
        self.robot_drawing.set(tl.configurations[i])
        self._now.position = self.view.timeline_xyz[i]

    def _on_slider(self, event) -> None:
        if event.client is not None:
            self.slider_moves += 1
        self.set_time(float(event.target.value))

    def _on_play(self, event) -> None:
        if not event.target.value:
            return

        def run() -> None:
            tl = self.view.trajectory
            t0, start = time.perf_counter(), float(self.slider.value)
            while self.play.value:
                t = start + (time.perf_counter() - t0)
                if t > tl.times[-1]:
                    t = tl.times[-1]
                    self.play.value = False
                self.slider.value = float(t)
                time.sleep(1 / 30)

        threading.Thread(target=run, daemon=True).start()

    # --- live ---------------------------------------------------------------------------------------------------

    def on_step(self, step) -> None:
        """The execution loop's per-step hook: move the robot and extend the trail (at most ~30 updates a second)."""
        with self._lock:
            self._live.append(np.asarray(step.configuration, dtype=np.float64))
            now = time.perf_counter()
            if now - self._live_sent < 1 / 30 or self.view is None:
                return
            self._live_sent = now
            q = self._live[-1]
            self.robot_drawing.set(q)
            # only the configurations not yet placed go through the tracer (a robot model's kinematics)
            placed = getattr(self, "_live_xyz", [])
            placed.extend(self.view.tracer.points(np.array(self._live[len(placed):])))
            self._live_xyz = placed
            if len(placed) > 1:
                pts = np.asarray(placed, dtype=np.float32)
                segments = np.stack([pts[:-1], pts[1:]], axis=1)
                handle = self.nodes.get("/path/live")
                if handle is None:
                    self._polyline("/path/live", pts, (0, 170, 255), 3.0)
                else:
                    handle.points = segments
            self.live_steps = len(self._live)

    def show_particles(self, q: np.ndarray, trail: bool = True) -> None:
        """Draw particles ``(n, d)`` (e.g. the belief's particles during an execution) as points at their tips, and
        with ``trail`` extend each particle's trail."""
        xyz = self.view.tracer.points(q).astype(np.float32)
        handle = self.nodes.get("/live/particles")
        if handle is not None and len(handle.points) == len(xyz):
            handle.points = xyz                     # an update of the existing cloud, not a new scene node
        else:
            self.nodes["/live/particles"] = self.server.scene.add_point_cloud(
                "/live/particles", xyz, colors=(230, 80, 30), point_size=max(self.view.scene.resolution, 0.01),
                point_shape="circle")
        if trail:
            # trails as points (a point cloud stays cheap where thousands of line segments do not), re-sent every
            # fifth call
            self._trails = getattr(self, "_trails", [])
            self._trails.append(xyz)
            if len(self._trails) % 5 == 1:
                self.nodes["/live/trails"] = self.server.scene.add_point_cloud(
                    "/live/trails", np.concatenate(self._trails), colors=(240, 160, 110),
                    point_size=max(self.view.scene.resolution, 0.01) * 0.4, point_shape="circle")

    # --- export -------------------------------------------------------------------------------------------------

    def export_html(self, path: FilePath, frames: int = 60) -> FilePath:
        """Write a self-contained HTML page of the view (viser's embedded playback); with a timeline, the page
        plays it back at ``frames`` poses."""
        serializer = self.server.get_scene_serializer()
        tl = self.view.trajectory if self.view else None
        if tl is not None and len(tl.times) > 1:
            ts = np.linspace(tl.times[0], tl.times[-1], frames)
            for a, b in itertools.pairwise(ts):
                self.set_time(float(b))
                serializer.insert_sleep(float(b - a))
        path = FilePath(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(serializer.as_html(), encoding="utf-8")
        return path
