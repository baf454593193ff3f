"""Where the named robots' description files are installed (shared by the robot model and the drivers).

PR2 and Baxter come from the ``example-robot-data`` package (data only, installed under the cmeel prefix
``<site-packages>/cmeel.prefix/share/example-robot-data/robots``).
"""

from __future__ import annotations

import importlib.metadata
from pathlib import Path

from pliant.errors import SceneError


def example_robot_data_dir(source: str | None = None) -> Path:
    """The ``robots`` directory of the installed ``example-robot-data`` (found via the package's file list).

    Raises :class:`~pliant.errors.SceneError` (naming ``source``) when it is not installed or not found.
    """
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        raise SceneError("example-robot-data is not installed (it provides the PR2 and Baxter URDFs)",
                         source=source, field="robot.model", value="example-robot-data") from None
    candidates = [Path(str(dist.locate_file("cmeel.prefix/share/example-robot-data/robots")))]
    marker = "share/example-robot-data/robots/"
    for f in dist.files or ():
        text = str(f).replace("\\", "/")
        if marker in text:
            candidates.append(Path(str(dist.locate_file(text[: text.index(marker) + len(marker) - 1]))))
            break
    for robots in candidates:
        if robots.is_dir():
            return robots
    raise SceneError("example-robot-data is installed but its robots directory was not found",
                     source=source, field="robot.model", value=str(candidates[0]))
