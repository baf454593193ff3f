"""Entry point of the T-RRT plugin (the planners are imported only when created)."""

from pliant.hookspecs import hookimpl


@hookimpl
def pliant_register(registrar):
    registrar.add("planner", "trrt", "pliant_trrt.planner:TRRTPlanner",
                  description="T-RRT (Jaillet, Cortes, Simeon 2010): transition test with adaptive temperature")
    registrar.add("planner", "gradient-trrt", "pliant_trrt.planner:GradientTRRTPlanner",
                  description="GradienT-RRT (Berenson, Simeon, Srinivasa 2011): rejected extensions follow the "
                              "cost gradient (thesis eq. 3.2)")
