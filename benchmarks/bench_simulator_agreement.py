"""Agreement of the simulators: every bundled pipeline's execution in every simulator that supports its space.

Issue 36: "one scene, any simulator, the same physics". Each bundled pipeline that executes runs once as it is
(plan, then execution in its own simulator: the reference); then the same plan is executed, with the same execution
seed stream, in each other registered simulator (``registry.available("simulator")``, so a new simulator plugin
joins automatically), built as the pipeline's ``[execution] world`` would build it (pliant.pipeline). Options of the
pipeline's simulator that the other simulator also has (``velocity_limit``, ``max_force``, ``frequency``, ...) are
carried over; the physics comes from the scene for all of them.

Reported per (pipeline, simulator): the outcome, and against the pipeline's own simulator (the reference) the final
robot configuration's gap (position in m and rotation in rad for rigid bodies; the largest joint gap for arms) and
the largest final gap of a movable object (position m, heading/rotation rad). A simulator that refuses the pipeline
at build time (a 2-D backend for a 3-D scene, ...) shows its one-line reason. The kinematic simulator has no object
dynamics (it holds movable objects fixed): its object columns are empty.

The acceptance check of issue 36 is printed last: push-slide's crate in pymunk and pybullet within 3 cm and 0.1 rad,
with the pipeline's pusher options carried over and with a plain ``--set simulator=pybullet`` swap (pybullet's own
defaults for the pusher's speed and force).

    python benchmarks/bench_simulator_agreement.py [--pipelines push-slide maze-slide ...] [--simulators ...]
    pliant bench simulator_agreement -- --pipelines push-slide
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import print_table, single_core, write_json

single_core()

import numpy as np  # noqa: E402
from pliant import Pipeline, registry  # noqa: E402
from pliant.errors import PliantError  # noqa: E402
from pliant.execution.loop import follow, strategy_for  # noqa: E402
from pliant.execution.strategy import TrajectoryStrategy  # noqa: E402
from pliant.geometry.rotations import wrap_angle  # noqa: E402
from pliant.pipeline import available_pipelines  # noqa: E402
from pliant.seeds import Streams  # noqa: E402

POSITION_TOLERANCE = 0.03      # m: issue 36's acceptance for push-slide's crate
ANGLE_TOLERANCE = 0.1          # rad


def quaternion_angle(a: np.ndarray, b: np.ndarray) -> float:
    """The rotation angle (rad) between unit quaternions ``a`` and ``b`` (x, y, z, w)."""
    return float(2 * np.arccos(min(1.0, abs(float(np.dot(a, b))))))


def pose_gap(a, b, kind: str) -> tuple[float, float]:
    """(position gap m, rotation gap rad) of two final configurations or object poses of ``kind``."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    if kind == "se2" or (kind == "object" and a.size == 3):
        return float(np.hypot(*(a[:2] - b[:2]))), float(abs(wrap_angle(a[2] - b[2])))
    if kind == "se3" or (kind == "object" and a.size == 7):
        return float(np.linalg.norm(a[:3] - b[:3])), quaternion_angle(a[3:7], b[3:7])
    if kind in ("rn", "r3"):
        return float(np.linalg.norm(a - b)), float("nan")          # no rotation
    return float("nan"), float(np.max(np.abs(a - b))) if a.size else 0.0     # joints: the largest joint gap (rad)


def carried_options(reference: dict, simulator: str) -> dict:
    """The reference simulator's options that ``simulator``'s Options also has."""
    options_class = getattr(registry.default_registry().entry("simulator", simulator).load(), "Options", None)
    if options_class is None:
        return {}
    names = {f.name for f in dataclasses.fields(options_class)}
    return {key: value for key, value in reference.items() if key in names}


def refused(exc: Exception, t0: float) -> dict:
    reason = str(exc).splitlines()[0].replace(f"{Path.cwd()}/", "")
    return {"outcome": "refused", "reason": reason, "cpu_s": time.process_time() - t0}


