"""Contact characterisation (thesis 6.4.3): projection to contact, sliding vs stuck, and the downstream check."""

import numpy as np
import pytest
from pliant.geometry.voxelgrid import VoxelGrid
from pliant_reachability.clearance import Clearance
from pliant_reachability.contact import BECOMES_STUCK, SLIDING, STUCK, classify, downstream, project_to_contact
from reachability_helpers import GOAL, START, metric, passage

RES = 0.0025


def test_near_configurations_are_projected_into_touching_contact():
    context = passage()
    clearance = Clearance(context.robot, VoxelGrid.from_scene(context.scene))
    # the L below the wall with its top 4-8 mm from the wall's lower face (y = 0.275), beside the passage
    q = np.array([[0.15, 0.125 - gap, 0.0] for gap in (0.004, 0.006, 0.008)])
    before, _, _ = clearance.query(q)
    projected, ok = project_to_contact(q, context.robot, clearance, iterations=6)
    after, _, colliding = clearance.query(projected)
    assert ok.all() and not colliding.any()
    assert np.all(after <= 0.6 * RES) and np.all(before > after)
    # a flat face onto a flat wall moves along the wall's normal (within 1/25 voxel sideways, 1 mrad)
    assert np.allclose(projected[:, 0], 0.15, atol=1e-4) and np.allclose(projected[:, 2], 0.0, atol=1e-3)


def test_pressing_into_the_wall_is_stuck_and_sliding_through_the_passage_is_not():
    context = passage()
    m = metric(context, epsilon_reached=0.125)
    rng = np.random.default_rng(0)
    # straight up into the wall 11 cm left of the passage, touching it: nothing moves, stuck after the window
    below = np.array([0.1, 0.08, 0.0])
    volumes = m.volumes(below, np.array([0.1, 0.2, 0.0]))
    x = volumes.coordinates(np.array([[0.1, 0.1245, 0.0]]))
    contacts = classify(volumes, x, np.array([0]), context.simulator, rng, stuck_distance=0.01, stuck_steps=5,
                        horizon=12, theta=0.26, axis=0.0)
    assert list(contacts.label) == [STUCK] and contacts.simulated == 5
    assert contacts.stuck_at[0] == pytest.approx(x[0], abs=1e-3)
    # in line with the passage, the L's top in it: it slides through to the goal
    volumes = m.volumes(START, GOAL)
    x = volumes.coordinates(np.array([[0.2375, 0.2, 0.0]]))
    contacts = classify(volumes, x, np.array([0]), context.simulator, rng, stuck_distance=0.01, stuck_steps=5,
                        horizon=40, theta=0.26, axis=0.0, unresolved_stuck=True)
    assert list(contacts.label) == [SLIDING] and np.isnan(contacts.stuck_at).all()
    # with too short a horizon to arrive, an unresolved contact counts as stuck when asked to
    contacts = classify(volumes, x, np.array([0]), context.simulator, rng, stuck_distance=0.01, stuck_steps=5,
                        horizon=6, theta=0.26, axis=0.0, unresolved_stuck=True)
    assert list(contacts.label) == [BECOMES_STUCK]


def test_downstream_marks_sliding_configurations_beyond_a_stuck_one():
    m = metric(passage(), epsilon_reached=0.125)
    volumes = m.volumes(START, GOAL)
    w = volumes.weights
    axis = volumes.coordinates(START[None])[0]            # the path runs along -axis to the target
    lateral = np.array([1.0, 0.0, 0.0]) / w[0]             # 1 weighted unit sideways (x)
    x = np.array([axis * 0.5 + 0.01 * lateral,              # stuck, 0.01 to the side
                  axis * 0.5 + 0.02 * lateral,              # sliding, farther on the same side: becomes stuck
                  axis * 0.5 - 0.02 * lateral,              # sliding, the other side: stays
                  axis * 0.5 + 0.005 * lateral])            # sliding, nearer the axis: stays
    label = np.array([STUCK, SLIDING, SLIDING, SLIDING])
    out = downstream(volumes, x, np.zeros(4, dtype=int), label, theta=0.26, axis=0.0)
    assert list(out) == [STUCK, BECOMES_STUCK, SLIDING, SLIDING]
    # a stuck contact of an earlier volume is upstream: it marks nothing; of a later volume it does
    out = downstream(volumes, x, np.array([0, 1, 1, 1]), label, theta=0.26, axis=0.0)
    assert list(out) == [STUCK, SLIDING, SLIDING, SLIDING]
    out = downstream(volumes, x, np.array([1, 0, 0, 0]), label, theta=0.26, axis=0.0)
    assert list(out) == [STUCK, BECOMES_STUCK, SLIDING, SLIDING]


def test_reachability_sets_aside_samples_behind_a_wall():
    """Thesis 6.6.2: a sample whose nearest previous sample lies across the wall is not reachable from it."""
    from pliant.planning.clustering import ClusteringContext
    from pliant_reachability.assess import reachable_from

    context = passage()
    m = metric(context)
    volumes = m.volumes(START, GOAL)
    clustering = ClusteringContext.from_context(context)
    previous = volumes.coordinates(np.array([[0.1, 0.2, 0.0]]))                 # below the wall, left of the gap
    x = volumes.coordinates(np.array([[0.1, 0.4, 0.0],                          # straight above, across the wall
                                      [0.2375, 0.2, 0.0]]))                     # beside it, in free space
    assert list(reachable_from(x, previous, volumes, clustering)) == [False, True]
    assert list(reachable_from(x, previous[:0], volumes, clustering)) == [False, False]
