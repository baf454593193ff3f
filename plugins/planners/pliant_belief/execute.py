"""Executing a partial policy in any execution world with a controller, adapting it online (thesis 5.3.5).

:func:`execute_policy` resets the world at the policy's start, then repeats: take the policy's action
(a target configuration), drive toward it with the controller (:func:`pliant.execution.loop.drive`: until the
controller reports it reached, gives up because the robot is stuck, or the action's time runs out), and
query the policy (thesis Algorithm 4) with the configuration reached and the action performed.  The query
matches the observation to the action's outcomes, adapts the probabilities (eq. 5.2-5.3) or inserts an
unforeseen outcome, and returns the next action.  Execution stops on

- ``success``: the configuration reached is within the goal tolerance of the policy's goal (without a goal
  in the policy: the query reports a goal vertex);
- ``failure``: the policy reports ``P(node -> goal) < P_goal`` (or no route to the goal), or it stops at a
  goal vertex outside the goal tolerance and the final approach (one drive to the goal configuration,
  ``final_approach``; not in the thesis) does not bring it within;
- ``timeout``: the total time limit; ``action limit``: the number of actions.

Everything is recorded in the core's :class:`~pliant.execution.loop.ExecutionRecord`: the trajectory with contacts and
the movable objects' poses, and, in its ``actions``, one entry per action performed: ``index``, ``from_node``,
``action_id``, ``kind`` (forward / reverse / goal), ``target`` ``(d,)``, ``start_time`` / ``end_time`` (s), ``drive``
(reached / stuck / timeout), ``reached`` (the configuration reached), ``node`` (matched or inserted),
``inserted``, ``relocalized``, ``matching``, ``status`` (continue / goal / failure) and ``probability``
(``P(node -> goal)`` after the update); in ``adaptations`` the probability changes of every query
``{"action_index", "action", "outcome", "before", "after"}`` (eq. 5.2-5.3); ``final_node`` the last vertex reached.
The world is any :class:`~pliant.execution.loop.ExecutionWorld`: a simulator, or a robot driver.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from pliant.api import ConfigError, Controller, DimensionError, ExecutionRecord, ExecutionWorld, Recorder, StepListener
from pliant.api import drive_to as drive

if TYPE_CHECKING:
    from pliant_belief.policy import Matcher, PartialPolicy


def execute_policy(policy: PartialPolicy, world: ExecutionWorld, controller: Controller, rng: np.random.Generator,
                   *, matcher: Matcher | None = None, period: float = 0.1, time_limit: float = 300.0,
                   action_limit: int = 100, action_time_limit: float = 30.0, start: np.ndarray | None = None,
                   final_approach: bool = True, on_step: StepListener | None = None,
                   world_name: str = "") -> ExecutionRecord:
    """Execute ``policy`` in ``world`` with ``controller``, querying and adapting it after every action.

    ``matcher(particles, q) -> bool`` (else ``policy.matcher``) matches observations to nodes (thesis
    Algorithm 4).  ``period``: control period (s); ``time_limit``: total budget (s); ``action_limit``: most
    actions; ``action_time_limit``: most seconds one action may drive.  ``start`` ``(d,)`` (default: the start
    node's expected configuration) is where the world is reset.  ``on_step`` receives every control step.
    The policy itself is adapted in place.
    ``final_approach``: when the policy stops at a goal vertex but the robot is outside the goal tolerance
    (a goal vertex needs only ``P_goal`` of its particles in the goal), drive to the goal configuration
    once (an action of kind ``goal``) and judge success there; ``False`` ends such an execution as failed.
    """
    if not (period > 0 and time_limit > 0 and action_time_limit > 0):
        raise DimensionError("period, time_limit and action_time_limit must be positive seconds",
                             field="period/time_limit/action_time_limit", value=(period, time_limit, action_time_limit))
    if isinstance(action_limit, bool) or not isinstance(action_limit, (int, np.integer)) or action_limit < 1:
        raise ConfigError("action_limit must be a positive integer", field="action_limit", value=action_limit)
    matcher = matcher if matcher is not None else policy.matcher
    if matcher is None:
        raise ConfigError("execution needs a matcher(particles, q) -> bool", field="matcher", value=None)
    space = policy.space
    q0 = policy.nodes[policy.start_node].expected if start is None else np.asarray(start, dtype=np.float64)
    if q0.shape != (space.dim,) or not np.all(np.isfinite(q0)):
        raise DimensionError(f"start must be a finite configuration of shape ({space.dim},)", field="start",
                             value=np.asarray(q0).tolist())
    world.reset(q0)
    q = world.configuration()
    recorder = Recorder(world, on_step)
    events: list[str] = []
    actions: list[dict] = []
    adaptations: list[dict] = []
    t = 0.0
    node = policy.start_node

    def perform(target: np.ndarray, t: float) -> tuple[np.ndarray, float, str]:
        """Drive toward ``target`` from time ``t``, recording the steps; (configuration reached, time, outcome)."""
        driven = drive(world, controller, target, rng, recorder, period=period,
                       time_limit=min(action_time_limit, time_limit - t))
        return world.configuration(), recorder.time, driven

    def in_goal(q: np.ndarray) -> bool:
        return policy.goal is not None and float(space.distance(q, policy.goal)) <= policy.goal_tolerance

    action = policy.first_action()
    if in_goal(q):
        outcome = "success"
    elif action is None:
        outcome = "success" if policy.goal is None and policy.is_goal(node) else "failure"
        events.append("the policy has no action from the start")
    else:
        outcome = ""
    while not outcome:
        if len(actions) >= action_limit:
            outcome = "action limit"
            events.append(f"t={t:.2f}s: {action_limit} actions performed")
            break
        if t >= time_limit - 1e-12:
            outcome = "timeout"
            events.append(f"t={t:.2f}s: time limit")
            break
        start_time = t
        q, t, driven = perform(action.target, t)
        step = policy.query_step(q, action.id, matcher)
        index = len(actions)
        actions.append({"index": index, "from_node": node, "action_id": action.id, "kind": action.kind,
                        "target": action.target.copy(), "start_time": start_time, "end_time": t, "drive": driven,
                        "reached": q.copy(), "node": step.node, "inserted": step.inserted,
                        "relocalized": step.relocalized,
                        "matching": list(step.matching), "status": step.status, "probability": step.probability})
        adaptations += [{"action_index": index, **change} for change in step.changes]
        if step.inserted:
            events.append(f"t={t:.2f}s: unforeseen outcome of action {action.id}, inserted node {step.node}")
        elif step.relocalized:
            events.append(f"t={t:.2f}s: unforeseen outcome of action {action.id} matches node {step.node}")
        node = step.node
        if in_goal(q):
            outcome = "success"
        elif step.status == "failure":
            outcome = "failure"
            events.append(f"t={t:.2f}s: P(node {node} -> goal) = {step.probability:.3g} < P_goal")
        elif step.status == "goal":
            outcome = "success" if policy.goal is None else "failure"
            if outcome == "failure" and final_approach and t < time_limit - 1e-12 and len(actions) < action_limit:
                # the goal vertex's belief is only partly inside the goal: servo to the goal itself, once
                start_time = t
                q, t, driven = perform(policy.goal, t)
                actions.append({"index": len(actions), "from_node": node, "action_id": -1, "kind": "goal",
                                "target": policy.goal.copy(), "start_time": start_time, "end_time": t,
                                "drive": driven, "reached": q.copy(), "node": node, "inserted": False,
                                "relocalized": False, "matching": [], "status": "goal",
                                "probability": step.probability})
                events.append(f"t={t:.2f}s: goal node {node} reached outside the goal tolerance; final approach "
                              f"to the goal: {driven}")
                outcome = "success" if in_goal(q) else "failure"
            if outcome == "failure":
                events.append(f"t={t:.2f}s: stopped at goal node {node} outside the goal tolerance")
        else:
            action = step.action
    recorder.settle(world)
    return recorder.record(outcome, events=events, actions=actions, adaptations=adaptations, final_node=node,
                           world=world_name)
