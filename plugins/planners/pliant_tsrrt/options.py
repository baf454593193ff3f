"""TS-RRT's option groups: ``push`` (how a push is made, shared by the planner and the ``push-models`` learner),
``cost`` (the task cost), ``planning`` (the tree), ``improvement`` (after the tree), ``execution`` (monitoring,
repairs, replanning) and ``learning`` (LEARN_MODEL's stopping rule).

A pipeline sets them as nested tables (``[planner.improvement] refine_share = 0.5``) or dotted keys (``--set
planner.improvement.refine_share=0.5``); the old flat spellings (``refine_share = 0.5``) still work, with a
deprecation warning.  Measured figures behind the defaults are on docs/plugins/tsrrt.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields

from pliant.api import ConfigError, option


@dataclass(frozen=True)
class PushingOptions:
    """How a push is made: the paddle's approach, travel, speed and noise (m, m/s, s)."""

    push_gap: float = option(0.02, "paddle's distance behind the contact point before a push (m)", minimum=0.0)
    push_depth: float = option(0.05, "how far the paddle travels beyond the contact point (m)", minimum=1e-3)
    turn_depth: float = option(0.015, "how far the paddle travels beyond the contact point in a turning push (m)",
                               minimum=1e-3)
    push_speed: float = option(0.1, "paddle speed during a push (m/s)", minimum=1e-3)
    retreat: float = option(0.02, "paddle's back-off after a push (m)", minimum=0.0)
    settle: float = option(0.2, "time at rest after a push before the objects are observed (s)", minimum=0.0)
    turn_offset: float = option(1.0, "where turning pushes press, as a fraction of the half side from the middle",
                                minimum=0.0, maximum=1.0)
    placement_noise: float = option(0.0, "standard deviation of the paddle's placement error, along and across the "
                                    "push (m): execution noise besides the simulator's actuation noise", minimum=0.0)
    control_period: float = option(0.05, "period of the paddle's velocity commands (s)", minimum=1e-3)
    guard_step: float = option(0.001, "guarded approach: the paddle advances in steps of this length (m) until the "
                               "object moves, then pushes the depth from there; 0 for a blind push of gap + depth",
                               minimum=0.0, maximum=0.01)


@dataclass(frozen=True)
class PushSettings(PushingOptions):
    """How a push is executed: the ``push`` options (:class:`pliant_tsrrt.options.PushingOptions`: gap, depths,
    speed, retreat, settle time, turn offset, control period, placement noise, guarded approach step) and the
    paddle's ``thickness`` and ``width`` (m; its extent along and across the push direction, from the scene).  With
    a guarded approach (``guard_step`` > 0) the paddle advances in steps of ``guard_step`` until the object moves,
    then travels the depth from there, so the error of its placement along the push does not change how far it
    pushes."""

    thickness: float = 0.03
    width: float = 0.08

    @classmethod
    def from_options(cls, options: PushingOptions, *, thickness: float, width: float) -> PushSettings:
        """The settings of ``options`` (every field of the group, whatever it holds) for a paddle of this size."""
        return cls(**{f.name: getattr(options, f.name) for f in fields(PushingOptions)}, thickness=thickness,
                   width=width)


@dataclass(frozen=True)
class LearningOptions:
    """LEARN_MODEL's stopping rule (poster lines 1-2)."""

    sigma_ref: float = option(0.002, "standard error of the mean displacement to reach (m)", minimum=1e-9)
    sigma_ref_angle: float = option(0.01, "standard error of the mean rotation to reach (rad)", minimum=1e-9)
    min_pushes: int = option(5, "fewest pushes per class and primitive", minimum=2)
    max_pushes: int = option(40, "most pushes per class and primitive", minimum=2)

    def validate(self) -> None:
        if self.min_pushes > self.max_pushes:
            raise ConfigError("must not exceed max_pushes", field="min_pushes", value=self.min_pushes)


