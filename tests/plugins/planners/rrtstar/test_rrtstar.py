"""RRT*: monotone best cost, exact cost bookkeeping after rewiring, puncture-free paths, the near radius,
task-space goals, determinism and option errors."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from pliant import Pipeline
from pliant.errors import PliantError
from pliant.geometry.topology import PunctureChecker
from pliant.geometry.voxelgrid import VoxelGrid
from pliant.interfaces import Context, PlanningProblem
from pliant.registry import create
from pliant.results import Status
from pliant.scene import Scene
from pliant.spaces import RealVectorSpace, SE3Space
from pliant.termination import Termination
from pliant.testing import check_planner
from pliant_rrtstar.radius import near_radius, rrt_star_gamma, space_measure, unit_ball_volume


def _problem(scene: Scene, cost: bool = True) -> PlanningProblem:
    ctx = Context(scene=scene)
    ctx.robot = create("robot", "rigid", ctx)
    if cost:
        ctx.cost = create("cost", "voxel", ctx)
    return PlanningProblem.from_context(ctx)


def _slab_scene() -> Scene:
    """A thin, soft, barely sensitive slab between start and goal: with a length weight, straight through it
    is far cheaper than around it, but it punctures the slab (thesis 4.3.4)."""
    return Scene.from_dict({
        "name": "slab", "start": [0.5, 0.1, 0.5], "goal": [0.5, 0.9, 0.5], "goal_tolerance": 0.05,
        "bounds": {"lower": [0, 0, 0], "upper": [1, 1, 1], "resolution": 0.05},
        "objects": [{"name": "slab", "shape": "box", "size": [0.7, 0.1, 0.7], "position": [0.5, 0.5, 0.5],
                     "deformability": 0.5, "sensitivity": 0.001}],
        "robot": {"kind": "rigid", "space": "r3", "parts": [{"shape": "box", "size": [0.1, 0.1, 0.1]}]},
    })


def _triple_wall(**options):
    ctx = Pipeline("triple-wall", cost="voxel", planner={"name": "rrtstar", **options}).build()
    return PlanningProblem.from_context(ctx), ctx.extras["planner"]


def test_the_best_cost_never_rises_and_the_callback_sees_it_fall():
    problem, planner = _triple_wall(max_step=0.03, puncture_check=False)
    seen = []
    result = planner.plan(problem, np.random.default_rng(3),
                          Termination(max_iterations=1500, callback=lambda i, best: seen.append(best) and False))
    assert result.status is Status.SOLVED
    history = np.array(result.statistics["cost_history"])
    assert len(history) >= 2 and np.all(np.diff(history[:, 1]) < 0) and np.all(np.diff(history[:, 0]) >= 0)
    assert result.cost == history[-1, 1]
    finite = [b for b in seen if np.isfinite(b)]
    assert finite and all(b1 >= b2 for b1, b2 in itertools.pairwise(finite))
    assert result.statistics["rewires"] > 0


@pytest.mark.parametrize("variant", [{}, {"path_bias": 0.5}, {"k_nearest": True}])
def test_the_variants_keep_the_best_cost_monotone_and_improve_it(variant):
    problem, planner = _triple_wall(max_step=0.03, puncture_check=False, **variant)
    result = planner.plan(problem, np.random.default_rng(3), Termination(max_iterations=1500))
    assert result.status is Status.SOLVED
    history = np.array(result.statistics["cost_history"])
    assert len(history) >= 2 and np.all(np.diff(history[:, 1]) < 0)
    path = result.path.configurations
    assert result.cost == pytest.approx(problem.path_cost(path, planner.check_step), abs=1e-12)


def test_path_bias_samples_lie_near_the_best_path():
    problem, planner = _triple_wall(max_step=0.03, puncture_check=False, path_bias=1.0, path_bias_sigma=0.01)
    planner.plan(problem, np.random.default_rng(3), Termination(max_iterations=800))
    best = planner.tree.path_to(planner.best_node)
    dense = np.vstack([problem.space.discretize(a, b, 0.005) for a, b in itertools.pairwise(best)])
    samples = np.array([planner._sample_near_best(np.random.default_rng(k)) for k in range(200)])
    gaps = np.array([np.min(problem.space.distance(dense, q)) for q in samples])
    # a Gaussian of sigma 0.01 per coordinate (3-D): 99.9% within 0.01 * sqrt(16.27) = 0.04 of the path
    assert np.all(gaps < 0.045) and np.median(gaps) > 0.005


@pytest.mark.parametrize("length_weight", [0.0, 0.7])
def test_every_node_cost_equals_the_cost_recomputed_along_its_branch(length_weight):
    problem, planner = _triple_wall(max_step=0.03, length_weight=length_weight)
    result = planner.plan(problem, np.random.default_rng(1), Termination(max_iterations=600))
    assert result.statistics["rewires"] > 0
    tree, step = planner.tree, planner.check_step
    for node in range(len(tree)):
        path = tree.path_to(node)
        expected = problem.path_cost(path, step) + length_weight * problem.space.path_length(path)
        assert tree.path_costs[node] == pytest.approx(expected, rel=1e-9, abs=1e-12), node
    if result.path is not None:
        path = result.path.configurations
        assert result.cost == pytest.approx(problem.path_cost(path, step)
                                            + length_weight * problem.space.path_length(path), abs=1e-12)


@pytest.mark.parametrize("scene, options, samples", [("cube-wall", {"k_nearest": True, "length_weight": 1.0}, 250),
                                                     ("triple-wall", {}, 400)])
def test_lazy_motion_checks_give_the_tree_of_checking_every_motion_first(scene, options, samples, monkeypatch):
    """The parent choice checks a candidate's motion only when it comes up, and rewiring only the motions of the
    near nodes the new node would make cheaper: the same tree, node for node, as checking every near node's motion
    before choosing, with far fewer motions checked, and every edge of the tree valid (a third of the motions are
    also refused by their midpoint alone, so that only the motion check refuses them, in both directions)."""
    import pliant_rrtstar.planner as module

    def run(eager: bool):
        ctx = Pipeline(scene, robot={"name": "rigid", "rotation_weight": 0.2}, cost="voxel",
                       planner={"name": "rrtstar", "max_step": 0.1, **options}).build()
        problem, planner = PlanningProblem.from_context(ctx), ctx.extras["planner"]
        checked, motions_valid = [], problem.checker.motions_valid

        def barred(a, b):   # and bars only motions meet: a third of all motions are refused, whatever their states
            checked.append(len(a))
            return motions_valid(a, b) & (np.floor((a[:, 0] + b[:, 0]) / 0.026) % 3 != 0)

        monkeypatch.setattr(problem.checker, "motions_valid", barred)
        if eager:       # every near node's motion checked with its states, before the parent is chosen
            monkeypatch.setattr(module, "evaluate_edges",
                                lambda *args, **kwargs: evaluate(*args, **{**kwargs, "check_motions": True}))
        result = planner.plan(problem, np.random.default_rng(5), Termination(max_iterations=samples))
        monkeypatch.setattr(module, "evaluate_edges", evaluate)
        return result, planner.tree, problem, sum(checked)

    evaluate = module.evaluate_edges
    lazy, tree, problem, lazy_checked = run(False)
    eager, eager_tree, _, eager_checked = run(True)
    assert np.array_equal(tree.configurations, eager_tree.configurations)
    assert np.array_equal(tree.parents, eager_tree.parents)
    assert np.array_equal(tree.path_costs, eager_tree.path_costs)
    assert lazy.status == eager.status and np.array_equal([lazy.cost], [eager.cost], equal_nan=True)
    assert lazy.statistics["rewires"] == eager.statistics["rewires"] > 0
    assert lazy_checked < 0.5 * eager_checked
    assert 0 < lazy.statistics["invalid_edges"] <= eager.statistics["invalid_edges"]     # those found: fewer looked at
    child = np.nonzero(tree.parents >= 0)[0]
    assert problem.motions_valid(tree.configurations[tree.parents[child]], tree.configurations[child]).all()


def _punctures(problem: PlanningProblem, path: np.ndarray, step: float) -> bool:
    checker = PunctureChecker(VoxelGrid.from_scene(problem.scene), problem.robot.body_points)
    dense = np.vstack([problem.space.discretize(a, b, step) for a, b in itertools.pairwise(path)])
    return not checker.check(dense)[0]


def test_a_puncturing_path_is_never_returned_and_every_node_is_puncture_free():
    problem = _problem(_slab_scene())
    options = {"max_step": 0.15, "length_weight": 1.0, "goal_bias": 0.1}
    free = create("planner", "rrtstar", puncture_check=False, **options)
    result = free.plan(problem, np.random.default_rng(0), Termination(max_iterations=1500))
    assert result.status is Status.SOLVED
    assert _punctures(problem, result.path.configurations, free.check_step)      # the cheap way is through
    checked = create("planner", "rrtstar", **options)                              # default: on with a scene
    result = checked.plan(problem, np.random.default_rng(0), Termination(max_iterations=1500))
    assert result.statistics["puncture_check"] and result.statistics["punctures_refused"] > 0
    assert result.statistics["rewires_refused"] > 0 and result.statistics["rewires"] > 0
    assert result.status is Status.SOLVED
    assert not _punctures(problem, result.path.configurations, checked.check_step)
    tree = checked.tree                                # rewiring kept every stored path puncture-free
    for node in np.random.default_rng(0).choice(len(tree), 40, replace=False):
        path = tree.path_to(int(node))
        if len(path) > 1:
            assert not _punctures(problem, path, checked.check_step), node
    # every node's stored state is its branch's, swept from the root edge by edge: rewiring re-derives the states
    # below a re-parented node from the kept sweeps and stops where they come out unchanged
    punctures, q = checked.punctures, tree.configurations
    for node in range(1, len(tree)):
        state = punctures.initial_state()
        branch = tree.branch(node)
        for parent, child in itertools.pairwise(branch):
            edge = problem.space.discretize(q[parent], q[child], checked.check_step)[1:]
            state, ok, _ = punctures.extend(state, edge, start=q[parent])
            assert ok, node
        assert all(np.array_equal(a, b) for a, b in zip(state.removed, checked.topology[node].removed)), node


def test_the_near_radius_follows_karaman_and_frazzoli():
    assert unit_ball_volume(2) == pytest.approx(math.pi) and unit_ball_volume(3) == pytest.approx(4 / 3 * math.pi)
    plane = RealVectorSpace([0, 0], [2, 1], weights=[1.0, 3.0])
    assert space_measure(plane) == pytest.approx(6.0)
    assert rrt_star_gamma(plane, 1.0) == pytest.approx((2 * 1.5) ** 0.5 * (6.0 / math.pi) ** 0.5)
    se3 = SE3Space([0, 0, 0], [1, 2, 1], translation_weight=1.0, rotation_weight=0.5)
    assert space_measure(se3) == pytest.approx(2.0 * 0.5 ** 3 * 8 * math.pi ** 2)
    gamma = rrt_star_gamma(se3, 1.1)
    assert gamma == pytest.approx(1.1 * (2 * 7 / 6) ** (1 / 6) * (space_measure(se3) / unit_ball_volume(6)) ** (1 / 6))
    radii = [near_radius(n, 6, gamma, 10.0) for n in (10, 100, 1000, 10_000)]
    assert radii[0] == pytest.approx(gamma * (math.log(10) / 10) ** (1 / 6))
    assert all(a > b for a, b in itertools.pairwise(radii))
    assert near_radius(10_000, 6, gamma, 0.05) == 0.05 and near_radius(1, 6, gamma, 0.05) == 0.05


def _free_scene(space: str) -> Scene:
    return Scene.from_dict({
        "name": "free", "start": [0.2, 0.2, 0.2] + ([0, 0, 0, 1] if space == "se3" else []),
        "goal": [0.8, 0.8, 0.8] + ([0, 0, 0, 1] if space == "se3" else []),
        "bounds": {"lower": [0, 0, 0], "upper": [1, 1, 1], "resolution": 0.05},
        "objects": [{"name": "block", "shape": "box", "size": [0.2, 0.2, 0.2], "position": [0.5, 0.5, 0.5],
                     "deformability": 0.5, "sensitivity": 1.0}],
        "robot": {"kind": "rigid", "space": space, "parts": [{"shape": "box", "size": [0.1, 0.1, 0.1]},
                                                            {"shape": "box", "size": [0.2, 0.04, 0.04],
                                                             "position": [0.1, 0.0, 0.0]}]},
    })


@pytest.mark.parametrize("space, goal", [("se3", {"tip": [0.2, 0.0, 0.0]}), ("r3", {"tip_index": 0})])
def test_a_task_space_target_is_reached_by_the_tip(space, goal):
    problem = _problem(_free_scene(space))
    target = [0.3, 0.75, 0.6]
    planner = create("planner", "rrtstar", target=target, target_tolerance=0.02, max_step=0.2, goal_bias=0.2, **goal)
    result = planner.plan(problem, np.random.default_rng(0), Termination(max_iterations=400))
    assert result.status is Status.SOLVED
    last = result.path.configurations[-1]
    assert np.linalg.norm(planner.goal.tip(last[None])[0] - target) <= 0.02 + 1e-9
    if "tip" in goal:                                         # the body-frame point, placed by hand
        rot, pos, _ = problem.robot.rigid_placement(last[None])
        assert np.linalg.norm(rot[0] @ [0.2, 0, 0] + pos[0] - target) <= 0.02 + 1e-9
        assert result.statistics["goal_states"] >= 1
    assert np.allclose(result.path.configurations[0], problem.start)


def test_the_same_seed_gives_the_same_run_and_conformance():
    problem, planner = _triple_wall(max_step=0.03)
    runs = [planner.plan(problem, np.random.default_rng(7), Termination(max_iterations=300)) for _ in range(2)]
    assert runs[0].statistics["nodes"] == runs[1].statistics["nodes"]
    assert runs[0].statistics["rewires"] == runs[1].statistics["rewires"]
    assert (runs[0].path is None) == (runs[1].path is None)
    if runs[0].path is not None:
        assert np.array_equal(runs[0].path.configurations, runs[1].path.configurations)
    quick = create("planner", "rrtstar", max_step=0.03, max_iterations=300)
    assert check_planner(quick, problem, seed=7)


@pytest.mark.parametrize("options, field", [
    ({"max_step": -1.0}, "max_step"),
    ({"rewire_factor": 0.5}, "rewire_factor"),
    ({"goal_bias": 1.5}, "goal_bias"),
    ({"length_weight": "heavy"}, "length_weight"),
    ({"target": [0.1, 0.2]}, "target"),
    ({"target": [0.1, 0.2, 0.3]}, "tip"),
    ({"tip": [0.1, 0.0, 0.0]}, "target"),
    ({"nonsense": 1}, "nonsense"),
])
def test_bad_options_raise_naming_the_field(options, field):
    with pytest.raises(PliantError, match=field):
        create("planner", "rrtstar", **options)


def test_puncture_check_without_a_scene_is_refused():
    space = RealVectorSpace([0, 0], [1, 1])
    problem = PlanningProblem(space=space, start=np.array([0.1, 0.1]), goal=np.array([0.9, 0.9]),
                              goal_tolerance=0.05)
    planner = create("planner", "rrtstar", puncture_check=True)
    with pytest.raises(PliantError, match="puncture_check"):
        planner.plan(problem, np.random.default_rng(0), Termination(max_iterations=10))
    plain = create("planner", "rrtstar", max_step=0.2, length_weight=1.0)
    result = plain.plan(problem, np.random.default_rng(0), Termination(max_iterations=2000))
    assert result.status is Status.SOLVED                     # no cost model: path length only
    assert result.cost == pytest.approx(space.path_length(result.path.configurations))
    assert result.cost < 1.05 * math.dist([0.1, 0.1], [0.9, 0.9])


def _hollow_box_scene() -> Scene:
    """A soft, barely sensitive hollow box (a shell one voxel thick) between start and goal, the goal diagonally
    past it: cheapest straight through, which opens its void (thesis 4.3.4)."""
    return Scene.from_dict({
        "name": "hollow-box", "start": [0.15, 0.15, 0.5], "goal": [0.85, 0.85, 0.5], "goal_tolerance": 0.05,
        "bounds": {"lower": [0, 0, 0], "upper": [1, 1, 1], "resolution": 0.05},
        "objects": [{"name": "box", "shape": "box", "size": [0.4, 0.4, 0.4], "position": [0.5, 0.5, 0.5],
                     "deformability": 0.5, "sensitivity": 0.001,
                     "cutouts": [{"shape": "box", "size": [0.3, 0.3, 0.3], "position": [0.5, 0.5, 0.5]}]}],
        "robot": {"kind": "rigid", "space": "r3", "parts": [{"shape": "box", "size": [0.04, 0.04, 0.04]}]},
    })


@pytest.mark.slow
def test_with_the_puncture_check_no_quarter_voxel_sampling_of_the_path_opens_the_hollow_box():
    problem = _problem(_hollow_box_scene())
    checked = create("planner", "rrtstar", max_step=0.15, length_weight=1.0, goal_bias=0.1)
    result = checked.plan(problem, np.random.default_rng(2), Termination(max_iterations=1500))
    assert result.status is Status.SOLVED and result.statistics["punctures_refused"] > 0
    assert not _punctures(problem, result.path.configurations, 0.05 / 4)     # a quarter voxel
