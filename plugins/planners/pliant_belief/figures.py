"""The report figure of a partial policy: beliefs, actions and the route it starts with (thesis Fig. 5.5)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def draw_policy(run, directory: Path) -> list[Path] | None:
    """Draw ``run.result.policy`` over the scene's obstacles (top view, x-y) as ``policy.png``.

    Particles of every belief are dots; each forward action is an arrow from its source's expectation to
    every outcome (dashed for the outcomes of a split); the route the policy follows when every action
    succeeds is drawn thick; the executed trajectory, if any, thin.  Returns the files written.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from pliant.api import VoxelGrid

    policy = run.result.policy
    scene = run.context.scene
    grid = VoxelGrid.from_scene(scene, static_only=True)
    index = np.argwhere(grid.occupied)
    walls = grid.centres(index) if len(index) else np.zeros((0, 3))
    fig, ax = plt.subplots(figsize=(7, 7))
    ax.scatter(walls[:, 0], walls[:, 1], s=9, c="0.55", marker="s", linewidths=0)
    for node in policy.nodes:
        ax.scatter(node.particles[:, 0], node.particles[:, 1], s=3, c="tab:blue", alpha=0.35, linewidths=0)
    for action in policy.actions.values():
        if action.kind != "forward":
            continue
        start = policy.nodes[action.source].expected
        split = len(action.outcomes) > 1
        for outcome in action.outcomes:
            end = policy.nodes[outcome].expected
            ax.annotate("", xy=end[:2], xytext=start[:2],
                        arrowprops={"arrowstyle": "->", "color": "tab:purple", "lw": 0.8,
                                    "linestyle": "--" if split else "-", "alpha": 0.7})
    route = np.array([policy.nodes[i].expected for i in policy.route(policy.start_node)])
    ax.plot(route[:, 0], route[:, 1], "-o", color="tab:red", lw=2.5, ms=4, label="route if every action succeeds")
    execution = run.execution
    if execution is not None and hasattr(execution, "actions"):
        q = np.asarray(execution.configurations)
        ax.plot(q[:, 0], q[:, 1], color="tab:green", lw=1.2, label=f"executed ({execution.outcome})")
    ax.plot(*scene.start[:2], "o", color="k", ms=8, label="start")
    ax.plot(*scene.goal[:2], "*", color="k", ms=14, label="goal")
    ax.set_xlim(scene.lower[0], scene.upper[0])
    ax.set_ylim(scene.lower[1], scene.upper[1])
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    solutions = len(policy.solutions)
    ax.set_title(f"{scene.name}: partial policy, {len(policy.nodes)} beliefs, {solutions} solutions")
    ax.legend(loc="upper left", fontsize=8)
    path = Path(directory) / "policy.png"
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return [path]
