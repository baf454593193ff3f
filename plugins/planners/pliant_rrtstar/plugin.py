"""Entry point of the RRT* plugin (the planner is imported only when created)."""

from pliant.api import hookimpl


@hookimpl
def pliant_register(registrar):
    """Register the ``rrtstar`` planner."""
    registrar.add("planner", "rrtstar", "pliant_rrtstar.planner:RRTStarPlanner",
                  description="RRT* (Karaman & Frazzoli 2011): choose-parent and rewiring over the path integral of "
                              "the state cost, task-space goals, puncture and cut detection (thesis 4.3.4)")
