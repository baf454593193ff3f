"""One pipeline file, three simulators: swapping by one name (issue 5, thesis 5.4).

The bundled pipelines ``maze-slide`` (SE(2)) and ``peg-slide`` (SE(3)) execute a scripted motion
with the contact controller; only ``simulator=NAME`` changes between runs.  pymunk is planar, so the
SE(3) pipeline must refuse it with the reason instead of approximating.
"""

from __future__ import annotations

import pytest
from pliant import Pipeline
from pliant.errors import SimulationError


@pytest.mark.parametrize("simulator", ["kinematic", "pybullet", "pymunk"])
def test_the_se2_maze_pipeline_runs_in_every_simulator(simulator, tmp_path):
    record = Pipeline.from_file("maze-slide", overrides=[f"simulator={simulator}", f'output="{tmp_path}"']).run()
    assert record.execution.success
    assert record.execution.configurations[-1, :2] == pytest.approx([0.75, 0.75], abs=0.1)   # the scene's goal
    assert (tmp_path / "report.md").is_file()


@pytest.mark.parametrize("simulator", ["kinematic", "pybullet"])
def test_the_se3_peg_pipeline_runs_in_every_3d_simulator(simulator, tmp_path):
    record = Pipeline.from_file("peg-slide", overrides=[f"simulator={simulator}", "simulator.noise=none",
                                                        f'output="{tmp_path}"']).run()
    assert record.execution.success and record.execution.configurations[-1, 2] == pytest.approx(0.625, abs=0.1)


def test_the_se3_pipeline_in_the_planar_simulator_is_refused_with_the_reason(tmp_path):
    with pytest.raises(SimulationError, match="planar"):
        Pipeline.from_file("peg-slide", overrides=["simulator=pymunk", f'output="{tmp_path}"']).run()
