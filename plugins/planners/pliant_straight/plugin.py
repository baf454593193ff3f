"""Entry point of the straight-line planner plugin."""

from pliant.api import hookimpl


@hookimpl
def pliant_register(registrar):
    """Register the ``straight`` (straight-line) and ``waypoints`` (a given motion) planners."""
    registrar.add("planner", "straight", "pliant_straight.planner:StraightLinePlanner",
                  description="straight-line interpolation with validity checking (a baseline)")
    registrar.add("planner", "waypoints", "pliant_straight.planner:WaypointPlanner",
                  description="a given motion: start, waypoints, goal (validity-checked, not searched)")