def run(name: str, overrides: dict) -> tuple[dict, object]:
    """One run of pipeline ``name`` (nothing written): its summary (outcome, plan, final configuration and object
    poses) and the run's record (``None`` when the pipeline was refused)."""
    t0 = time.process_time()
    try:
        record = Pipeline.from_file(name, overrides=overrides).run(write=False)
    except PliantError as exc:
        return refused(exc, t0), None
    result = record.result
    out = {"outcome": record.outcome.value, "cpu_s": time.process_time() - t0,
           "space": record.context.robot.space.kind if record.context is not None and record.context.robot else None,
           "path": None if result is None or result.path is None else np.asarray(result.path.configurations),
           "final": None, "objects": {}, "reason": record.error or ""}
    return summarise(out, record.execution), record


def reexecute(name: str, record, simulator: str, options: dict) -> dict:
    """Execute ``record``'s plan (a reference run of pipeline ``name``) again in ``simulator`` with ``options``,
    built as ``[execution] world`` builds it, with the run's own execution seed stream."""
    t0 = time.process_time()
    pipeline = Pipeline.from_file(name, overrides={"execution.world": {"name": simulator, **options}})
    context, result, settings = record.context, record.result, pipeline.execution
    try:
        world = pipeline.execution_world(context)
    except PliantError as exc:
        return refused(exc, t0)
    strategy = strategy_for(result, context, settings)
    if record.trajectory is not None and result.policy is None:
        strategy = TrajectoryStrategy(record.trajectory, settings["period"], context.space)
    try:
        execution = follow(world, context.controller, strategy, Streams(pipeline.seed).rng("execution"),
                           period=settings["period"], time_limit=settings["time_limit"], world_name=simulator)
    except PliantError as exc:
        return refused(exc, t0)
    outcome = "reached" if execution.success else execution.outcome
    out = {"outcome": outcome, "cpu_s": time.process_time() - t0, "space": context.robot.space.kind,
           "path": None, "final": None, "objects": {}, "reason": ""}
    return summarise(out, execution)


def summarise(out: dict, execution) -> dict:
    """``out`` with the execution's final configuration and object poses (and a failure's reason)."""
    if execution is not None and len(execution.configurations):
        out["final"] = np.asarray(execution.configurations[-1])
        out["objects"] = {k: np.asarray(v[-1]) for k, v in (execution.objects or {}).items() if len(v)}
        if execution.outcome == "failed":
            out["outcome"] = "failed"
            out["reason"] = str(execution.error).splitlines()[0]
    return out


def compare(reference: dict, other: dict) -> dict:
    """Gaps of ``other``'s final state to ``reference``'s."""
    row = {"robot_position": None, "robot_rotation": None, "object": None, "object_position": None,
           "object_rotation": None}
    if reference["final"] is None or other.get("final") is None:
        return row
    row["robot_position"], row["robot_rotation"] = pose_gap(reference["final"], other["final"], reference["space"])
    worst = None
    for key, pose in reference["objects"].items():
        if key in other["objects"]:
            gap = pose_gap(pose, other["objects"][key], "object")
            if worst is None or gap[0] + 0.1 * gap[1] > worst[1][0] + 0.1 * worst[1][1]:
                worst = (key, gap)
    if worst is not None:
        row["object"], (row["object_position"], row["object_rotation"]) = worst[0], worst[1]
    return row


