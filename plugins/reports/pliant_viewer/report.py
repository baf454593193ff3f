"""The viewer's part of a pipeline's report: the run folder's view cache, written when the run is written.

``pliant run`` calls every plugin's ``pliant_report`` hook after it wrote ``run.json``, ``result.json`` and
``execution.json``.  For a run of an articulated robot (PR2, Baxter, iiwa) this hook builds the view of the folder
exactly as ``pliant view out/<run>/`` would (the same scene, read back from ``run.json``; the same run files) with
the robot model the run already has in memory, and writes ``view-cache.npz`` (:mod:`pliant_viewer.cache`); it also
converts the robot's collision meshes into the user's cache (:mod:`pliant_viewer.robot_mesh`) when they are not
there yet.  So the first ``pliant view`` of a fresh run folder neither builds a robot model nor parses a URDF.

Runs of rigid robots are skipped (their views are cheap to build; nothing is cached for them).  The hook never
fails a run: whatever goes wrong is logged and the view is built when it is opened, as before.
"""

from __future__ import annotations

import logging
import time
from pathlib import Path

log = logging.getLogger(__name__)


def write_view_cache(run, directory: Path) -> Path | None:
    """Write ``directory/view-cache.npz`` for the finished pipeline ``run`` (a :class:`pliant.pipeline.RunRecord`)
    when its robot is articulated; returns the file, or ``None`` when nothing was written (a rigid robot, a run
    folder without ``run.json``, or an error, which is logged)."""
    robot = getattr(run.context, "robot", None)
    if robot is None or robot.urdf_description() is None:
        return None
    directory = Path(directory)
    if not (directory / "run.json").is_file():
        return None
    t0 = time.perf_counter()
    try:
        from pliant_viewer import cache, robot_mesh
        from pliant_viewer.commands import resolve
        from pliant_viewer.viewer import build_content

        scene, data, policy = resolve(str(directory), None)        # what ``pliant view DIRECTORY`` reads
        view = build_content(scene, robot, run=data, policy=policy)
        if not view.articulated:
            return None
        path = cache.save(view, directory)
        robot_mesh.ensure_cached(view.urdf, "collision")
    except Exception as exc:  # the view is built when it is opened instead; never fail the run for it
        log.warning("view cache not written for %s: %s: %s", directory, type(exc).__name__, exc)
        return None
    log.info("view cache %s written in %.2f s", path, time.perf_counter() - t0)
    return path