@dataclass(frozen=True)
class CostOptions:
    """The task cost: weighted orthogonality, circumscribed area, edge distance and table setting."""

    w_orth: float = option(1.0, "weight of orthogonality, sum of sin^2(2 theta) over box objects", minimum=0.0)
    w_area: float = option(1.0, "weight of the circumscribed area (fraction of the table's area)", minimum=0.0)
    w_edge: float = option(1.0, "weight of the edge term, sum of 1 - d/d_ref (d: distance to the table's edge)",
                           minimum=0.0)
    w_setting: float = option(0.0, "weight of the table-setting term (relations)", minimum=0.0)
    relations: tuple[str, ...] = option((), "table setting: 'object reference dx dy', the object's centre at "
                                        "(dx, dy) m from the reference object's (or the table's lower-left corner "
                                        "for reference 'table')")
    setting_scale: float = option(0.1, "length scale l of the table-setting term (m)", minimum=1e-6)


@dataclass(frozen=True)
class PlanningOptions:
    """The tree's growth (poster lines 3-14): sampling, DIRECTGD and the clearance margin."""

    epsilon: float = option(0.1, "probability of a uniform sample instead of DIRECTGD's (poster line 6)",
                            minimum=0.0, maximum=1.0)
    gd_step: float = option(1.0, "DIRECTGD's step along the negative cost gradient, in mean push lengths",
                            minimum=1e-3)
    gd_pool: int = option(64, "DIRECTGD descends from one of this many cheapest open nodes", minimum=1)
    gd_tries: int = option(2, "descents without a cheaper child after which a node is exhausted", minimum=1)
    gd_noise: float = option(0.7, "standard deviation of a Gaussian added to DIRECTGD's sample, in mean push lengths "
                             "(a stochastic descent)", minimum=0.0)
    margin: float = option(0.01, "clearance kept around every footprint in planning (m)", minimum=0.0)
    strokes: tuple[float, ...] = option((1.0, 0.5, 0.25, 0.125, 0.0625), "the strokes a planned push may use, as "
                                        "fractions of its primitive's depth, the whole stroke first ([1]: whole "
                                        "pushes only)")

    def validate(self) -> None:
        check_strokes(self.strokes, "strokes")


def check_strokes(strokes, name: str) -> tuple[float, ...]:
    """``strokes`` as floats when they are distinct fractions in (0, 1], the whole stroke (1) first (the planner's
    ``planning.strokes`` and a plan's own); else a :class:`ConfigError` naming ``name``."""
    s = tuple(strokes)
    if not s or not all(isinstance(f, (int, float)) and not isinstance(f, bool) and 0 < f <= 1 for f in s) \
            or float(s[0]) != 1.0 or len(set(s)) != len(s):
        raise ConfigError("must be distinct fractions in (0, 1], the whole stroke (1) first", field=name,
                          value=list(s))
    return tuple(float(f) for f in s)