def fmt(value, digits: int = 4) -> str:
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "NO"
    if isinstance(value, float):
        return "-" if np.isnan(value) else f"{value:.{digits}g}"
    return str(value)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--pipelines", nargs="*", default=None, help="bundled pipelines (default: every one)")
    parser.add_argument("--simulators", nargs="*", default=None, help="simulators (default: every registered one)")
    args = parser.parse_args()
    logging.getLogger("pliant").setLevel(logging.ERROR)        # the runs' own progress lines
    simulators = args.simulators or registry.available("simulator")
    pipelines = args.pipelines or available_pipelines()
    rows, table = [], []
    for name in pipelines:
        pipeline = Pipeline.from_file(name)
        if "controller" not in pipeline.components or "simulator" not in pipeline.components:
            table.append((name, "-", "not executed (no controller or simulator)", "", "", "", "", ""))
            rows.append({"pipeline": name, "skipped": "no execution"})
            continue
        spec = pipeline.world_spec()
        reference, record = run(name, {})
        for simulator in [spec.name] + [s for s in simulators if s != spec.name]:
            options = carried_options(dict(spec.options), simulator)
            if simulator == spec.name:
                other, gaps = reference, {}
            elif record is None or record.result is None or not record.result.solved:
                other, gaps = {"outcome": "not run", "reason": "the reference run made no plan", "cpu_s": 0.0}, {}
            else:
                other = reexecute(name, record, simulator, options)
                gaps = compare(reference, other)
            rows.append({"pipeline": name, "simulator": simulator, "reference": spec.name, "carried": options,
                         **{k: v for k, v in other.items() if k not in ("path", "final", "objects")},
                         "final": None if other.get("final") is None else other["final"].tolist(),
                         "objects": {k: v.tolist() for k, v in other.get("objects", {}).items()}, **gaps})
            outcome = other["outcome"] + (f": {other['reason'][:70]}" if other["outcome"] in ("refused", "failed",
                                                                                             "not run") else "")
            label = simulator + (" (ref)" if simulator == spec.name else "")
            table.append((name, label, outcome, fmt(gaps.get("robot_position")),
                          fmt(gaps.get("robot_rotation")), fmt(gaps.get("object")),
                          fmt(gaps.get("object_position")), fmt(gaps.get("object_rotation"))))
            print(f"  {name} in {simulator}: {other['outcome']} ({other['cpu_s']:.1f} s CPU)", flush=True)
    print_table("Final-state gaps to the pipeline's own simulator (the same plan and execution seed)",
                ("pipeline", "simulator", "outcome", "robot dpos m", "robot drot rad", "object",
                 "object dpos m", "object drot rad"), table)

    acceptance = []
    if "push-slide" in pipelines or args.pipelines is None:
        crates = {}
        for label, overrides in (
                ("pymunk (pipeline)", {}),
                ("pybullet, pusher options carried", {"execution.world": {"name": "pybullet", "velocity_limit": 0.25,
                                                                          "max_force": 50.0}}),
                ("pybullet, plain --set simulator=pybullet", {"simulator": "pybullet"})):
            crates[label] = run("push-slide", overrides)[0]["objects"].get("crate")
        reference = crates["pymunk (pipeline)"]
        for label, crate in crates.items():
            dpos, drot = pose_gap(reference, crate, "object")
            ok = dpos < POSITION_TOLERANCE and drot < ANGLE_TOLERANCE
            acceptance.append({"run": label, "crate": crate.tolist(), "position_gap": dpos, "rotation_gap": drot,
                               "within": ok})
        print_table(f"push-slide: the crate's final pose (issue 36: within {POSITION_TOLERANCE} m and "
                    f"{ANGLE_TOLERANCE} rad of pymunk's)",
                    ("run", "crate x", "crate y", "crate theta", "dpos m", "drot rad", "within"),
                    [(a["run"], f"{a['crate'][0]:.4f}", f"{a['crate'][1]:.4f}", f"{a['crate'][2]:.4f}",
                      f"{a['position_gap']:.4f}", f"{a['rotation_gap']:.4f}", "yes" if a["within"] else "NO")
                     for a in acceptance])
    write_json("simulator_agreement", {"simulators": simulators, "rows": rows, "push_slide": acceptance,
                                       "tolerance": {"position": POSITION_TOLERANCE, "rotation": ANGLE_TOLERANCE}})


if __name__ == "__main__":
    main()
