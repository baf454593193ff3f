"""The one execution loop (pliant.execution.loop.follow) with each kind of strategy: a path, a toy policy (closed-loop
drives chosen from what was observed), a toy action plan (placements and open-loop moves, one refused and survived);
Ctrl-C mid-run keeps the record and the strategy's details; the outcome enum; a policy kind names its strategy."""

from __future__ import annotations

import json
import sys
import textwrap

import numpy as np
import pytest
from pliant.errors import ConfigError, SimulationError
from pliant.execution.loop import capture, execute, follow
from pliant.execution.record import ExecutionDetails, ExecutionOutcome, ExecutionRecord, PathDetails
from pliant.execution.strategy import (
    Done,
    Drive,
    ExecutionStrategy,
    Move,
    PathStrategy,
    Place,
    ScriptedStrategy,
    strategy_for,
)
from pliant.results import Path, PlanResult, Policy, Status


class Line:
    """A 1-D world with one movable object ``box``: the robot moves by velocity * dt (steps counted); a step at or
    beyond ``wall`` is refused with a SimulationError; step number ``interrupt_at`` raises KeyboardInterrupt."""

    can_place_objects = True

    def __init__(self, wall: float = np.inf, interrupt_at: int | None = None):
        self.q = np.zeros(1)
        self.box = np.zeros(1)
        self.steps = 0
        self.wall, self.interrupt_at = wall, interrupt_at
        self.placed: list[float] = []

    def reset(self, q):
        self.q = np.array(q, dtype=np.float64)
        self.placed.append(float(self.q[0]))

    def set_object_poses(self, poses):
        self.box = np.array(poses["box"], dtype=np.float64)

    def step(self, velocity, dt, rng):
        self.steps += 1
        if self.steps == self.interrupt_at:
            raise KeyboardInterrupt
        q = self.q + np.asarray(velocity) * dt
        if q[0] >= self.wall:
            raise SimulationError("the robot would enter the wall", field="q", value=float(q[0]))
        self.q = q
        return self.q.copy()

    def configuration(self):
        return self.q.copy()

    def in_contact(self):
        return False

    def object_poses(self):
        return {"box": self.box.copy()}

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


RNG = np.random.default_rng


def test_a_path_is_a_strategy_and_execute_is_the_loop_with_it():
    path = Path(np.array([[0.0], [0.5], [1.0]]))
    assert isinstance(PathStrategy(path), ExecutionStrategy)
    followed = follow(Line(), Proportional(), PathStrategy(path), RNG(0), period=0.1, time_limit=10.0, world_name="l")
    executed = execute(Line(), Proportional(), path, RNG(0), period=0.1, time_limit=10.0, world_name="l")
    assert followed.outcome is ExecutionOutcome.REACHED and followed.success
    assert isinstance(followed.details, PathDetails) and followed.details.waypoints_reached == 2
    np.testing.assert_array_equal(followed.configurations, executed.configurations)
    assert followed.to_dict() == executed.to_dict()
    assert followed.to_dict()["details"] == {"kind": "path", "waypoints_reached": 2}


def test_a_path_that_runs_out_of_time_says_before_which_waypoint():
    record = execute(Line(), Proportional(), Path(np.array([[0.0], [0.5], [1.0]])), RNG(0), period=0.1,
                     time_limit=0.7)
    assert record.outcome == "timeout" and record.details.waypoints_reached == 1
    assert record.events == ["t=0.70s: time limit before waypoint 2"]
    assert record.times[-1] == pytest.approx(0.7)


@pytest.mark.parametrize("outcome", list(ExecutionOutcome))
def test_the_outcome_enum_is_a_string_and_round_trips_through_the_record(outcome):
    record = ExecutionRecord(np.zeros((1, 1)), np.zeros(1), np.zeros(1, dtype=bool), outcome.value)
    assert record.outcome is outcome and record.outcome == outcome.value
    assert json.loads(json.dumps(record.to_dict()))["outcome"] == outcome.value
    assert record.success == (outcome in (ExecutionOutcome.REACHED, ExecutionOutcome.SUCCESS))
    with pytest.raises(ValueError):
        ExecutionRecord(np.zeros((1, 1)), np.zeros(1), np.zeros(1, dtype=bool), "no such outcome")


