"""Executing a partial policy in any execution world with a controller, adapting it online (thesis 5.3.5).

The policy's side of the core's one execution loop (:func:`pliant.api.follow`): :class:`PolicyStrategy` says what
to do next from what was observed, and the loop does the rest (stepping the world under the controller, recording,
the time limit, Ctrl-C).  The loop places the robot at the policy's start, then repeats: take the policy's action (a
target configuration), drive toward it with the controller (until the controller reports it reached, gives up
because the robot is stuck, or the action's time runs out), and query the policy (thesis Algorithm 4) with the
configuration reached and the action performed.  The query matches the observation to the action's outcomes, adapts
the probabilities (eq. 5.2-5.3) or inserts an unforeseen outcome, and returns the next action.  Execution stops on

- ``success``: the configuration reached is within the goal tolerance of the policy's goal (without a goal
  in the policy: the query reports a goal vertex);
- ``failure``: the policy reports ``P(node -> goal) < P_goal`` (or no route to the goal), or it stops at a
  goal vertex outside the goal tolerance and the final approach (one drive to the goal configuration,
  ``final_approach``; not in the thesis) does not bring it within;
- ``timeout``: the total time limit; ``action limit``: the number of actions.

The record is the core's :class:`~pliant.api.ExecutionRecord` (the trajectory with contacts and the movable objects'
poses) with :class:`PolicyDetails`: in ``actions`` one entry per action performed: ``index``, ``from_node``,
``action_id``, ``kind`` (forward / reverse / goal), ``target`` ``(d,)``, ``start_time`` / ``end_time`` (s), ``drive``
(reached / stuck / timeout), ``reached`` (the configuration reached), ``node`` (matched or inserted),
``inserted``, ``relocalized``, ``matching``, ``status`` (continue / goal / failure) and ``probability``
(``P(node -> goal)`` after the update); in ``adaptations`` the probability changes of every query
``{"action_index", "action", "outcome", "before", "after"}`` (eq. 5.2-5.3); ``final_node`` the last vertex reached.
The world is any :class:`~pliant.api.ExecutionWorld`: a simulator, or a robot driver.

This module imports :mod:`pliant_belief.policy`, never the other way round: the policy is data and queries, and a
pipeline finds this strategy through :attr:`PartialPolicy.follower` (:func:`follow_policy`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from pliant.api import (
    ConfigError,
    Controller,
    DimensionError,
    Drive,
    ExecutionDetails,
    ExecutionOutcome,
    ExecutionRecord,
    ExecutionWorld,
    Place,
    ScriptedStrategy,
    StepListener,
    follow,
)

from pliant_belief.policy import Matcher, PartialPolicy


@dataclass
class PolicyDetails(ExecutionDetails):
    """A partial policy's execution: the ``actions`` performed, the probability ``adaptations`` of its queries and
    the ``final_node`` reached (see the module's description for their entries)."""

    kind = "partial-policy"
    actions: list[dict] = field(default_factory=list)
    adaptations: list[dict] = field(default_factory=list)
    final_node: int | None = None

    def summary(self) -> list[tuple[str, str]]:
        return [("actions executed", str(len(self.actions)))]


class PolicyStrategy(ScriptedStrategy):
    """Follow ``policy``, querying and adapting it (in place) after every action; see :func:`execute_policy` for
    the arguments."""

    def __init__(self, policy: PartialPolicy, *, matcher: Matcher | None = None, action_limit: int = 100,
                 action_time_limit: float = 30.0, start: np.ndarray | None = None,
                 final_approach: bool = True) -> None:
        super().__init__()
        if not action_time_limit > 0:
            raise DimensionError("action_time_limit must be positive seconds", field="action_time_limit",
                                 value=action_time_limit)
        if isinstance(action_limit, bool) or not isinstance(action_limit, (int, np.integer)) or action_limit < 1:
            raise ConfigError("action_limit must be a positive integer", field="action_limit", value=action_limit)
        matcher = matcher if matcher is not None else policy.matcher
        if matcher is None:
            raise ConfigError("execution needs a matcher(particles, q) -> bool", field="matcher", value=None)
        self.policy, self.matcher = policy, matcher
        self.action_limit, self.action_time_limit, self.final_approach = action_limit, action_time_limit, \
            final_approach
        space = policy.space
        q0 = policy.nodes[policy.start_node].expected if start is None else np.asarray(start, dtype=np.float64)
        if q0.shape != (space.dim,) or not np.all(np.isfinite(q0)):
            raise DimensionError(f"start must be a finite configuration of shape ({space.dim},)", field="start",
                                 value=np.asarray(q0).tolist())
        self.start = q0
        self.record = PolicyDetails(final_node=policy.start_node)

    def details(self) -> PolicyDetails:
        return self.record

    def script(self, rng):
        policy, events, actions = self.policy, self.events, self.record.actions
        space = policy.space

        def in_goal(q: np.ndarray) -> bool:
            return policy.goal is not None and float(space.distance(q, policy.goal)) <= policy.goal_tolerance

        seen = yield Place(self.start)
        q, t, time_limit = seen.configuration, seen.time, seen.time_limit
        node = policy.start_node
        action = policy.first_action()
        if in_goal(q):
            return ExecutionOutcome.SUCCESS
        if action is None:
            events.append("the policy has no action from the start")
            return ExecutionOutcome.SUCCESS if policy.goal is None and policy.is_goal(node) else \
                ExecutionOutcome.FAILURE
        while True:
            if len(actions) >= self.action_limit:
                events.append(f"t={t:.2f}s: {self.action_limit} actions performed")
                return ExecutionOutcome.ACTION_LIMIT
            if t >= time_limit - 1e-12:
                events.append(f"t={t:.2f}s: time limit")
                return ExecutionOutcome.TIMEOUT
            start_time = t
            seen = yield Drive(action.target, self.action_time_limit)
            q, t, driven = seen.configuration, seen.time, seen.result
            step = policy.query_step(q, action.id, self.matcher)
            index = len(actions)
            actions.append({"index": index, "from_node": node, "action_id": action.id, "kind": action.kind,
                            "target": action.target.copy(), "start_time": start_time, "end_time": t, "drive": driven,
                            "reached": q.copy(), "node": step.node, "inserted": step.inserted,
                            "relocalized": step.relocalized,
                            "matching": list(step.matching), "status": step.status, "probability": step.probability})
            self.record.adaptations += [{"action_index": index, **change} for change in step.changes]
            if step.inserted:
                events.append(f"t={t:.2f}s: unforeseen outcome of action {action.id}, inserted node {step.node}")
            elif step.relocalized:
                events.append(f"t={t:.2f}s: unforeseen outcome of action {action.id} matches node {step.node}")
            node = self.record.final_node = step.node
            if in_goal(q):
                return ExecutionOutcome.SUCCESS
            if step.status == "failure":
                events.append(f"t={t:.2f}s: P(node {node} -> goal) = {step.probability:.3g} < P_goal")
                return ExecutionOutcome.FAILURE
            if step.status == "goal":
                if policy.goal is None:
                    return ExecutionOutcome.SUCCESS
                outcome = ExecutionOutcome.FAILURE
                if self.final_approach and t < time_limit - 1e-12 and len(actions) < self.action_limit:
                    # the goal vertex's belief is only partly inside the goal: servo to the goal itself, once
                    start_time = t
                    seen = yield Drive(policy.goal, self.action_time_limit)
                    q, t, driven = seen.configuration, seen.time, seen.result
                    actions.append({"index": len(actions), "from_node": node, "action_id": -1, "kind": "goal",
                                    "target": policy.goal.copy(), "start_time": start_time, "end_time": t,
                                    "drive": driven, "reached": q.copy(), "node": node, "inserted": False,
                                    "relocalized": False, "matching": [], "status": "goal",
                                    "probability": step.probability})
                    events.append(f"t={t:.2f}s: goal node {node} reached outside the goal tolerance; final approach "
                                  f"to the goal: {driven}")
                    outcome = ExecutionOutcome.SUCCESS if in_goal(q) else ExecutionOutcome.FAILURE
                if outcome is ExecutionOutcome.FAILURE:
                    events.append(f"t={t:.2f}s: stopped at goal node {node} outside the goal tolerance")
                return outcome
            action = step.action


def execute_policy(policy: PartialPolicy, world: ExecutionWorld, controller: Controller, rng: np.random.Generator,
                   *, matcher: Matcher | None = None, period: float = 0.1, time_limit: float = 300.0,
                   action_limit: int = 100, action_time_limit: float = 30.0, start: np.ndarray | None = None,
                   final_approach: bool = True, on_step: StepListener | None = None,
                   world_name: str = "") -> ExecutionRecord:
    """Execute ``policy`` in ``world`` with ``controller``, querying and adapting it after every action: the core's
    loop (:func:`pliant.api.follow`) with a :class:`PolicyStrategy`.

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
    strategy = PolicyStrategy(policy, matcher=matcher, action_limit=action_limit,
                              action_time_limit=action_time_limit, start=start, final_approach=final_approach)
    return follow(world, controller, strategy, rng, period=period, time_limit=time_limit, on_step=on_step,
                  world_name=world_name)


def follow_policy(policy: PartialPolicy, context=None, settings: dict | None = None) -> PolicyStrategy:
    """The strategy a pipeline follows for ``policy`` (:attr:`PartialPolicy.follower`): without a matcher, the
    clustering match is built from the pipeline's ``context``; ``settings`` are the pipeline's ``[execution]``
    (``action_limit``)."""
    if policy.matcher is None:
        if context is None:
            raise ConfigError("executing a policy needs a matcher or the pipeline's context", field="context",
                              value=None)
        policy.use_clustering(context)
    return PolicyStrategy(policy, action_limit=int((settings or {}).get("action_limit", 100)))
