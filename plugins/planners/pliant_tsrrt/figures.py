"""Report figures of TS-RRT runs (poster ICHR 2010): ``tsrrt.png`` (the initial arrangement, the planned sequence and
the final arrangement, planned and executed) and ``push-models.png`` (mean and 95 % interval of each primitive's
displacement per workspace dimension and object class, as the poster's model-learning figure)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pliant_tsrrt import domain
from pliant_tsrrt.geometry import CIRCLE, Footprints, box_corners
from pliant_tsrrt.models import PushModels, footprints_from_scene
from pliant_tsrrt.pushing import PRIMITIVES


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def draw_arrangement(ax, poses: np.ndarray, fp: Footprints, colors, alpha: float = 1.0, fill: bool = True,
                     labels: list[str] | None = None) -> None:
    """Footprints at ``poses`` ``(k, 3)`` on a matplotlib axis."""
    from matplotlib.patches import Circle, Polygon

    for i, p in enumerate(poses):
        c = colors[i % len(colors)]
        if fp.kind[i] == CIRCLE:
            patch = Circle(p[:2], fp.half[i, 0], fc=c if fill else "none", ec=c, alpha=alpha, lw=1.2)
        else:
            patch = Polygon(box_corners(p, fp.half[i]), closed=True, fc=c if fill else "none", ec=c, alpha=alpha,
                            lw=1.2)
        ax.add_patch(patch)
        if labels:
            ax.text(p[0], p[1], labels[i], ha="center", va="center", fontsize=6)


def _frame(ax, scene, table, obstacles, title: str) -> None:
    from matplotlib.patches import Rectangle

    x0, y0, x1, y1 = table
    ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, fc="#f3ead9", ec="k", lw=1.0))
    if obstacles is not None and len(obstacles[0]):
        draw_arrangement(ax, obstacles[1], obstacles[0], ["#555555"])
    ax.set_xlim(scene.lower[0], scene.upper[0])
    ax.set_ylim(scene.lower[1], scene.upper[1])
    ax.set_aspect("equal")
    ax.set_title(title, fontsize=9)


def draw_plan(path: Path, scene, plan, executed: np.ndarray | None = None, executed_cost: float | None = None,
              start_cost: float | None = None) -> Path:
    """Three panels: initial arrangement, the planned sequence (every predicted arrangement, fading in), final."""
    plt = _plt()
    options = plan.options
    names = plan.names
    fp = footprints_from_scene(scene, names)
    table = domain.table_rect(scene, options.get("table", "table"))
    obs_fp, obs_poses, _ = domain.obstacles(scene, names, table)
    colors = plt.cm.tab10(np.arange(len(names)) % 10)
    short = [n.replace("-", "")[:6] for n in names]
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6))
    _frame(axes[0], scene, table, (obs_fp, obs_poses), "initial" + (f" (cost {start_cost:.3f})" if start_cost
                                                                     is not None else ""))
    draw_arrangement(axes[0], plan.start, fp, colors, labels=short)
    _frame(axes[1], scene, table, (obs_fp, obs_poses), f"planned sequence: {len(plan.actions)} pushes")
    m = len(plan.states)
    for j, s in enumerate(plan.states):
        draw_arrangement(axes[1], s, fp, colors, alpha=0.15 + 0.6 * j / max(1, m - 1), fill=False)
    for j, a in enumerate(plan.actions):
        o = a // plan.n_prims
        p0, p1 = plan.states[j][o, :2], plan.states[j + 1][o, :2]
        axes[1].annotate("", p1, p0, arrowprops={"arrowstyle": "->", "color": colors[o], "lw": 0.8})
    title = f"final: planned cost {plan.cost:.3f}"
    _frame(axes[2], scene, table, (obs_fp, obs_poses), title if executed is None else
           f"{title}; executed {executed_cost:.3f} (filled)")
    draw_arrangement(axes[2], plan.states[-1], fp, colors, fill=executed is None, alpha=0.9 if executed is None
                     else 0.7, labels=None if executed is not None else short)
    if executed is not None:
        draw_arrangement(axes[2], executed, fp, colors, alpha=0.8, labels=short)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def draw_models(path: Path, models: PushModels) -> Path:
    """Mean and 95 % interval (mean +- 1.96 s) of dx, dy (mm) and dtheta (deg) per primitive, one row per class."""
    plt = _plt()
    classes = list(models.models)
    fig, axes = plt.subplots(len(classes), 3, figsize=(12, 2.6 * len(classes)), squeeze=False)
    labels = ("dx (mm)", "dy (mm)", "dtheta (deg)")
    scale = np.array([1000.0, 1000.0, 180.0 / np.pi])
    x = np.arange(len(PRIMITIVES))
    for r, cls in enumerate(classes):
        per = models.models[cls]
        mean = np.array([d.mean for d in per]) * scale
        half = 1.96 * np.array([d.std for d in per]) * scale
        for c in range(3):
            ax = axes[r, c]
            ax.bar(x, mean[:, c], color="#8fb3d9")
            ax.errorbar(x, mean[:, c], yerr=half[:, c], fmt="none", ecolor="k", capsize=3)
            ax.axhline(0.0, color="k", lw=0.5)
            ax.set_xticks(x, PRIMITIVES, fontsize=7)
            ax.set_ylabel(labels[c], fontsize=8)
            if c == 0:
                ax.set_title(f"{cls} (n = {sum(d.n for d in per)} pushes)", fontsize=9, loc="left")
    fig.suptitle("push models: mean and 95 % interval of the displacement (object frame)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def draw_run(run, directory: Path) -> list[Path] | None:
    """The report hook: figures for runs whose planner is ``tsrrt`` or whose learner is ``push-models``."""
    from pliant_tsrrt.planner import PushPlan

    files = []
    directory = Path(directory)
    scene = run.context.scene
    plan = run.result.policy if run.result is not None and isinstance(run.result.policy, PushPlan) else None
    if plan is not None:
        done = run.execution.details if run.execution is not None else None     # PushPlanDetails (or a partial's)
        files.append(draw_plan(directory / "tsrrt.png", scene, plan, getattr(done, "final_state", None),
                               getattr(done, "final_cost", None), run.result.statistics.get("start_cost")))
    learner = run.context.extras.get("learner")
    models = getattr(learner, "models", None)
    if not isinstance(models, PushModels) and plan is not None:
        models = plan.models
    if isinstance(models, PushModels) and models.models:
        files.append(draw_models(directory / "push-models.png", models))
    return files or None