class ToyPolicyDetails(ExecutionDetails):
    kind = "toy-policy"

    def __init__(self):
        self.visits: list[tuple[float, str]] = []

    def to_dict(self):
        return {"kind": self.kind, "visits": self.visits}


class ToyPolicy:
    """A policy from the observed state: from anywhere below 1, drive to 1; then back to 0.5; succeed near 0.5.  It is
    written as a plain strategy (begin / next), not a script."""

    def __init__(self):
        self.events: list[str] = []
        self.record = ToyPolicyDetails()

    def begin(self, rng):
        return Place(np.array([0.2]))

    def next(self, seen):
        q = float(seen.configuration[0])
        self.record.visits.append((round(q, 6), seen.result))
        if len(self.record.visits) > 10:
            return Done("action limit")
        if abs(q - 0.5) <= 0.05 and any(v[0] >= 0.95 for v in self.record.visits):
            self.events.append(f"t={seen.time:.2f}s: at 0.5 after 1")
            return Done(ExecutionOutcome.SUCCESS)
        return Drive(np.array([1.0]) if q < 0.95 else np.array([0.5]), time_limit=5.0)

    def details(self):
        return self.record


def test_a_toy_policy_chooses_each_target_from_what_was_observed():
    record = follow(Line(), Proportional(), ToyPolicy(), RNG(0), period=0.1, time_limit=10.0)
    assert record.outcome == "success" and record.events == [f"t={record.times[-1]:.2f}s: at 0.5 after 1"]
    assert [r for _, r in record.details.visits] == ["placed", "reached", "reached"]
    assert record.configurations[0, 0] == pytest.approx(0.2) and record.configurations[-1, 0] == pytest.approx(0.5)
    assert record.to_dict()["details"]["kind"] == "toy-policy"


def test_a_drive_is_capped_by_what_is_left_of_the_time_limit():
    record = follow(Line(), Proportional(), ToyPolicy(), RNG(0), period=0.1, time_limit=0.5)
    # 0.2 -> 1 needs 0.8 s; the drive stops at 0.5 s, and the policy then asks again until its action limit
    assert record.times[-1] == pytest.approx(0.5) and record.outcome == "action limit"
    assert {r for _, r in record.details.visits[1:]} == {"timeout"}


class PushDetails(ExecutionDetails):
    kind = "toy-pushes"

    def __init__(self):
        self.pushes: list[dict] = []

    def to_dict(self):
        return {"kind": self.kind, "pushes": self.pushes}


class ToyPushes(ScriptedStrategy):
    """An action plan as a script: place the robot and the box, then open-loop moves; a move into the wall (at 1.0)
    is refused by the world and the plan skips it."""

    def __init__(self):
        super().__init__()
        self.record = PushDetails()

    def script(self, rng):
        yield Place(np.array([0.0]), {"box": np.array([0.3])})
        for velocity, duration in [(1.0, 0.45), (2.0, 1.0), (-1.0, 0.2)]:
            try:
                seen = yield Move(np.array([velocity]), duration, period=0.1, recover=True)
            except SimulationError as exc:
                self.events.append(f"t={self.last.time:.2f}s: skipped ({exc.message})")
                self.record.pushes.append({"velocity": velocity, "skipped": True})
                continue
            self.record.pushes.append({"velocity": velocity, "reached": float(seen.configuration[0]),
                                       "box": seen.objects["box"]})
        return "success"

    def details(self):
        return self.record


def test_a_toy_action_plan_moves_open_loop_in_equal_steps_and_survives_a_refused_move():
    world = Line(wall=1.0)
    record = follow(world, None, ToyPushes(), RNG(0), period=0.5, time_limit=0.1)    # moves ignore the limit
    pushes = record.details.pushes
    # 0.45 s at 1 in 5 steps of 0.09 s (at most the move's 0.1 s period, not the loop's 0.5 s)
    assert pushes[0]["reached"] == pytest.approx(0.45) and np.allclose(np.diff(record.times[:6]), 0.09)
    assert pushes[1] == {"velocity": 2.0, "skipped": True} and "skipped" in record.events[0]
    # the refused step was not recorded: the 2 steps before it were (0.65, 0.85), then 0.2 s back
    assert pushes[2]["reached"] == pytest.approx(0.65) and record.outcome == "success"
    assert len(record.times) == 1 + 5 + 2 + 2 and pushes[0]["box"] == pytest.approx([0.3])
    assert world.placed == [0.0]


