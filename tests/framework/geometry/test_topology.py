"""Topology of voxel objects and puncture / cut detection (thesis 4.3.4)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import array_shapes, arrays
from pliant.errors import ConfigError, DimensionError, PliantError
from pliant.geometry.topology import PunctureChecker, euler_number, surface_topology, topology
from pliant.geometry.voxelgrid import VoxelGrid
from pliant.interfaces import Context
from pliant.registry import create
from pliant.scene import Scene


def _box(shape=(4, 5, 6)):
    return np.ones(shape, dtype=bool)


def _ring():
    m = np.ones((5, 5, 2), dtype=bool)
    m[2, 2, :] = False
    return m


def _shell(n=5):
    m = np.ones((n, n, n), dtype=bool)
    m[1:-1, 1:-1, 1:-1] = False
    return m


def _plate_two_holes():
    m = np.ones((8, 5, 2), dtype=bool)
    m[1:3, 1:3, :] = False
    m[5, 2:4, :] = False
    return m


def _jack(scale=1):
    """A 3x3x3 cube with three orthogonal tunnels through its centre (Menger sponge, level 1)."""
    m = np.ones((3, 3, 3), dtype=bool)
    for axis in range(3):
        idx = [1, 1, 1]
        idx[axis] = slice(None)
        m[tuple(idx)] = False
    return np.kron(m, np.ones((scale,) * 3, dtype=bool)).astype(bool)


def _torus(r_major=6.0, r_minor=2.5, n=20):
    c = (np.arange(n) - (n - 1) / 2)
    x, y, z = np.meshgrid(c, c, c, indexing="ij")
    return (np.hypot(x, y) - r_major) ** 2 + z ** 2 <= r_minor ** 2


KNOWN = {          # name: (mask, components, cavities, tunnels)
    "solid box": (_box(), 1, 0, 0),
    "ring": (_ring(), 1, 0, 1),
    "torus": (_torus(), 1, 0, 1),
    "hollow shell": (_shell(), 1, 1, 0),
    "plate with two holes": (_plate_two_holes(), 1, 0, 2),
    "3x3x3 jack": (_jack(), 1, 0, 5),
    "jack scaled x3": (_jack(3), 1, 0, 5),
    "two boxes": (np.concatenate([_box((2, 3, 3)), np.zeros((1, 3, 3), bool), _box((2, 3, 3))]), 2, 0, 0),
    "empty": (np.zeros((3, 3, 3), bool), 0, 0, 0),
}


@pytest.mark.parametrize("name", list(KNOWN))
def test_known_shapes_both_methods(name):
    mask, components, cavities, tunnels = KNOWN[name]
    t = topology(mask)
    assert (t.components, t.cavities, t.tunnels) == (components, cavities, tunnels)
    assert t.euler == components + cavities - tunnels == euler_number(mask)
    s = surface_topology(mask)
    assert s.holes == tunnels and s.surfaces == components + cavities


def test_jack_by_hand():
    # 4^3 = 64 lattice vertices (all touched), 144 edges (the removed cross holds no 2x2 square),
    # 108 - 12 faces (6 between the centre and the face centres, 6 from a face centre to outside), 20 cubes.
    assert euler_number(_jack()) == 64 - 144 + 96 - 20 == -4
    s = surface_topology(_jack())
    m = s.degree_counts
    assert 1 + (m[5] + 2 * m[6] - m[3]) / 8 == 5          # the thesis's formula: one closed surface
    assert (m[3], m[5], m[6]) == (8, 24, 8)


def test_thesis_formula_holds_for_one_closed_surface_only():
    # a hollow shell has two closed surfaces of genus 0: the thesis's 1 + (...)/8 gives 0 + 1
    s = surface_topology(_shell())
    m = s.degree_counts
    assert s.surfaces == 2 and 1 + (m[5] + 2 * m[6] - m[3]) / 8 == -1 and s.holes == 0


def test_vertex_and_edge_contacts_are_26_connected():
    pair = np.zeros((2, 2, 2), bool)
    pair[0, 0, 0] = pair[1, 1, 1] = True                     # meet at one vertex only
    assert topology(pair).components == 1 and surface_topology(pair).pinches == 1
    assert surface_topology(pair).holes == 0
    edge = np.zeros((2, 2, 1), bool)
    edge[0, 0, 0] = edge[1, 1, 0] = True                     # meet along an edge only
    assert topology(edge) == topology(np.ones((1, 1, 1), bool))
    # a diagonal ring of voxels touching at edges encloses a tunnel; the background crosses nowhere
    diamond = np.zeros((3, 3, 1), bool)
    diamond[1, 0, 0] = diamond[0, 1, 0] = diamond[2, 1, 0] = diamond[1, 2, 0] = True
    assert topology(diamond).tunnels == 1 == surface_topology(diamond).holes


@settings(max_examples=300)
@given(arrays(bool, array_shapes(min_dims=3, max_dims=3, min_side=1, max_side=6)))
def test_both_methods_agree_on_random_shapes(mask):
    t = topology(mask)
    s = surface_topology(mask)
    assert s.holes == t.tunnels
    assert s.surfaces == t.components + t.cavities


@settings(max_examples=100)
@given(st.integers(0, 2**32 - 1), st.floats(0.2, 0.95), st.tuples(*[st.integers(2, 12)] * 3))
def test_both_methods_agree_on_random_dense_shapes(seed, density, shape):
    mask = np.random.default_rng(seed).random(shape) < density
    t = topology(mask)
    assert surface_topology(mask).holes == t.tunnels
    assert t.euler == euler_number(mask)


def test_bad_masks_name_the_field():
    with pytest.raises(DimensionError, match=r"mask: must be a 3-D array.*\[3, 3\]"):
        topology(np.ones((3, 3), bool))
    with pytest.raises(PliantError, match="mask"):
        surface_topology(np.array([[["a"]]]))


# --- the puncture checker on hand-made grids ----------------------------------------------------------

RES = 0.1


def _grid(objects: dict[str, tuple[np.ndarray, float]], shape=(12, 12, 12)) -> VoxelGrid:
    """A grid at 0.1 m from named masks with their deformability."""
    object_id = np.full(shape, -1, dtype=np.int32)
    defo = np.ones(shape)
    for k, (mask, d) in enumerate(objects.values()):
        object_id[mask] = k
        defo[mask] = d
    return VoxelGrid(np.zeros(3), RES, defo, np.where(object_id >= 0, 1.0, 0.0), object_id, list(objects))


def _probe(half: int = 0):
    """Body points of a cube probe of (2 half + 1)^3 voxels at configuration (x, y, z) in metres."""
    r = np.arange(-half, half + 1) * RES
    offsets = np.stack(np.meshgrid(r, r, r, indexing="ij"), -1).reshape(-1, 3)

    def body_points(q):
        q = np.atleast_2d(q)
        return q[:, None, :] + offsets[None]
    return body_points


def _line(a, b, step=RES / 2):
    a, b = np.asarray(a, float), np.asarray(b, float)
    n = int(np.ceil(np.linalg.norm(b - a) / step)) + 1
    return a + np.linspace(0, 1, n)[:, None] * (b - a)


def _centre(i, j, k):
    return (np.array([i, j, k]) + 0.5) * RES


def _shell_grid():
    m = np.zeros((12, 12, 12), bool)
    m[2:10, 2:10, 2:10] = True
    m[3:9, 3:9, 3:9] = False             # walls one voxel thick at x = 2 and x = 9 ...
    return _grid({"shell": (m, 0.5)})


def test_piercing_one_wall_of_a_shell_opens_the_void():
    checker = PunctureChecker(_shell_grid(), _probe())
    assert checker.initial[0].cavities == 1                  # hollow at the start: legal
    _, ok, reason = checker.extend(checker.initial_state(), _line(_centre(0, 5, 5), _centre(5, 5, 5)))
    assert not ok and "void opened" in reason and "'shell'" in reason and "cavities 1 -> 0" in reason


def test_going_through_both_walls_adds_a_hole():
    checker = PunctureChecker(_shell_grid(), _probe())
    _, ok, reason = checker.extend(checker.initial_state(), _line(_centre(0, 5, 5), _centre(11, 5, 5)))
    assert not ok and "gained a hole" in reason and "tunnels 0 -> 1" in reason


def test_a_dent_that_does_not_pierce_is_valid():
    m = np.zeros((12, 12, 12), bool)
    m[2:10, 4:7, 2:10] = True             # a slab three voxels thick in y
    checker = PunctureChecker(_grid({"slab": (m, 0.5)}), _probe())
    state, ok, reason = checker.extend(checker.initial_state(), _line(_centre(5, 0, 5), _centre(5, 5, 5)))
    assert ok and reason == "" and state.removed_count == 2
    state, ok, reason = checker.extend(state, _line(_centre(5, 5, 5), _centre(5, 11, 5)))
    assert not ok and "gained a hole" in reason
    # the same hole made in two steps from the start, edge by edge: caught when the last wall voxel goes
    s, ok1, _ = checker.extend(checker.initial_state(), _line(_centre(5, 0, 5), _centre(5, 5, 5)))
    _, ok2, _ = checker.extend(s, _line(_centre(5, 5, 5), _centre(5, 6, 5)))
    assert ok1 and not ok2


def test_the_state_covers_the_whole_path_and_rewiring_starts_from_the_new_parent():
    m = np.zeros((12, 12, 12), bool)
    m[2:10, 4:6, 2:10] = True             # two voxels thick
    checker = PunctureChecker(_grid({"slab": (m, 0.5)}), _probe())
    root = checker.initial_state()
    a, ok_a, _ = checker.extend(root, [_centre(5, 4, 5)])          # dents the front layer
    b, ok_b, _ = checker.extend(root, [_centre(5, 5, 5)])          # dents the back layer (from behind)
    assert ok_a and ok_b
    _, ok, _ = checker.extend(a, [_centre(5, 5, 5)])               # the path via a has removed both layers
    assert not ok
    assert [len(r) for r in b.removed] == [1] and b.removed[0].dtype == np.int64


def test_a_cut_splits_a_bar():
    m = np.zeros((12, 12, 12), bool)
    m[1:11, 5:7, 5:7] = True              # a bar along x, 2 x 2 voxels in section
    checker = PunctureChecker(_grid({"bar": (m, 0.3)}), _probe(half=1))
    _, ok, reason = checker.extend(checker.initial_state(), _line([0.55, 0.2, 0.6], [0.55, 1.0, 0.6]))
    assert not ok and reason.startswith("cut: object 'bar' split into 2 pieces (was 1)")


@pytest.mark.parametrize(("kept", "kept_bytes"), [(5, 2**20), (1000, 8 * 30)], ids=["by count", "by bytes"])
def test_remembered_verdicts_equal_fresh_ones_and_survive_a_full_memory(monkeypatch, kept, kept_bytes):
    """The checker remembers the verdicts of removed sets (a tree meets the same sets again); what it returns from
    memory equals a fresh judgement, for sets it has seen, new ones, and after its memory filled (by count or by
    bytes) and was cleared."""
    from pliant.geometry import topology as module

    monkeypatch.setattr(module, "VERDICTS_KEPT", kept)
    monkeypatch.setattr(module, "VERDICT_BYTES", kept_bytes)
    m = np.zeros((12, 12, 12), bool)
    m[2:10, 4:7, 2:10] = True                                     # a slab three voxels thick in y
    checker = PunctureChecker(_grid({"slab": (m, 0.5)}), _probe())
    rng = np.random.default_rng(3)
    crop = checker._masks[0]
    front = np.flatnonzero((crop & (np.arange(crop.shape[1]) == 1)[None, :, None]).ravel())   # the first layer
    column = np.ravel_multi_index((np.full(3, 4), np.arange(1, 4), np.full(3, 4)), crop.shape)  # through it
    sets = [np.unique(np.concatenate([rng.choice(front, size=int(rng.integers(1, 20))),
                                      column if k % 3 == 0 else []]).astype(np.int64)) for k in range(12)]
    verdicts, cleared = set(), 0
    for removed in sets + sets[::-1] + sets:                       # seen, seen again, after clearing
        before = len(checker._verdicts)
        remembered, fresh = checker._judge(0, removed), checker._judge_anew(0, removed)
        assert remembered == fresh and len(checker._verdicts) <= kept and checker._verdict_bytes <= kept_bytes
        cleared += len(checker._verdicts) < before
        verdicts.add(bool(fresh))
    assert cleared >= 2                                            # the memory filled and was emptied
    assert verdicts == {True, False}                               # the columns puncture the slab, dents do not


def test_a_legal_hollow_object_and_untouched_objects_pass():
    checker = PunctureChecker(_shell_grid(), _probe())
    state, ok, reason = checker.extend(checker.initial_state(), _line(_centre(0, 0, 0), _centre(11, 0, 0)))
    assert ok and reason == "" and state.removed_count == 0
    assert checker.topologies(state) == checker.initial


def test_which_objects_are_watched():
    soft = np.zeros((12, 12, 12), bool)
    soft[1:3] = True
    rigid = np.zeros((12, 12, 12), bool)
    rigid[5:7] = True
    forbidden = np.zeros((12, 12, 12), bool)
    forbidden[9:11] = True
    grid = _grid({"soft": (soft, 0.5), "rigid": (rigid, 0.0), "forbidden": (forbidden, np.nan)})
    assert PunctureChecker(grid, _probe()).names == ["soft"]
    assert PunctureChecker(grid, _probe(), watch="all").names == ["soft", "rigid", "forbidden"]
    assert PunctureChecker(grid, _probe(), watch=["rigid"]).names == ["rigid"]
    with pytest.raises(ConfigError, match=r"watch: unknown object.*'nope'"):
        PunctureChecker(grid, _probe(), watch=["nope"])
    with pytest.raises(ConfigError, match=r"watch: must be"):
        PunctureChecker(grid, _probe(), watch="some")
    # the slab touches the grid's border at x = 0 .. 1 and spans y, z fully: the crop margin lies outside
    checker = PunctureChecker(grid, _probe())
    _, ok, reason = checker.extend(checker.initial_state(), _line(_centre(0, 5, 5), _centre(4, 5, 5)))
    assert not ok and "gained a hole" in reason


def test_bad_configurations_name_the_field():
    checker = PunctureChecker(_shell_grid(), _probe())
    with pytest.raises(DimensionError, match="configurations"):
        checker.extend(checker.initial_state(), np.full((2, 3), np.nan))
    with pytest.raises(DimensionError, match="state"):
        checker.extend(type(checker.initial_state())(()), [_centre(0, 0, 0)])


# --- a real scene: a rigid-body robot through a deformable slab ---------------------------------------

def _scene() -> Scene:
    return Scene.from_dict({
        "name": "slab", "start": [0.51, 0.15, 0.51], "goal": [0.51, 0.85, 0.51],
        "bounds": {"lower": [0, 0, 0], "upper": [1, 1, 1], "resolution": 0.05},
        "objects": [
            {"name": "slab", "shape": "box", "size": [0.8, 0.1, 0.8], "position": [0.5, 0.5, 0.5],
             "deformability": 0.5, "sensitivity": 1.0},
            {"name": "post", "shape": "box", "size": [0.1, 0.1, 1.0], "position": [0.1, 0.1, 0.5],
             "deformability": 0.0, "sensitivity": 1.0},
        ],
        "robot": {"kind": "rigid", "space": "r3", "parts": [{"shape": "box", "size": [0.1, 0.1, 0.1]}]},
    })


def test_moving_a_rigid_body_through_a_slab_is_a_puncture():
    scene = _scene()
    ctx = Context(scene=scene)
    ctx.robot = create("robot", "rigid", ctx)
    checker = PunctureChecker(VoxelGrid.from_scene(scene), ctx.robot.body_points)
    assert checker.names == ["slab"] and checker.initial[0].tunnels == 0
    start, goal = scene.start, scene.goal
    dent = start + np.array([0.0, 0.27, 0.0])                 # the probe's front enters the slab's first layer
    state, ok, reason = checker.extend(checker.initial_state(), _line(start, dent, 0.02))
    assert ok and state.removed_count > 0, reason
    _, ok, reason = checker.extend(state, _line(dent, goal, 0.02))
    assert not ok and "puncture: object 'slab' gained a hole" in reason
    # around the slab (over its top edge): valid
    over = [start, start + [0, 0, 0.44], goal + [0, 0, 0.44], goal]
    path = np.concatenate([_line(a, b, 0.02) for a, b in itertools.pairwise(over)])
    ok, reason = checker.check(path)
    assert ok, reason


# --- the swept volume is conservative: no finer sampling finds a voxel the check left out -----------------------


def test_a_diagonal_move_through_a_voxel_corner_takes_the_voxels_beside_the_corner():
    m = np.zeros((12, 12, 12), bool)
    m[3, 2, 2] = True                              # the one voxel beside the corner the probe passes through
    checker = PunctureChecker(_grid({"dot": (m, 0.5)}), _probe())
    # from the centre of (2, 2, 2) to the centre of (3, 3, 2): exactly through the edge x = 3, y = 3 of the grid
    move = np.array([_centre(2, 2, 2), _centre(3, 3, 2)])
    end_points, _, _ = checker.extend(checker.initial_state(), move[1:])
    assert end_points.removed_count == 0          # the end configurations alone never touch it (the old check)
    state, _, _ = checker.extend(checker.initial_state(), move)
    assert state.removed_count == 1


def _fine(configurations, per_edge: int) -> np.ndarray:
    q = np.asarray(configurations, dtype=float)
    t = np.linspace(0.0, 1.0, per_edge + 1)[:, None]
    return np.concatenate([a + t * (b - a) for a, b in itertools.pairwise(q)])


@settings(max_examples=150, deadline=None)
@given(st.tuples(st.integers(1, 4), st.integers(1, 4), st.integers(1, 4)),
       st.tuples(st.integers(3, 6), st.integers(3, 6), st.integers(3, 6)),
       st.lists(st.tuples(*[st.floats(0.0, 1.2, allow_nan=False)] * 3), min_size=2, max_size=4))
def test_no_finer_sampling_of_a_path_finds_a_puncture_the_edge_check_missed(corner, size, waypoints):
    """Random hollow boxes (a one-voxel shell around a void) and random diagonal paths: whenever 1/16-voxel
    sampling of the path opens the void or adds a hole, the check of the path sampled a voxel apart does too."""
    m = np.zeros((12, 12, 12), bool)
    lo = np.array(corner)
    hi = np.minimum(lo + np.array(size), 11)
    m[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]] = True
    m[lo[0] + 1:hi[0] - 1, lo[1] + 1:hi[1] - 1, lo[2] + 1:hi[2] - 1] = False
    checker = PunctureChecker(_grid({"shell": (m, 0.5)}), _probe())
    path = np.array(waypoints)
    coarse = []
    for a, b in itertools.pairwise(path):          # a voxel (0.1 m) apart at most, as the planners interpolate
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / 0.1)))
        coarse.extend(a + (b - a) * k / n for k in range(n))
    coarse = np.array([*coarse, path[-1]])
    fine_state = checker.initial_state()
    for q in _fine(coarse, 16):                    # point samples, no sweep: what a finer checker would see
        fine_state, _, _ = checker.extend(fine_state, q[None])
    fine_bad = any(t.tunnels > i.tunnels or t.cavities < i.cavities
                   for t, i in zip(checker.topologies(fine_state), checker.initial))
    edge_ok, _ = checker.check(coarse)
    if fine_bad:
        assert not edge_ok
    if checker.ids:                                 # the sweep contains every voxel a finer sampling reaches
        assert set(fine_state.removed[0].tolist()) <= set(checker.occupied(coarse)[0].tolist())


# --- edge by edge equals the whole path; voids and pieces followed one by one (issue 31) ------------------------


def _wall_shell(thickness: int, lo: int = 2, hi: int = 10) -> np.ndarray:
    m = np.zeros((12, 12, 12), bool)
    m[lo:hi, lo:hi, lo:hi] = True
    m[lo + thickness:hi - thickness, lo + thickness:hi - thickness, lo + thickness:hi - thickness] = False
    return m


def test_an_edge_is_swept_from_its_parent_when_given_its_start():
    """A shell two voxels thick, entered diagonally: the step from the parent (in the first wall layer) to the
    edge's first state (in the second layer, one voxel over in y) crosses the edge between the two layers' voxels.
    Given only the states after the parent, the two removed voxels meet at an edge and the void stays closed to
    the 6-connected outside; swept from the parent, a voxel beside the edge goes too and the void opens."""
    checker = PunctureChecker(_grid({"shell": (_wall_shell(2), 0.5)}), _probe())
    outside, first_layer = _centre(1, 5, 5), np.array([0.29, 0.59, 0.55])   # voxel (2, 5, 5)
    root, ok, _ = checker.extend(checker.initial_state(), [first_layer], start=outside)
    assert ok and root.removed_count == 1
    edge = np.array([[0.31, 0.61, 0.55], _centre(4, 6, 5)])    # (3, 6, 5) -- second layer -- then the void
    _, ok_states_only, _ = checker.extend(root, edge)
    _, ok_swept, reason = checker.extend(root, edge, start=first_layer)
    assert ok_states_only                          # the old per-edge call: the corner step is never swept
    assert not ok_swept and "void opened" in reason
    assert not checker.check(np.vstack([outside, first_layer, edge]))[0]      # the whole path agrees
    with pytest.raises(DimensionError, match="start"):
        checker.extend(root, edge, start=np.zeros(2))


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 3), st.lists(st.tuples(*[st.floats(0.0, 1.19, allow_nan=False)] * 3), min_size=2,
                                   max_size=6), st.integers(1, 4))
def test_edge_by_edge_from_each_parent_sweeps_exactly_the_whole_path(thickness, waypoints, per_edge):
    """Any path cut into edges: extending edge by edge, each from its parent, gives the same removed voxels as
    checking the whole path at once, and a path whose edges all pass passes the whole check (the planners' per-edge
    check and their final check).  The converse does not hold: see the next test."""
    checker = PunctureChecker(_grid({"shell": (_wall_shell(thickness), 0.5)}), _probe())
    q = np.array(waypoints)
    t = np.linspace(0.0, 1.0, per_edge + 1)[1:, None]
    path = np.vstack([q[:1]] + [a + t * (b - a) for a, b in itertools.pairwise(q)])   # per_edge states an edge
    state, ok_edges = checker.initial_state(), True
    for parent, child in itertools.pairwise(range(0, len(path), per_edge)):
        state, ok, _ = checker.extend(state, path[parent + 1:child + 1], start=path[parent])
        ok_edges &= ok
    whole, ok_whole, _ = checker.extend(checker.initial_state(), path)
    assert [r.tolist() for r in state.removed] == [r.tolist() for r in whole.removed]
    assert ok_whole == checker.check(path)[0]
    assert ok_whole or not ok_edges                 # every edge passed -> the whole path passes


def test_a_hole_cut_open_into_a_notch_later_in_the_path_is_judged_where_the_path_is_judged():
    """Found by the property above: out through a wall's corner and back along the same line.  The way out leaves
    a hole (tunnels 0 -> 1); the way back sweeps a few voxels more and cuts the hole's rim, leaving a notch with no
    hole.  The check judges the removal where it is asked to, as the thesis judges it at every tree node: the edge
    out fails, and a planner never extends from its node; the whole path judged at its end only passes.

    Judging every interpolated state instead (tried) is stricter than the robot's body allows: its body points are
    up to a voxel apart, so a state inside an object leaves bridges between them that later states sweep away, and
    Table 4.2's recovered plan (seed 0, 12,000 iterations) then avoided the demonstrated object O2 (true cost 1021
    against 435; 1.009 x the uniform plan's, against 0.335)."""
    checker = PunctureChecker(_grid({"shell": (_wall_shell(3), 0.5)}), _probe())
    out, back = np.zeros(3), np.array([0.5, 0.9375, 1 / 3])
    first, ok_first, reason = checker.extend(checker.initial_state(), [back], start=out)
    assert not ok_first and "gained a hole" in reason
    assert checker.topologies(first)[0].tunnels == 1
    whole, ok_whole, _ = checker.extend(checker.initial_state(), np.array([out, back, out]))
    assert checker.topologies(whole)[0].tunnels == 0            # at the end: a notch, not a hole
    assert ok_whole and checker.check(np.array([out, back, out]))[0]


