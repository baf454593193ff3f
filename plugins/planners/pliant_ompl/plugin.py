"""Entry point of the OMPL plugin (OMPL is imported only when the planner is created)."""

from pliant.api import hookimpl


@hookimpl
def pliant_register(registrar):
    """Register the ``ompl`` planner (any OMPL geometric planner by name)."""
    registrar.add("planner", "ompl", "pliant_ompl.planner:OMPLPlanner",
                  description="any OMPL geometric planner by name (RRTConnect, BITstar, InformedRRTstar, KPIECE1, "
                              "FMT, ...) with pliant's validity, cost objective, seed and work budget")