@dataclass(frozen=True)
class ImprovementOptions:
    """After the tree: the improvement phase (free descent to local minima, beam searches toward them), the final
    beam and the plan length's price."""

    refine: bool = option(True, "run the improvement phase after the tree (free descent of the task cost to local "
                          "minima, each object pushed toward them by a beam search)")
    refine_share: float = option(0.75, "share of a time budget (max_time, replan_time) for the improvement phase; "
                                 "the tree gets the rest (fraction)", minimum=0.0, maximum=1.0)
    refine_targets: int = option(4, "local minima to connect to, per pass", minimum=1)
    refine_rounds: int = option(800, "rounds of the free descent", minimum=1)
    refine_slack: float = option(0.003, "clearance added to the margin in the free descent (m): room for the "
                                 "pushes' quantisation", minimum=0.0)
    refine_depth: int = option(40, "most pushes per object toward its target", minimum=1)
    refine_width: int = option(64, "beam width of the search toward a target (nodes)", minimum=1)
    refine_passes: int = option(5, "most passes, each from the previous result; after one without gain the next "
                                "has a beam twice as wide (up to 4 x refine_width)", minimum=1)
    refine_branches: int = option(3, "nodes of the best path (the best node, the root and evenly between) that "
                                  "connect to the targets", minimum=1)
    refine_randoms: int = option(128, "random collision-free arrangements whose free descent adds targets",
                                 minimum=0)
    refine_patterns: int = option(0, "packed table-aligned arrangements (rows, columns, shelves) whose free descent "
                                  "adds targets (0: none)", minimum=0)
    refine_optimum: int = option(3000, "rounds of the multi-start free-placement optimisation whose optimum and its "
                                 "mirror images across the table are targets too (0: none; not in replanning)",
                                 minimum=0)
    refine_restarts: int = option(2, "improvement phases run one after another, each from the last one's plan with "
                                  "a new refine_optimum; under a time budget alone, until its deadline", minimum=1)
    refine_optimum_population: int = option(512, "members of each of the refine_optimum's three pools of starts "
                                            "(random, quarter-turned, packed patterns)", minimum=1)
    refine_optimum_basins: int = option(3, "minima of the refine_optimum in different basins (the cheapest first) "
                                        "whose arrangements and mirror images are targets", minimum=1)
    refine_optimum_orders: int = option(120, "orders of the objects tried when connecting to the refine_optimum "
                                        "targets: all permutations up to this many, else this many at random",
                                        minimum=0)
    refine_optimum_turns: int = option(10, "refine_optimum's targets are also re-solved with each box's yaw on what "
                                       "its turns reach from the start and the best node in at most this many "
                                       "turns (0: off)", minimum=0)
    refine_turn_first: bool = option(True, "a box that a connection leaves turned off its target's yaw is also "
                                     "tried turned where it is first, then pushed there; the closer wins")
    refine_sweeps: int = option(2, "sweeps over the objects when pushing them toward a target (a later sweep moves "
                                "objects that others blocked)", minimum=1)
    refine_yaw_quota: int = option(4, "most poses per yaw bin (0.25 degrees) in a box's beam, so that it keeps "
                                   "different numbers of turns (0: no limit)", minimum=0)
    beam_depth: int = option(4, "most pushes of the final beam search over every object's primitives, ordered by "
                             "the task cost (0: none)", minimum=0)
    beam_width: int = option(128, "beam width of the final beam search (nodes)", minimum=1)
    push_cost: float = option(0.0002, "price of one push in task cost: after the tree, a push is kept only if it "
                              "gains more than this (0: the cheapest plan whatever its length)", minimum=0.0)


@dataclass(frozen=True)
class ExecutionOptions:
    """Executing a plan: monitoring after every push, repairs and replanning."""

    replan_threshold: float = option(0.02, "replan when an object lies this far from where the plan predicted it "
                                     "at this step (m)", minimum=0.0)
    replan_angle: float = option(0.15, "repair or replan when a box is turned this far from the plan's predicted "
                                 "yaw at this step (rad, modulo its symmetry)", minimum=0.0)
    finish_tolerance: float = option(0.05, "when a plan is done and the arrangement costs more than (1 + this) x "
                                     "the first plan's final cost, replan toward that arrangement (fraction)",
                                     minimum=0.0)
    outcome_tolerance: float = option(0.1, "an execution that completes collision-free with its final cost above "
                                      "(1 + this) x the first plan's cost ends 'above tolerance', not 'success'",
                                      minimum=0.0)
    finish_steps: int = option(30, "when a plan is done above finish_tolerance: most closed-loop finishing pushes, "
                               "each the single push predicted to lower the cost most (0: off)", minimum=0)
    finish_scales: tuple[float, ...] = option((0.25, 0.5, 1.0), "finish_steps: the strokes a finishing push may "
                                              "use, as fractions of the primitive's depth (finer ones correct "
                                              "smaller errors)")
    adapt_models: bool = option(False, "update the push models with every push observed in execution (the pushed "
                                "object's displacement, when no other object moved) before repairs and replans")
    max_replans: int = option(20, "most replannings in one execution", minimum=0)
    replan_refine: bool = option(True, "run the improvement phase in every replanning (it connects back to the "
                                 "first plan's end); else only in the replanning after the plan is done")
    repair: bool = option(True, "before replanning, try to repair the plan by pushing displaced objects back (or "
                          "toward the first plan's final arrangement); replan only when that fails")
    repair_depth: int = option(12, "most pushes per object of a repair", minimum=1)
    max_repairs: int = option(40, "most repairs in one execution (beside max_replans)", minimum=0)
    repair_retarget: bool = option(True, "a repair after a deviation may instead re-plan the displaced objects' "
                                   "remaining pushes; the repair with fewer pushes wins")
    repair_placed: bool = option(True, "after an object's last push, repair it at once if it is off by more than "
                                 "place_threshold / place_angle")
    place_threshold: float = option(0.01, "repair_placed: position error of a placed object that is repaired (m)",
                                    minimum=0.0)
    place_angle: float = option(0.07, "repair_placed: yaw error of a placed box that is repaired (rad, modulo its "
                                "symmetry)", minimum=0.0)
    replan_shortest: bool = option(True, "a replanning counts every final cost at or below the first plan's as "
                                   "equally good, so the plan with the fewest pushes wins (else the cheapest)")

    def validate(self) -> None:
        if not self.finish_scales or not all(isinstance(f, (int, float)) and not isinstance(f, bool) and 0 < f <= 1
                                             for f in self.finish_scales):
            raise ConfigError("must be one or more fractions in (0, 1]", field="finish_scales",
                              value=list(self.finish_scales))


