"""An iiwa pipeline on the ROS 2 peer by one setting: ``execution.world = "iiwa-ros2"`` (the lbr_fri_ros2_stack's
/lbr, lbr_A1..lbr_A7, mapped to pliant's lbr_iiwa_joint_1..7)."""

from __future__ import annotations

import time

import numpy as np
import pytest
from pliant import Pipeline
from pliant.hardware.limits import load_limits
from ros2_helpers import assert_within_limits, at_rest

pytestmark = pytest.mark.realtime


def test_a_pipeline_executes_on_the_ros2_peer_by_one_setting(make_peer, tmp_path):
    """The contact controller runs closed-loop on the peer's measured states, as with ``iiwa-ros`` (its gain gentle:
    the iiwa's limits file allows 2 rad/s^2 and 10 rad/s^3)."""
    from pliant_ros2.robots import IIWA_LIMITS

    peer = make_peer(wait=False)
    since = time.monotonic()
    pipeline = Pipeline(scene="iiwa-shelf", name="iiwa-ros2-drive", output=tmp_path / "out",
                        planner={"name": "waypoints", "waypoints": [[0.4, 0.45, 0.0, -1.1, 0.0, 0.75, 0.0]]},
                        simulator={"name": "kinematic", "noise": "none", "joint_velocity_limits": [1.0] * 7},
                        controller={"name": "contact", "gain": 1.5, "tolerance": 0.05},
                        execution={"period": 0.05, "time_limit": 30.0,
                                   "world": {"name": "iiwa-ros2", "domain_id": peer.domain_id,
                                             "localhost_only": True, "state_timeout": 0.5,
                                             "connect_timeout": 20.0}})
    result = pipeline.run(write=False)
    assert result.execution.success and result.execution.world == "iiwa-ros2"
    goal = np.array([0.8, 0.6, 0.0, -1.0, 0.0, 0.9, 0.0])
    np.testing.assert_allclose(result.execution.configurations[-1], goal, atol=0.15)
    rest = at_rest(peer)
    np.testing.assert_allclose(rest, result.execution.configurations[-1], atol=0.005)
    assert_within_limits(peer, load_limits(IIWA_LIMITS), since)
