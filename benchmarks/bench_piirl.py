"""PIIRL (thesis ch. 4) on the hollow cube: the cost of each stage of a fit on 12 demonstrations x 100 samples.

The simulated expert shows one demonstration for each of the 12 adjacent pairs (seed 0).  Timed, on one core: the
fit, that is drawing 100 valid sample paths around each demonstration (smooth noise, funnel checks, the end put
back on the target) together with their per-object deformation (the voxel cost's breakdown, read once from the
states the funnel check measured), the demonstrations' own features, and the recovery's solve (L-BFGS-B; the
default objective).  The fit is repeated ``--repeats`` times from the same random
state (the same samples each time) and the median of each stage is shown, wall and CPU seconds: on a machine shared
with other work the wall time is the larger.  Also shown, for comparison with the draw: the features of all sample
paths read again on their own (``of_paths``), the other objectives' solves on the same features, the local
optimiser's rounds, and ``learner.fit`` as a user calls it (its defaults: the local optimiser, whose last round's
samples are the fit's, and the solve).  Figure to reach: ``learner.fit`` <= 1 s of CPU, normalised to the idle
machine of the reference figures by the expert's CPU time in the same run (the thesis gave no time).
The whole active-learning trial is timed by `pliant experiment active-learning` (its report gives seconds per trial).

    pliant bench piirl [-- --samples 100 --repeats 5]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import print_table, single_core, write_json

single_core()

#: CPU seconds of the expert's 12 demonstrations on an idle machine (2026-11-26, load 1.5, docs/plugins/piirl.md):
#: what the fit's CPU time is normalised by
REFERENCE_EXPERT_CPU = 4.68


def _timed(fn):
    """``fn()`` and its (wall, CPU) seconds."""
    wall, cpu = time.perf_counter(), time.process_time()
    out = fn()
    return out, (time.perf_counter() - wall, time.process_time() - cpu)


def main() -> None:
    import pliant
    from pliant_piirl.expert import SimulatedExpert
    from pliant_piirl.features import DeformationFeatures, true_sensitivities
    from pliant_piirl.piirl import OBJECTIVES, RecoveryOptions, recover
    from pliant_piirl.sampling import PathSampler, SampleOptions
    from pliant_piirl.tasks import TaskSpace, rotation_onto

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=100)
    parser.add_argument("--repeats", type=int, default=5, help="times the fit is run (the median is shown)")
    args = parser.parse_args()
    scene = pliant.load_scene("hollow-cube")
    features = DeformationFeatures(scene)
    tip = np.array([0.0, 0.0, -0.06])
    tasks = TaskSpace(scene)
    expert = SimulatedExpert(features, true_sensitivities(scene), tip)
    rng = np.random.default_rng(0)
    adjacency = tasks.adjacency()
    pairs = sorted({tuple(sorted((a, b))) for a in adjacency for b in adjacency[a]})
    demonstrations, demonstrate = _timed(lambda: [expert.demonstrate(tasks.generate_task(a, b, rng, tip,
                                                                                         rotation_onto), rng)
                                                  for a, b in pairs])
    sampler = PathSampler(features, tip, SampleOptions(samples=args.samples))
    state = rng.bit_generator.state
    default = RecoveryOptions().objective
    others = [o for o in OBJECTIVES if o != default]
    stages: dict[str, list[tuple[float, float]]] = {"draw": [], "demo": [], "solve": [], "fit": [], "alone": [],
                                                    **{o: [] for o in others}}
    solved: dict[str, dict] = {}
    result, samples, sample_features = None, None, None
    for _ in range(args.repeats):
        rng.bit_generator.state = state                     # every repeat draws the same samples
        drawn, draw = _timed(lambda: [sampler.draw_with_features(d, rng) for d in demonstrations])
        demo_features, demo = _timed(lambda: np.array([features.of_path(d.path) for d in demonstrations]))
        result, solve = _timed(lambda v=demo_features, w=[f for _, f in drawn]: recover(v, w))
        for other in others:
            solved[other], other_time = _timed(lambda v=demo_features, w=[f for _, f in drawn], o=other:
                                               recover(v, w, RecoveryOptions(objective=o)))
            stages[other].append(other_time)
        if samples is not None:
            assert all(np.array_equal(a, f) for a, (_, f) in zip(sample_features, drawn)), "repeats differ"
        samples, sample_features = [s for s, _ in drawn], [f for _, f in drawn]
        stages["draw"].append(draw)
        stages["demo"].append(demo)
        stages["solve"].append(solve)
        stages["fit"].append((draw[0] + demo[0] + solve[0], draw[1] + demo[1] + solve[1]))
        again, alone = _timed(lambda paths=samples: [features.of_paths(s) for s in paths])
        assert all(np.array_equal(a, b) for a, b in zip(again, sample_features)), "of_paths differs from the draw"
        stages["alone"].append(alone)
    _, improve = _timed(lambda: [sampler.improve(d, rng) for d in demonstrations])
    # learner.fit as a user calls it: its defaults, the local optimiser included (its last round's samples are the
    # fit's samples), from the same random state each time
    context = pliant.api.Context(scene=scene)
    context.robot = pliant.registry.create("robot", "rigid", context)
    learner = pliant.registry.create("learner", "piirl", context, samples=args.samples)
    for _ in range(args.repeats):
        _, user_fit = _timed(lambda: learner.fit(demonstrations, np.random.default_rng(1)))
        stages.setdefault("learner_fit", []).append(user_fit)
    median = {k: (statistics.median(w for w, _ in v), statistics.median(c for _, c in v)) for k, v in stages.items()}
    n_samples = sum(len(s) for s in samples)
    rows = [("expert: 12 demonstrations (once)", f"{demonstrate[0]:.2f}", f"{demonstrate[1]:.2f}", "-"),
            (f"draw {n_samples} valid sample paths with their features", f"{median['draw'][0]:.3f}",
             f"{median['draw'][1]:.3f}", "-"),
            ("features of the 12 demonstrations", f"{median['demo'][0]:.4f}", f"{median['demo'][1]:.4f}", "-"),
            (f"solve ({default}, the default)", f"{median['solve'][0]:.4f}", f"{median['solve'][1]:.4f}", "-"),
            ("fit = draw + features + solve", f"{median['fit'][0]:.3f}", f"{median['fit'][1]:.3f}", "<= 1 s"),
            (f"(features of the {n_samples} sample paths alone)", f"{median['alone'][0]:.3f}",
             f"{median['alone'][1]:.3f}", "-"),
            *[(f"(objective {o}'s solve on the same features)", f"{median[o][0]:.4f}", f"{median[o][1]:.4f}",
               "-") for o in others],
            ("local optimiser (3 rounds, 12 demos, once)", f"{improve[0]:.2f}", f"{improve[1]:.2f}", "-"),
            ("learner.fit, its defaults (local optimiser + samples + alternatives + solve)",
             f"{median['learner_fit'][0]:.3f}", f"{median['learner_fit'][1]:.3f}", "<= 1 s")]
    print_table(f"PIIRL on hollow-cube: 12 demonstrations x {args.samples} samples, one core, median of "
                f"{args.repeats} fits", ("stage", "wall s", "CPU s", "target"), rows)
    # CPU seconds on a loaded machine run long (shared caches and cores); scaled by the expert's 12 demonstrations,
    # whose CPU time on an idle machine is on file (4.68 s, docs/plugins/piirl.md), they compare across runs
    factor = REFERENCE_EXPERT_CPU / demonstrate[1]
    print(f"normalised to the idle reference (expert {demonstrate[1]:.2f} s CPU here, {REFERENCE_EXPERT_CPU} s "
          f"idle: x{factor:.3f}): fit = draw + features + solve {median['fit'][1] * factor:.3f} s, learner.fit "
          f"{median['learner_fit'][1] * factor:.3f} s (target <= 1 s)")
    names = features.names
    print(f"recovered ({default}): " + ", ".join(f"{n} {v:.4g}" for n, v in zip(names, result["sensitivities"])))
    for o in others:
        print(f"{o}: " + ", ".join(f"{n} {v:.4g}" for n, v in zip(names, solved[o]["sensitivities"])))
    write_json("piirl", {"samples": n_samples, "repeats": args.repeats, "demonstrate_s": demonstrate[0],
                         **{f"{k}_s": [w for w, _ in v] for k, v in stages.items()},
                         **{f"{k}_cpu_s": [c for _, c in v] for k, v in stages.items()},
                         "improve_s": improve[0], "expert_cpu_s": demonstrate[1],
                         "normalisation": REFERENCE_EXPERT_CPU / demonstrate[1],
                         "learner_fit_normalised_cpu_s": median["learner_fit"][1] * REFERENCE_EXPERT_CPU
                         / demonstrate[1],
                         "sensitivities": dict(zip(names, result["sensitivities"].tolist())),
                         "objective": default,
                         **{f"{o}_sensitivities": dict(zip(names, solved[o]["sensitivities"].tolist()))
                            for o in others}})


if __name__ == "__main__":
    main()
