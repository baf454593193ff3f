"""The one execution loop keeps what an execution did when the world raises mid-way (pliant.execution.loop.capture)."""

from __future__ import annotations

import numpy as np
import pytest
from pliant.errors import DriveFault
from pliant.execution.loop import capture, execute
from pliant.results import Path


class Line:
    """A 1-D world: the robot moves by velocity * dt; step number ``fail_at`` raises ``error``."""

    def __init__(self, fail_at=None, error=None):
        self.q = np.zeros(1)
        self.steps = 0
        self.fail_at, self.error = fail_at, error

    def reset(self, q):
        self.q = np.array(q, dtype=np.float64)

    def step(self, velocity, dt, rng):
        self.steps += 1
        if self.steps == self.fail_at:
            raise self.error
        self.q = self.q + np.asarray(velocity) * dt
        return self.q.copy()

    def configuration(self):
        return self.q.copy()

    def in_contact(self):
        return False

    def object_poses(self):
        return {}

    def settle(self):
        return self.q.copy()


class Proportional:
    """Velocity = 1 toward the target (units / s) until within 0.05."""

    gave_up = False

    def reset(self):
        pass

    def reached(self, q, target):
        return abs(float(q[0] - target[0])) <= 0.05

    def command(self, q, target, period):
        return np.sign(target - q)


def test_an_execution_that_raises_leaves_a_partial_record_of_its_steps():
    path = Path(np.array([[0.0], [0.5], [1.0]]))
    # the fault comes at step 8: 7 steps were taken (0.7 units at 1 unit/s, 0.1 s periods), waypoint 1 was reached
    world = Line(fail_at=8, error=DriveFault("joint 1 reports fault 0x2310"))
    with capture() as run, pytest.raises(DriveFault):
        execute(world, Proportional(), path, np.random.default_rng(0), period=0.1, time_limit=10.0)
    partial = run.partial("failed", "DriveFault: joint 1 reports fault 0x2310", "line", dim=1)
    assert partial.outcome == "failed" and partial.world == "line" and "0x2310" in partial.error
    assert partial.configurations.shape == (8, 1) and partial.times == pytest.approx(np.arange(8) * 0.1)
    np.testing.assert_allclose(partial.configurations[:, 0], np.arange(8) * 0.1, atol=1e-12)
    assert partial.details.waypoints_reached == 1 and not partial.success
    assert partial.events[-1] == "t=0.70s: DriveFault: joint 1 reports fault 0x2310"
    assert partial.to_dict()["error"] == partial.error


def test_the_same_execution_without_a_fault_is_unchanged_by_capture():
    path = Path(np.array([[0.0], [0.5], [1.0]]))
    with capture() as run:
        record = execute(Line(), Proportional(), path, np.random.default_rng(0), period=0.1, time_limit=10.0)
    assert record.outcome == "reached" and record.details.waypoints_reached == 2 and record.error == ""
    assert len(run.recorders) == 1 and record.events == []


def test_a_world_that_fails_before_its_first_state_gives_an_empty_record():
    with capture() as run:
        pass
    partial = run.partial("interrupted", "Ctrl-C", "line", dim=3)
    assert partial.configurations.shape == (0, 3) and len(partial.times) == 0 and partial.outcome == "interrupted"


def test_recorders_are_captured_only_inside_the_block():
    with capture() as run:
        execute(Line(), Proportional(), Path(np.array([[0.0], [0.2]])), np.random.default_rng(0))
    execute(Line(), Proportional(), Path(np.array([[0.0], [0.2]])), np.random.default_rng(0))
    assert len(run.recorders) == 1