@dataclass(frozen=True)
class PushOptions:
    """Options of the objects, the table and the pushes (shared by the planner and the learner)."""

    objects: tuple[str, ...] = option((), "the movable objects to plan for / learn from, by scene name (default all)")
    table: str = option("table", "the scene region (by name) that is the table top; without it the scene's bounds")
    push: PushingOptions = field(default_factory=PushingOptions, metadata={
        "doc": "how a push is made (the paddle's approach, travel, speed, noise)"})


@dataclass(frozen=True)
class TSRRTOptions(PushOptions):
    """Options of the ``tsrrt`` planner (and of its plan's execution): the problem and the budgets at the top level,
    the rest in groups (``push``, ``cost``, ``planning``, ``improvement``, ``execution``, ``learning``)."""

    models: str = option("auto", "push models: 'auto' (the pipeline's push-models learner, else LEARN_MODEL in the "
                         "simulator now: poster lines 1-2) or a models file (JSON) written by that learner")
    start: str = option("scene", "initial arrangement: the scene's poses, or 'random' collision-free poses drawn "
                        "from the run's generator (placed in the world before execution)", choices=("scene", "random"))
    start_clearance: float = option(0.06, "random start: the least gap between objects, obstacles and the table's "
                                    "edge (m), so that the paddle fits between them", minimum=0.0)
    max_nodes: int = option(5000, "tree size limit (poster line 4)", minimum=2)
    max_time: float | None = option(None, "deprecated: use planning.max_time (the request's wall-clock cap, s)",
                                    minimum=0.0)
    max_iterations: int | None = option(None, "deprecated: use planning.max_iterations (the request's work budget: "
                                        "tree extensions)", minimum=1)
    replan_time: float = option(5.0, "wall-clock cap of each replanning during execution (s)", minimum=0.0)
    replan_iterations: int | None = option(None, "work budget of each replanning during execution (tree "
                                           "extensions); default the request's planning.max_iterations", minimum=1)
    cost: CostOptions = field(default_factory=CostOptions, metadata={
        "doc": "the task cost: its terms' weights and the table setting"})
    planning: PlanningOptions = field(default_factory=PlanningOptions, metadata={
        "doc": "the tree's growth: sampling, DIRECTGD, clearance margin"})
    improvement: ImprovementOptions = field(default_factory=ImprovementOptions, metadata={
        "doc": "after the tree: the improvement phase, the final beam and the price of a push"})
    execution: ExecutionOptions = field(default_factory=ExecutionOptions, metadata={
        "doc": "executing a plan: monitoring, repairs, replanning"})
    learning: LearningOptions = field(default_factory=LearningOptions, metadata={
        "doc": "LEARN_MODEL's stopping rule (models 'auto' without a learner)"})

    def validate(self) -> None:
        if self.models not in ("auto", "") and not self.models.endswith(".json"):
            raise ConfigError("must be 'auto' or a .json models file", field="models", value=self.models)


__all__ = ["CostOptions", "ExecutionOptions", "ImprovementOptions", "LearningOptions", "PlanningOptions",
           "PushOptions", "PushSettings", "PushingOptions", "TSRRTOptions", "check_strokes"]
