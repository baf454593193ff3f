"""The warm-up before planning (pliant.planning.warmup): building a pipeline loads the core's compiled kernels, so
that a time budget does not pay for loading them."""

from __future__ import annotations

import subprocess
import sys

from pliant.planning.warmup import warm_up

#: in a fresh process (another test may have run the kernels in this one): build a pipeline, nothing else
PROBE = """
from pliant import Pipeline
from pliant.components import validity_kernels
from pliant.geometry import topology_kernels
Pipeline("cube-wall", planner="rrtstar").build()
print([len(k.signatures) for k in (validity_kernels.points_free, validity_kernels.clearances,
                                   topology_kernels.swept_cells)])
"""


def test_building_a_pipeline_loads_the_collision_checker_and_the_puncture_sweep_kernels():
    out = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, check=True).stdout
    assert out.strip().splitlines()[-1] == "[1, 1, 1]"


def test_a_pipeline_without_a_robot_warms_nothing():
    class Bare:
        scene = None
        robot = None
    assert warm_up(Bare()) == 0.0
