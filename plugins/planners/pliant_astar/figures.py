"""Report figures of a Pareto sweep: the front, and the distinct path classes over the scene."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from pliant.api import VoxelGrid


def draw_pareto(run, directory: Path) -> list[Path]:
    """Write ``pareto_front.png`` and ``pareto_paths.png`` for an ``astar-pareto`` result."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    stats = run.result.statistics
    scene = run.context.scene
    sweep = np.array(stats["sweep"], dtype=float).reshape(-1, 3)
    front = stats["pareto"]
    paths = [np.asarray(c, dtype=float) for c in stats["pareto_paths"]]
    colours = [plt.cm.plasma(i / max(1, len(front) - 1) * 0.85) for i in range(len(front))]
    out = []

    fig, ax = plt.subplots(figsize=(6, 4.5))
    ok = np.isfinite(sweep[:, 1])
    ax.scatter(sweep[ok, 1], sweep[ok, 2], s=12, color="0.7", label=f"A* runs ({ok.sum()} values of p)")
    ax.plot([f["length_voxels"] for f in front], [f["deformation"] for f in front], "-", color="0.3", lw=1)
    for f, c in zip(front, colours):
        ps = f["p_values"]
        ax.scatter(f["length_voxels"], f["deformation"], s=60, color=c, zorder=3,
                   label=f"p in [{min(ps):.2f}, {max(ps):.2f}]: length {f['length_voxels']:.1f}, "
                         f"deformation {f['deformation']:.4g}")
    ax.set_xlabel("path length (voxels)")
    ax.set_ylabel("deformation (accumulated cost)")
    ax.set_title(f"{scene.name}: Pareto front ({len(front)} distinct paths)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    out.append(Path(directory) / "pareto_front.png")
    fig.savefig(out[-1], dpi=110)
    plt.close(fig)

    grid = VoxelGrid.from_scene(scene)
    occ = grid.occupied
    views = [("top view: x (voxels) / y", 0, 1), ("side view: y / z (voxels)", 1, 2)]
    fig, axes = plt.subplots(1, 2, figsize=(14, 4.5), gridspec_kw={"width_ratios": [1, 2]})
    for ax, (title, i, j) in zip(axes, views):
        other = 3 - i - j
        ax.imshow(occ.sum(axis=other).T if i < j else occ.sum(axis=other), origin="lower", cmap="Greys",
                  alpha=0.6, aspect="equal")
        for cells, f, c in zip(paths, front, colours):
            ax.plot(cells[:, i], cells[:, j], "-", color=c, lw=2,
                    label=f"length {f['length_voxels']:.1f}, deformation {f['deformation']:.4g}")
        if paths:
            ax.plot(paths[0][0, i], paths[0][0, j], "go", ms=8)
            ax.plot(paths[0][-1, i], paths[0][-1, j], "b*", ms=12)
        ax.set_title(title)
    axes[1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.suptitle(f"{scene.name}: Pareto-optimal path classes (reference voxel; walls shaded by thickness)")
    fig.tight_layout()
    out.append(Path(directory) / "pareto_paths.png")
    fig.savefig(out[-1], dpi=110)
    plt.close(fig)
    return out
