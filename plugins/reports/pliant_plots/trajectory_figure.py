"""The planned path's time parameterisation over time (report figure ``trajectory.png``): every coordinate's position
and velocity, with the velocity limits dashed."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def draw_trajectory(run, directory: Path) -> list[Path] | None:
    """Draw ``trajectory.png`` when the run has a trajectory (a pipeline's ``[trajectory]`` table)."""
    trajectory = getattr(run, "trajectory", None)
    if trajectory is None or trajectory.duration <= 0:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    samples = trajectory.sample(min(1000.0, max(100.0, 2000.0 / trajectory.duration)))
    t = samples["times"]
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i in range(trajectory.dim):
        colour = colours[i % len(colours)]
        top.plot(t, samples["positions"][:, i], color=colour, label=f"q{i}")
        bottom.plot(t, samples["velocities"][:, i], color=colour)
        for sign in (-1, 1):
            bottom.axhline(sign * trajectory.velocity[i], color=colour, linestyle="--", linewidth=0.7)
    for k in trajectory.knot_times:
        for ax in (top, bottom):
            ax.axvline(k, color="0.85", linewidth=0.6, zorder=0)
    top.set_ylabel("position")
    bottom.set_ylabel("velocity (dashed: limits)")
    bottom.set_xlabel("time (s)")
    top.legend(loc="best", fontsize="small", ncol=min(4, trajectory.dim))
    top.set_title(f"trajectory: {trajectory.duration:.2f} s, {len(trajectory.knots)} rest points "
                  f"(peak velocity {np.max(np.abs(samples['velocities']) / trajectory.velocity):.0%} of its limit)")
    fig.tight_layout()
    path = Path(directory) / "trajectory.png"
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return [path]
