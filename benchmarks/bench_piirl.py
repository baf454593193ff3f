"""PIIRL (thesis ch. 4) on the hollow cube: the cost of each stage of a fit on 12 demonstrations x 100 samples.

The simulated expert shows one demonstration for each of the 12 adjacent pairs (seed 0).  Timed, on one core:
drawing 100 valid sample paths around each (smooth noise, funnel checks), reading the per-object deformation of
all 1,200 sample paths (the voxel cost's breakdown), and solving eq. 4.1 (L-BFGS-B) on those features; also the
local optimiser's extra rounds.  Figure to reach: the fit <= 1 s (the thesis used MATLAB's minimiser and gave no
time).  The whole active-learning trial is timed by `pliant learn-active` (its report gives seconds per trial).

    pliant bench piirl [-- --samples 100 --repeats 5]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import print_table, write_json


def main() -> None:
    import pliant
    from pliant_piirl.expert import SimulatedExpert
    from pliant_piirl.features import DeformationFeatures, true_sensitivities
    from pliant_piirl.piirl import recover
    from pliant_piirl.sampling import PathSampler, SampleOptions
    from pliant_piirl.tasks import TaskSpace, rotation_onto

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=100)
    parser.add_argument("--repeats", type=int, default=5, help="times eq. 4.1 is solved (the median is shown)")
    args = parser.parse_args()
    scene = pliant.load_scene("hollow-cube")
    features = DeformationFeatures(scene)
    tip = np.array([0.0, 0.0, -0.06])
    tasks = TaskSpace(scene)
    expert = SimulatedExpert(features, true_sensitivities(scene), tip)
    rng = np.random.default_rng(0)
    adjacency = tasks.adjacency()
    pairs = sorted({tuple(sorted((a, b))) for a in adjacency for b in adjacency[a]})
    t0 = time.perf_counter()
    demonstrations = [expert.demonstrate(tasks.generate_task(a, b, rng, tip, rotation_onto), rng) for a, b in pairs]
    demonstrate = time.perf_counter() - t0
    sampler = PathSampler(features, tip, SampleOptions(samples=args.samples))
    t0 = time.perf_counter()
    samples = [sampler.draw(d, rng) for d in demonstrations]
    draw = time.perf_counter() - t0
    t0 = time.perf_counter()
    sample_features = [features.of_paths(s) for s in samples]
    demo_features = np.array([features.of_path(d.path) for d in demonstrations])
    read = time.perf_counter() - t0
    solves, result = [], None
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        result = recover(demo_features, sample_features)
        solves.append(time.perf_counter() - t0)
    t0 = time.perf_counter()
    for d in demonstrations:
        sampler.improve(d, rng)
    improve = time.perf_counter() - t0
    solve = float(np.median(solves))
    n_samples = sum(len(s) for s in samples)
    rows = [("expert: 12 demonstrations", f"{demonstrate:.2f}", "-"),
            (f"draw {n_samples} valid sample paths", f"{draw:.2f}", "-"),
            (f"features of {n_samples} sample paths", f"{read:.2f}", "-"),
            ("eq. 4.1 solve (median)", f"{solve:.4f}", "<= 1 s"),
            ("fit = draw + features + solve", f"{draw + read + solve:.2f}", "<= 1 s"),
            ("local optimiser (3 rounds, 12 demos)", f"{improve:.2f}", "-")]
    print_table(f"PIIRL on hollow-cube: 12 demonstrations x {args.samples} samples, one core",
                ("stage", "seconds", "target"), rows)
    names = features.names
    print("recovered: " + ", ".join(f"{n} {v:.4g}" for n, v in zip(names, result["sensitivities"])))
    write_json("piirl", {"samples": n_samples, "demonstrate_s": demonstrate, "draw_s": draw,
                                "features_s": read, "solve_s": solves, "improve_s": improve,
                                "sensitivities": dict(zip(names, result["sensitivities"].tolist()))})


if __name__ == "__main__":
    main()