def test_a_move_not_marked_recover_ends_the_execution_with_its_error():
    class Blind(ToyPushes):
        def script(self, rng):
            yield Place(np.array([0.0]))
            yield Move(np.array([2.0]), 1.0)
            return "success"

    with capture() as run, pytest.raises(SimulationError):
        follow(Line(wall=1.0), None, Blind(), RNG(0))
    partial = run.partial("failed", "SimulationError: the robot would enter the wall")
    assert partial.outcome is ExecutionOutcome.FAILED and len(partial.times) == 5
    assert partial.details.kind == "toy-pushes"


def test_ctrl_c_mid_run_keeps_the_steps_and_the_strategys_details():
    world = Line(interrupt_at=4)
    with capture() as run, pytest.raises(KeyboardInterrupt):
        follow(world, None, ToyPushes(), RNG(0), period=0.1)
    partial = run.partial("interrupted", "Ctrl-C", "line", dim=1)
    assert partial.outcome is ExecutionOutcome.INTERRUPTED and not partial.success
    assert len(partial.times) == 4 and partial.times[-1] == pytest.approx(0.27)     # 3 steps of 0.09 s
    assert partial.details.kind == "toy-pushes" and partial.details.pushes == []
    assert partial.events == ["t=0.27s: Ctrl-C"] and partial.to_dict()["details"]["kind"] == "toy-pushes"


def test_a_strategy_that_drives_needs_a_controller_and_one_that_places_objects_a_world_that_can():
    with pytest.raises(ConfigError, match="controller"):
        follow(Line(), None, ToyPolicy(), RNG(0))

    class Fixed(Line):
        can_place_objects = False

    with pytest.raises(ConfigError, match="place objects"):
        follow(Fixed(), None, ToyPushes(), RNG(0))

    class Hasty(ToyPolicy):
        def begin(self, rng):
            return Drive(np.array([1.0]))

    with pytest.raises(ConfigError, match="begins by placing"):
        follow(Line(), Proportional(), Hasty(), RNG(0))


MODULE = textwrap.dedent('''
    import numpy as np
    from pliant.api import Done, Place, ScriptedStrategy


    class Stay(ScriptedStrategy):
        def __init__(self, policy, context, settings):
            super().__init__()
            self.where, self.settings = policy.where, settings

        def script(self, rng):
            yield Place(np.array([self.where]))
            return "success"


    def follow_stay(policy, context, settings):
        return Stay(policy, context, settings)
''')


def test_a_policy_kind_names_its_strategy_and_the_core_finds_it(tmp_path, monkeypatch):
    (tmp_path / "stay_strategy.py").write_text(MODULE)
    monkeypatch.syspath_prepend(str(tmp_path))

    class StayPolicy(Policy):
        kind = "test-stay"
        follower = "stay_strategy:follow_stay"

        def __init__(self, where):
            self.where = where

    class Opaque(Policy):
        kind = "test-opaque"

    try:
        strategy = strategy_for(PlanResult(Status.SOLVED, policy=StayPolicy(0.7)), None, {"action_limit": 3})
        assert strategy.settings == {"action_limit": 3}
        record = follow(Line(), None, strategy, RNG(0))
        assert record.outcome == "success" and record.configurations[-1, 0] == pytest.approx(0.7)
        assert isinstance(strategy_for(PlanResult(Status.SOLVED, path=Path(np.zeros((2, 1))))), PathStrategy)
        with pytest.raises(ConfigError, match="cannot be executed"):
            strategy_for(PlanResult(Status.SOLVED, policy=Opaque()))
        StayPolicy.follower = "stay_strategy:nothing_here"
        with pytest.raises(ConfigError, match="cannot be loaded"):
            strategy_for(PlanResult(Status.SOLVED, policy=StayPolicy(0.7)))
    finally:
        for kind in ("test-stay", "test-opaque"):
            Policy._kinds.pop(kind, None)
        sys.modules.pop("stay_strategy", None)


def test_results_are_data_no_policy_has_an_execute_method():
    assert not hasattr(Policy, "execute")
