"""The 3-D viewer: a viser server (a local web page) showing a scene, its robot and what a run produced.

Scene graph (the names the page's scene tree shows and the tests look for):

- ``/scene/objects/<name>``   each voxel object, its surface voxels as instanced cubes coloured by material
- ``/scene/start``, ``/scene/goal``   the task's ends (at the robot's tip for an articulated robot)
- ``/robot``                  the robot: URDF meshes (PR2, Baxter, iiwa; merged per planned joint, see
                              :mod:`pliant_viewer.robot_mesh`) or the rigid body's voxels
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
import dataclasses
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
from pliant.api import Context, VoxelGrid

from pliant_viewer import content, glb

log = logging.getLogger(__name__)

DEFAULT_ROBOT = {"rigid": "rigid", "urdf": "pinocchio"}
LIVE_RATE = 15.0        # live updates a second at most (the page draws continuously while they arrive)
LIVE_CHUNK = 64         # steps per node of a live trail
# voxel faces are wound to face out (content.exposed_faces), so only front faces are drawn: in software WebGL the
# page's time per frame is mostly the fragments of the large objects (baxter-reach's wall), and a double-sided wall
# shades its hidden back faces too
VOXEL_SIDE = "front"
QUAD_OVERLAP = 0.01     # voxel faces grow by this fraction of a voxel in their plane (see _widen_quads)
GLB_EDGES = 256         # a tree of more edges draws them as WebGL lines (a GLB), a smaller one as line segments


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
    from pliant.api import create

    name = robot_name or DEFAULT_ROBOT[scene.robot.kind]
    return create("robot", name, Context(scene=scene), **(robot_options or {}))


def make_tracer(scene, robot) -> content.Tracer:
    """The :class:`~pliant_viewer.content.Tracer` that places ``robot``'s configurations in 3-D: a free-flying body at
    its translation (a 3-D vector space without a URDF counts as R^3; SE(2) at the middle of the scene's height), any
    other robot at its tip."""
    space = robot.space
    kind = space.kind
    articulated = robot.urdf_description() is not None
    if kind == "rn" and space.dim == 3 and not articulated:
        kind = "r3"
    z = float((scene.lower[2] + scene.upper[2]) / 2.0)
    return content.Tracer(kind, robot, scene.start, scene.goal, z=z)


def build_content(scene, robot=None, *, run: content.RunData | None = None, policy: dict | None = None,
                  grid: VoxelGrid | None = None, max_particles: int = 50_000,
                  objects: list[content.VoxelObject] | None = None) -> ViewContent:
    """Translate a scene (and a run's path / policy / execution, or a policy file's JSON) into what is drawn.
    ``objects``: the voxel objects when they are made elsewhere (``[]``: none; the scene is then not voxelised)."""
    if run is not None and run.path is not None and len(run.path) and np.asarray(scene.start).size == 0:
        # a robot-independent task (docs/scenes.md) states no configurations: the run's path has the ones it solved
        scene = dataclasses.replace(scene, start=np.asarray(run.path[0], dtype=np.float64),
                                    goal=np.asarray(run.path[-1], dtype=np.float64))
    if robot is None:
        robot = make_robot(scene, run.robot_name if run else None, run.robot_options if run else None)
    if grid is None and objects is None:
        grid = VoxelGrid.from_scene(scene)
    tracer = make_tracer(scene, robot)
    view = ViewContent(scene, robot, tracer, content.voxel_objects(grid) if objects is None else objects,
                       title=scene.name)
    if run is not None:
        view.path = run.path
        if run.trajectory is not None:
            times, q = run.trajectory
            view.trajectory = Timeline(times, q)
        policy = policy if policy is not None else run.policy
        stats = (run.result or {}).get("statistics") or {}
        if stats.get("pareto"):
            lower, resolution = (grid.lower, grid.resolution) if grid is not None else (
                np.asarray(scene.lower, dtype=np.float64), scene.resolution)       # a grid starts at the scene's lower
            view.pareto = content.pareto_paths(stats, lower, resolution)
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
                 description=None, use_cache: bool = True) -> None:
        self.server = server
        self.robot = robot
        self.meshes = meshes
        self.use_cache = use_cache
        self.urdf = None
        self.ready = threading.Event()
        self.error: BaseException | None = None
        self._q = np.asarray(q0, dtype=np.float64)
        self._set_lock = threading.Lock()
        description = description if robot is None else robot.urdf_description()
        if description is not None:
            # converting the meshes takes seconds the first time (yourdfpy, trimesh): the scene is drawn meanwhile
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
        """The robot's merged meshes (:mod:`pliant_viewer.robot_mesh`: from the disk cache, or converted with yourdfpy
        once), one frame per planned joint's group of links and one mesh per group and colour."""
        from pliant_viewer import robot_mesh

        # collision meshes by default: Baxter's visual meshes are 412,633 triangles in 59 pieces (2.6 s to parse, under
        # 1 frame/s in software WebGL), its collision meshes 18,955 in 37 (0.3 s; 14,155 with lighter spheres)
        meshes = robot_mesh.load_or_convert(description, self.meshes, use_cache=self.use_cache)
        s = self.server.scene
        poses = meshes.poses(self._q)
        with self.server.atomic():
            x, y, z, w = getattr(description, "base_orientation", (0.0, 0.0, 0.0, 1.0))
            self.root = s.add_frame("/robot", show_axes=False, wxyz=(w, x, y, z),
                                    position=tuple(getattr(description, "base_position", (0.0, 0.0, 0.0))))
            self.group_frames = []
            for g, name in enumerate(meshes.names):
                wxyz, position = _pose(poses[g])
                self.group_frames.append(s.add_frame(f"/robot/{name}", show_axes=False, wxyz=wxyz,
                                                     position=position))
            for i, (g, v, f, colour) in enumerate(meshes.meshes):
                s.add_mesh_simple(f"/robot/{meshes.names[g]}/mesh{i}", v, f, color=colour, material="toon3",
                                  cast_shadow=False, receive_shadow=False)
        self._sent = poses
        self.urdf = meshes

    def set(self, q: np.ndarray) -> None:
        q = np.asarray(q, dtype=np.float64)
        self._q = q
        if not self.ready.is_set():
            return                          # applied when the meshes are in
        with self._set_lock:
            self._apply(q)

    def _apply(self, q: np.ndarray) -> None:
        if self.urdf is not None:
            # only the groups that moved: one orientation and one position message each, applied together
            poses = self.urdf.poses(q)
            moved = np.nonzero(np.abs(poses - self._sent).reshape(len(poses), -1).max(axis=1) > 1e-9)[0]
            with self.server.atomic():
                for g in moved:
                    self.group_frames[g].wxyz, self.group_frames[g].position = _pose(poses[g])
            self._sent = poses
        elif self.error is not None or not hasattr(self, "_rigid"):
            return
        elif self._rigid:
            R, t, _ = self.robot.rigid_placement(q[None])
            self.frame.wxyz = _wxyz(R[0])
            self.frame.position = t[0]
        else:
            self.body.batched_positions = self.robot.body_points(q[None])[0].astype(np.float32)


