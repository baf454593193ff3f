"""The core's argument checks, under their first name: kept so that existing code keeps importing from here.

The checks now live with the kind they guard (:mod:`pliant.components.planner`, :mod:`~pliant.components.simulator`,
:mod:`~pliant.components.controller`, :mod:`~pliant.components.metric`) and in :mod:`pliant.components.checks`.
"""

from __future__ import annotations

from pliant.components.checks import WRAPPED, check_duration, check_rng, check_vector, space_label
from pliant.components.controller import checked_command
from pliant.components.metric import checked_evaluate
from pliant.components.planner import check_planner, checked_plan, validated_result
from pliant.components.simulator import check_starts, checked_reset, checked_simulate, checked_step

__all__ = [
    "WRAPPED", "check_duration", "check_planner", "check_rng", "check_starts", "check_vector", "checked_command",
    "checked_evaluate", "checked_plan", "checked_reset", "checked_simulate", "checked_step", "space_label",
    "validated_result",
]
