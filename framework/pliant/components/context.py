"""What the components of one pipeline share (:class:`Context`), filled in dependency order by the pipeline.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from pliant.errors import (
    PlanningError,
)
from pliant.spaces import Space

if TYPE_CHECKING:
    from pliant.components.controller import Controller
    from pliant.components.cost import CostModel
    from pliant.components.robot import RobotModel
    from pliant.components.simulator import Simulator
    from pliant.scene import Scene


@dataclass
class Context:
    """What the components of one pipeline share; filled in dependency order by the pipeline.

    Order: scene -> robot -> cost -> simulator -> controller -> planner / metric / learner / driver.
    A component's :meth:`Component.bind` sees everything built before it.
    """

    scene: Scene | None = None
    robot: RobotModel | None = None
    cost: CostModel | None = None
    simulator: Simulator | None = None
    controller: Controller | None = None
    seed: int = 0
    extras: dict[str, Any] = field(default_factory=dict)

    @property
    def space(self) -> Space:
        if self.robot is None:
            raise PlanningError("this component needs a robot (and its configuration space) in the pipeline",
                                field="robot")
        return self.robot.space