def _widen_quads(vertices: np.ndarray, margin: float) -> np.ndarray:
    """Quads (4 consecutive vertices each) grown by ``margin`` in their plane on every side.  Merged strips meet in
    T-junctions (a strip's corner on the middle of its neighbour's edge), where rasterisation leaves pixel-wide cracks;
    with front faces only, the background shows through them.  Neighbouring strips overlapping by a fraction of a
    voxel close them (same plane, same colour: the overlap is invisible)."""
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 4, 3)
    return (v + margin * np.sign(v - v.mean(axis=1, keepdims=True))).reshape(-1, 3)


def _pose(T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return _wxyz(T[:3, :3]), T[:3, 3].copy()


def _wxyz(R: np.ndarray) -> np.ndarray:
    # the core's rotations (numpy only): scipy's Rotation took 0.66 s to import on this machine under load
    from pliant.api import matrix_to_quat

    x, y, z, w = matrix_to_quat(np.asarray(R, dtype=np.float64))
    return np.array([w, x, y, z])


class Viewer:
    """A viser server drawing one :class:`ViewContent`; ``host`` is loopback unless asked otherwise."""

    def __init__(self, host: str = "127.0.0.1", port: int | None = None, robot_meshes: str = "collision",
                 tree_limit: int = 2000, use_cache: bool = True, live_rate: float = LIVE_RATE) -> None:
        from pliant_viewer import page

        self.robot_meshes = robot_meshes
        self.use_cache = use_cache
        self.tree_limit = tree_limit
        self.tree_drawn = 0
        self.host = host
        self.port = port or free_port(host)
        # viser's page with our script for software WebGL (no multisampling there; pliant_viewer.page)
        self.server, self.page_patched = page.start_server(host, self.port)
        # viser moves on to the next port when one is taken (another server took the free one meanwhile): the port
        # it serves on is the one it reports
        self.port = self.server.get_port()
        # no share button: viser's share links tunnel through an outside server; the page stays on this machine
        self.server.gui.configure_theme(control_width="medium", show_share_button=False)
        # No image-based lighting and no shadows: in software WebGL (headless Chromium, SwiftShader) viser's default
        # HDRI environment map held the page at 0.2-2 frames/s for many seconds after loading (baxter-reach with its
        # policy; 46 without it) and delayed every later message; shadows cost 42 -> 30 fps on triple-wall.  A
        # hemisphere and an ambient light keep the faces that look away from the default lights readable.
        self._lights()
        self.nodes: dict[str, object] = {}
        self.view: ViewContent | None = None
        self.robot_drawing: RobotDrawing | None = None
        self.slider = None
        self.slider_moves = 0                   # slider moves from the page that have been drawn
        self._slider_lock = threading.Lock()
        self._live: list[np.ndarray] = []
        self.live_steps = 0
        self.live_rate = live_rate              # live updates a second at most (:meth:`flush_live`)
        self.live_updates = 0
        self._live_sent = 0.0
        self._live_placed = 0
        self._live_trail: list = []
        self._particles: np.ndarray | None = None
        self._trail_pending: list[np.ndarray] = []
        self._particle_trail: list = []
        self._flush_timer: threading.Timer | None = None
        self._lock = threading.RLock()
        self.created = time.perf_counter()

    @property
    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{host}:{self.port}/"

    def _lights(self) -> None:
        self.server.scene.configure_environment_map(hdri=None)
        self.server.scene.configure_default_lights(True, cast_shadow=False)
        self.server.scene.add_light_hemisphere("/lights/sky", sky_color=(255, 255, 255), ground_color=(90, 90, 110),
                                               intensity=1.2)
        self.server.scene.add_light_ambient("/lights/ambient", intensity=0.6)

    def reset(self) -> None:
        """Remove every node and control (e.g. to show the finished run after a live one)."""
        with self._lock:
            if self._flush_timer is not None:
                self._flush_timer.cancel()
                self._flush_timer = None
            self.view = None
            self.server.scene.reset()
            self.server.gui.reset()
            self.nodes.clear()
            self._lights()
            self._live_trail, self._particle_trail, self._trail_pending, self._particles = [], [], [], None

    def stop(self) -> None:
        if self._flush_timer is not None:
            self._flush_timer.cancel()
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
                self._add(f"/scene/objects/{obj.name}", self._voxel_mesh(f"/scene/objects/{obj.name}", obj,
                                                                        scene.resolution))

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
            # toon shading like every other mesh: one shader program fewer for the page to compile before its first
            # frame (the standard material's)
            self._add("/scene/start", s.add_icosphere("/scene/start", radius=radius, color=(40, 200, 60),
                                                      position=ends[0], material="toon3"))
            self._add("/scene/goal", s.add_icosphere("/scene/goal", radius=radius, color=(220, 40, 200),
                                                     position=ends[1], material="toon3"))
            self.robot_drawing = RobotDrawing(self.server, view.robot, scene.start, scene.resolution,
                                              meshes=self.robot_meshes, description=view.urdf,
                                              use_cache=self.use_cache)
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

    def _voxel_mesh(self, name: str, obj: content.VoxelObject, resolution: float):
        """One mesh of the object's exposed voxel faces in its material's colour; an object of per-voxel materials
        gets one mesh per colour (``name`` is then a frame holding ``name/<k>``)."""
        colours, inverse = np.unique(obj.vertex_colours[::4], axis=0, return_inverse=True)   # one colour a quad
        vertices = _widen_quads(obj.vertices, QUAD_OVERLAP * resolution)
        if len(colours) <= 1:
            colour = tuple(int(c) for c in (colours[0] if len(colours) else obj.colours[0]))
            return self._mesh(name, vertices, obj.faces, colour)
        frame = self.server.scene.add_frame(name, show_axes=False)
        quad = np.asarray(inverse).ravel()
        for k, colour in enumerate(colours):
            quads = np.nonzero(quad == k)[0]
            # exposed_faces lists every quad's first triangle, then every quad's second
            faces = np.concatenate([obj.faces[quads], obj.faces[quads + len(quad)]])
            used, local = np.unique(faces, return_inverse=True)
            self._mesh(f"{name}/{k}", vertices[used], local.reshape(-1, 3).astype(np.uint32),
                       tuple(int(c) for c in colour))
        return frame

    def _mesh(self, name: str, vertices: np.ndarray, faces: np.ndarray, colour, flat: bool = True):
        # toon shading: in software WebGL a frame of baxter-reach drew in about half the time of the standard
        # (physically based) material's, and the faces still read by their light
        return self.server.scene.add_mesh_simple(name, np.asarray(vertices, dtype=np.float32), faces, color=colour,
                                                 material="toon3", side=VOXEL_SIDE, flat_shading=flat,
                                                 cast_shadow=False, receive_shadow=False)

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
        if len(edges) > GLB_EDGES:
            # WebGL lines (a GLB of one LINES primitive, one draw call), not viser's line segments: those are
            # instanced quads, and software WebGL (SwiftShader) pays 20-35 us per instance -- 2,000 edges were half
            # of a drawn frame of baxter-reach's page and 10,000 most of one (pliant_viewer.glb)
            segments = np.stack([tree.nodes[edges[:, 0]], tree.nodes[edges[:, 1]]], axis=1)
            self._add("/policy/edges", s.add_glb("/policy/edges", glb.lines(segments, content.TREE_COLOUR),
                                                 cast_shadow=False, receive_shadow=False))
        elif len(edges):
            # a small tree: line segments, drawn in the same frame as the rest of the view (a GLB is loaded
            # asynchronously and was drawn 0.4-0.5 s after it, which delayed a run's first frame by as much)
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
            # in a fixed shuffled order, so that every prefix is an even sample of them: while the camera moves, a
            # software-WebGL page draws only the first MOTION_POINTS of this cloud, and all of it at rest (page.py)
            order = np.nonzero(parts)[0]
            order = order[np.random.default_rng(0).permutation(len(order))]     # display order only
            self._add("/policy/particles", s.add_point_cloud(
                "/policy/particles", tree.particles[order].astype(np.float32),
                colors=node_colours[tree.particle_node[order]], point_size=radius * 0.35, point_shape="square"))
        if len(tree.action_targets):
            self._add("/policy/actions", s.add_point_cloud("/policy/actions", tree.action_targets.astype(np.float32),
                                                           colors=(30, 30, 30), point_size=radius * 0.5,
                                                           point_shape="diamond"))

    def _whole_tree(self, event) -> None:
        radius = max(self.view.scene.resolution, 0.01 * float(np.max(self.view.scene.upper - self.view.scene.lower)))
        for name in [k for k in self.nodes if k.startswith("/policy/")]:
            self.nodes.pop(name).remove()
        self._draw_tree(self.view.tree, radius, whole=event.target.value)
        if getattr(self, "summary", None) is not None:
            self.summary.content = self._summary(self.view)        # how many nodes are drawn now

    def _summary(self, view: ViewContent) -> str:
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
        return "\n".join(lines)

    def _gui(self, view: ViewContent) -> None:
        g = self.server.gui
        self.summary = g.add_markdown(self._summary(view))
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
                                                        color=(20, 20, 20), material="toon3",
                                                        position=view.timeline_xyz[0])
            self._add("/path/now", self._now)

    def _toggle(self, names, event) -> None:
        for n in names:
            handle = self.nodes[n]
            if isinstance(handle, RobotDrawing):
                if handle.urdf is not None:
                    handle.root.visible = event.target.value
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
        # viser runs update callbacks on a thread pool after it has stored the new value: two quick moves may run
        # at once, so each draws the slider's value as it is when it holds the lock -- the last one drawn is the
        # last value -- and a move counts once it is drawn
        with self._slider_lock:
            self.set_time(float(self.slider.value))
            if event.client is not None:
                self.slider_moves += 1

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
        """The execution loop's per-step hook: record the step; the robot and the trail move in the page at most
        :attr:`live_rate` times a second (:meth:`flush_live`)."""
        with self._lock:
            self._live.append(np.asarray(step.configuration, dtype=np.float64))
            self.live_steps = len(self._live)
        self._maybe_flush()

    def show_particles(self, q: np.ndarray, trail: bool = True) -> None:
        """Draw particles ``(n, d)`` (e.g. the belief's particles during an execution) as points at their tips, and
        with ``trail`` extend each particle's trail; sent with the next live update (:meth:`flush_live`)."""
        xyz = self.view.tracer.points(q).astype(np.float32)
        with self._lock:
            self._particles = xyz
            if trail:
                self._trail_pending.append(xyz)
        self._maybe_flush()

    def _maybe_flush(self) -> None:
        """Send now when the last update is older than ``1 / live_rate`` s, else once that time has passed (so the
        page always ends at the latest step)."""
        with self._lock:
            if self.view is None:
                return
            wait = self._live_sent + 1.0 / self.live_rate - time.perf_counter()
            if wait > 0:
                if self._flush_timer is None:
                    self._flush_timer = threading.Timer(wait, self._timer_flush)
                    self._flush_timer.daemon = True
                    self._flush_timer.start()
                return
        self.flush_live()

    def _timer_flush(self) -> None:
        with self._lock:
            self._flush_timer = None
        self.flush_live()

    def flush_live(self) -> None:
        """One live update, as one batch of messages the page applies together: the robot at the latest step, the
        steps' trail since the last update, the particles and their trails.  Trails are drawn in chunks of
        ``LIVE_CHUNK`` steps, so an update re-sends at most one chunk, however long the execution."""
        with self._lock:
            if self.view is None:
                return
            self._live_sent = time.perf_counter()
            self.live_updates += 1
            new = self._live[self._live_placed:]
            self._live_placed = len(self._live)
            particles, self._particles = self._particles, None
            trail, self._trail_pending = self._trail_pending, []
            s = self.server.scene
            with self.server.atomic():
                if new:
                    self.robot_drawing.set(new[-1])
                    # only the configurations not yet placed go through the tracer (a robot model's kinematics)
                    xyz = self.view.tracer.points(np.array(new)).astype(np.float32)
                    if "/path/live" not in self.nodes:
                        self.nodes["/path/live"] = s.add_frame("/path/live", show_axes=False)
                    self._live_trail = self._extend_chunks(self._live_trail, xyz, LIVE_CHUNK, "/path/live/",
                                                           self._trail_segments, overlap=True)
                if particles is not None:
                    handle = self.nodes.get("/live/particles")
                    if handle is not None and len(handle.points) == len(particles):
                        handle.points = particles       # an update of the existing cloud, not a new scene node
                    else:
                        self.nodes["/live/particles"] = s.add_point_cloud(
                            "/live/particles", particles, colors=(230, 80, 30),
                            point_size=max(self.view.scene.resolution, 0.01), point_shape="circle")
                if trail:
                    # trails as points (a point cloud stays cheap where thousands of line segments do not)
                    steps = np.stack(trail)                                     # (k, n, 3)
                    self._particle_trail = self._extend_chunks(self._particle_trail, steps, LIVE_CHUNK // 2,
                                                               "/live/trails/", self._trail_points, overlap=False)

    def _extend_chunks(self, chunks: list, items: np.ndarray, size: int, prefix: str, draw, overlap: bool) -> list:
        """Append ``items`` to the last chunk (a list of arrays) until it holds ``size``; each chunk changed is
        re-drawn as one node ``prefix<k>``; with ``overlap`` a chunk starts at the last item of the one before (so
        a line stays unbroken)."""
        chunks = chunks or [[]]
        touched = set()
        for item in items:
            if len(chunks[-1]) >= size:
                chunks.append([chunks[-1][-1]] if overlap else [])
            chunks[-1].append(item)
            touched.add(len(chunks) - 1)
        for k in sorted(touched):
            name = f"{prefix}{k}"
            handle = draw(name, np.asarray(chunks[k]), size, self.nodes.get(name))
            if handle is not None:
                self.nodes[name] = handle
        return chunks

    def _trail_segments(self, name: str, pts: np.ndarray, size: int, handle):
        """A chunk of the live trail as ``size`` line segments, the ones not reached yet collapsed onto its last
        point: the node keeps its size, so an update is one message (its points), not a new node."""
        if len(pts) < 2:
            return None
        full = np.concatenate([pts, np.repeat(pts[-1:], size + 1 - len(pts), axis=0)])
        segments = np.stack([full[:-1], full[1:]], axis=1)
        if handle is not None:
            handle.points = segments
            return handle
        return self.server.scene.add_line_segments(name, segments, colors=(0, 170, 255), thickness=3.0,
                                                   thickness_units="screen")

    def _trail_points(self, name: str, steps: np.ndarray, size: int, handle):
        """A chunk of the particles' trails: ``size`` steps of points, those not reached yet at the last step's."""
        full = np.concatenate([steps, np.repeat(steps[-1:], size - len(steps), axis=0)]).reshape(-1, 3)
        if handle is not None:
            handle.points = full
            return handle
        return self.server.scene.add_point_cloud(name, full, colors=(240, 160, 110),
                                                 point_size=max(self.view.scene.resolution, 0.01) * 0.4,
                                                 point_shape="circle")

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
        from pliant.api import write_text

        from pliant_viewer import page

        # atomic: a failure (a full disk, Ctrl-C) leaves the previous file or none, never half a page
        return write_text(FilePath(path), page.patch(serializer.as_html()))
