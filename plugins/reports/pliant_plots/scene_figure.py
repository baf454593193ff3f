"""Top and side views of a scene with the robot's planned path (report figure ``path.png``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def _object_points(scene, max_points: int = 60000) -> tuple[np.ndarray, np.ndarray]:
    """Voxel centres occupied by objects (subsampled) and their deformability."""
    shape = np.array(scene.shape)
    stride = max(1, int(np.ceil((np.prod(shape) / max_points) ** (1 / 3))))
    axes = [scene.lower[i] + (np.arange(0, shape[i], stride) + 0.5) * scene.resolution for i in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    pts, defo = [], []
    for obj in scene.objects:
        inside = obj.contains(grid)
        pts.append(grid[inside])
        defo.append(np.full(inside.sum(), obj.material.deformability))
    if not pts:
        return np.zeros((0, 3)), np.zeros(0)
    return np.concatenate(pts), np.concatenate(defo)


def draw_run(run, directory: Path) -> list[Path] | None:
    """Draw ``path.png``: objects (shaded by deformability), the path and the body at a few waypoints."""
    if run.result is None or run.result.path is None or run.context.robot is None:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scene = run.context.scene
    robot = run.context.robot
    configs = run.result.path.configurations
    body = robot.body_points(configs[np.linspace(0, len(configs) - 1, min(6, len(configs))).astype(int)])
    reference = robot.body_points(configs).mean(axis=1)
    executed = None
    if run.execution is not None:
        executed = robot.body_points(run.execution.configurations).mean(axis=1)
    obj_pts, obj_def = _object_points(scene)
    views = [("top view (x, y)", 0, 1)] if scene.planar else [("top view (x, y)", 0, 1), ("side view (y, z)", 1, 2)]
    fig, axes = plt.subplots(1, len(views), figsize=(6 * len(views), 5), squeeze=False)
    for ax, (title, i, j) in zip(axes[0], views):
        if len(obj_pts):
            ax.scatter(obj_pts[:, i], obj_pts[:, j], c=obj_def, cmap="Greys_r", vmin=0, vmax=1.5, s=4, marker="s",
                       alpha=0.35, linewidths=0)
        for k, pts in enumerate(body):
            ax.scatter(pts[:, i], pts[:, j], s=2, color=plt.cm.viridis(k / max(1, len(body) - 1)), alpha=0.6)
        ax.plot(reference[:, i], reference[:, j], "r-", lw=1.5, label="path (body centre)")
        if executed is not None:
            ax.plot(executed[:, i], executed[:, j], "b-", lw=1.2, alpha=0.8,
                    label=f"executed ({run.execution.outcome})")
        ax.plot(*reference[0, [i, j]], "go", label="start")
        ax.plot(*reference[-1, [i, j]], "b*", ms=10, label="goal")
        ax.set_xlim(scene.lower[i], scene.upper[i])
        ax.set_ylim(scene.lower[j], scene.upper[j])
        ax.set_aspect("equal")
        ax.set_title(title)
        ax.set_xlabel("xyz"[i] + " (m)")
        ax.set_ylabel("xyz"[j] + " (m)")
    axes[0][0].legend(loc="best", fontsize=8)
    fig.suptitle(f"{scene.name}: {run.result.status.value}, cost {run.result.cost:.4g}")
    fig.tight_layout()
    out = Path(directory) / "path.png"
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return [out]
