"""The report's trajectory figure (pliant_plots): drawn when the run has a trajectory, skipped when not."""

from __future__ import annotations

from types import SimpleNamespace

from pliant.api import time_parameterize
from pliant_plots.trajectory_figure import draw_trajectory


def test_trajectory_figure(tmp_path):
    trajectory = time_parameterize([[0.0, 0.0], [0.5, 0.2], [0.1, 0.4]], [1.0, 0.5], [2.0, 1.0])
    drawn = draw_trajectory(SimpleNamespace(trajectory=trajectory), tmp_path)
    assert drawn == [tmp_path / "trajectory.png"] and drawn[0].stat().st_size > 1000
    assert draw_trajectory(SimpleNamespace(trajectory=None), tmp_path) is None
    assert draw_trajectory(SimpleNamespace(), tmp_path) is None