def test_a_void_opened_is_caught_even_when_the_sweep_carves_a_new_cavity():
    """A probe of two points: one pierces a wall three voxels thick into the void, the other, inside the top wall
    from the start, carves a closed groove out of that wall's middle layer.  The cavity count stays 1 (one void
    opened, one made), which the counts alone passed; the void itself is followed and found open."""
    m = _wall_shell(3, 1, 11)                      # solid 1 .. 10, void 4 .. 7 on every axis
    offsets = np.array([[0.0, 0.0, 0.0], [0.2, 0.0, 0.4]])

    def body_points(q):
        return np.atleast_2d(q)[:, None, :] + offsets[None]
    checker = PunctureChecker(_grid({"shell": (m, 0.5)}), body_points)
    path = _line([0.05, 0.55, 0.55], [0.55, 0.55, 0.55])  # point 1: x 0 .. 5 (into the void); 2: x 2 .. 7 at z = 9
    topo = checker.topologies(checker.extend(checker.initial_state(), path)[0])[0]
    ok, reason = checker.check(path)
    assert topo.cavities == checker.initial[0].cavities == 1 and topo.tunnels == 0    # counts unchanged ...
    assert not ok and "void opened" in reason                                          # ... but the void is open


def test_a_piece_split_is_a_cut_even_when_another_piece_is_swept_away():
    m = np.zeros((12, 12, 12), bool)
    m[1:11, 5:7, 5:7] = True                       # a bar along x, 2 x 2 in section
    m[5, 2, 5] = True                              # and a one-voxel crumb in front of it
    checker = PunctureChecker(_grid({"bar": (m, 0.3)}), _probe(half=1))
    assert checker.initial[0].components == 2
    _, ok, reason = checker.extend(checker.initial_state(), _line([0.55, 0.15, 0.6], [0.55, 1.0, 0.6]))
    assert checker.topologies(checker.extend(checker.initial_state(),
                                             _line([0.55, 0.15, 0.6], [0.55, 1.0, 0.6]))[0])[0].components == 2
    assert not ok and "cut: object 'bar' had a piece split" in reason
