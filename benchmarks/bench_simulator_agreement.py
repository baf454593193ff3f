"""Agreement of the simulators: every bundled pipeline's execution in every simulator that supports its space.

Issue 36: "one scene, any simulator, the same physics".  For each bundled pipeline that executes, and each registered
simulator (``registry.available("simulator")``, so a new simulator plugin joins automatically), the pipeline runs with
its execution world swapped through ``[execution] world`` (pliant.pipeline): the planner and its planning context stay
the pipeline's own, the seed is the pipeline's, so the plan is the same (checked: "same plan"), and only the world it
is executed in changes.  Options of the pipeline's simulator that the other simulator also has (``velocity_limit``,
``max_force``, ``frequency``, ...) are carried over; the physics comes from the scene for all of them.

Reported per (pipeline, simulator): the outcome, and against the pipeline's own simulator (the reference) the final
robot configuration's gap (position in m and rotation in rad for rigid bodies; the largest joint gap for arms) and the
largest final gap of a movable object (position m, heading/rotation rad).  A simulator that refuses the pipeline at
build time (a 2-D backend for a 3-D scene, ...) shows its one-line reason.  The kinematic simulator has no object
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
from pliant.geometry.rotations import wrap_angle  # noqa: E402
from pliant.pipeline import available_pipelines  # noqa: E402

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


def run(name: str, overrides: dict) -> dict:
    """One run of pipeline ``name`` (nothing written): outcome, plan, final configuration and object poses."""
    t0 = time.process_time()
    try:
        record = Pipeline.from_file(name, overrides=overrides).run(write=False)
    except PliantError as exc:
        reason = str(exc).splitlines()[0].replace(f"{Path.cwd()}/", "")
        return {"outcome": "refused", "reason": reason, "cpu_s": time.process_time() - t0}
    execution = record.execution
    result = record.result
    out = {"outcome": record.outcome.value, "cpu_s": time.process_time() - t0,
           "space": record.context.robot.space.kind if record.context is not None and record.context.robot else None,
           "path": None if result is None or result.path is None else np.asarray(result.path.configurations),
           "final": None, "objects": {}, "reason": record.error or ""}
    if execution is not None and len(execution.configurations):
        out["final"] = np.asarray(execution.configurations[-1])
        out["objects"] = {k: np.asarray(v[-1]) for k, v in (execution.objects or {}).items() if len(v)}
        if execution.outcome == "failed":
            out["outcome"] = "failed"
            out["reason"] = str(execution.error).splitlines()[0]
    return out


def compare(reference: dict, other: dict) -> dict:
    """Gaps of ``other``'s final state to ``reference``'s."""
    row = {"same_plan": None, "robot_position": None, "robot_rotation": None, "object": None,
           "object_position": None, "object_rotation": None}
    if reference["path"] is not None and other.get("path") is not None:
        row["same_plan"] = bool(reference["path"].shape == other["path"].shape and
                                np.array_equal(reference["path"], other["path"]))
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
            table.append((name, "-", "not executed (no controller or simulator)", "", "", "", "", "", ""))
            rows.append({"pipeline": name, "skipped": "no execution"})
            continue
        spec = pipeline.world_spec()
        runs = {}
        for simulator in [spec.name] + [s for s in simulators if s != spec.name]:
            options = carried_options(dict(spec.options), simulator)
            runs[simulator] = run(name, {"execution.world": {"name": simulator, **options}})
            other = runs[simulator]
            gaps = compare(runs[spec.name], other) if simulator != spec.name else {}
            rows.append({"pipeline": name, "simulator": simulator, "reference": spec.name, "carried": options,
                         **{k: v for k, v in other.items() if k not in ("path", "final", "objects")},
                         "final": None if other.get("final") is None else other["final"].tolist(),
                         "objects": {k: v.tolist() for k, v in other.get("objects", {}).items()}, **gaps})
            outcome = other["outcome"] + (f": {other['reason'][:70]}" if other["outcome"] in ("refused", "failed")
                                          else "")
            label = simulator + (" (ref)" if simulator == spec.name else "")
            table.append((name, label, outcome, fmt(gaps.get("same_plan")), fmt(gaps.get("robot_position")),
                          fmt(gaps.get("robot_rotation")), fmt(gaps.get("object")),
                          fmt(gaps.get("object_position")), fmt(gaps.get("object_rotation"))))
            print(f"  {name} in {simulator}: {other['outcome']} ({other['cpu_s']:.1f} s CPU)", flush=True)
    print_table("Final-state gaps to the pipeline's own simulator (same seed, same plan, execution world swapped)",
                ("pipeline", "simulator", "outcome", "same plan", "robot dpos m", "robot drot rad", "object",
                 "object dpos m", "object drot rad"), table)

    acceptance = []
    if "push-slide" in pipelines or args.pipelines is None:
        crates = {}
        for label, overrides in (
                ("pymunk (pipeline)", {}),
                ("pybullet, pusher options carried", {"execution.world": {"name": "pybullet", "velocity_limit": 0.25,
                                                                          "max_force": 50.0}}),
                ("pybullet, plain --set simulator=pybullet", {"simulator": "pybullet"})):
            result = run("push-slide", overrides)
            crates[label] = result["objects"].get("crate")
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
