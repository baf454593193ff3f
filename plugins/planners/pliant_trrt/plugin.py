"""Entry point of the T-RRT plugin (the planners are imported only when created)."""

from pliant.api import hookimpl


@hookimpl
def pliant_register(registrar):
    """Register the ``trrt`` and ``gradient-trrt`` planners."""
    registrar.add("planner", "trrt", "pliant_trrt.planner:TRRTPlanner",
                  description="T-RRT (Jaillet, Cortes, Simeon 2010): transition test with adaptive temperature")
    registrar.add("planner", "gradient-trrt", "pliant_trrt.planner:GradientTRRTPlanner",
                  description="GradienT-RRT (Berenson, Simeon, Srinivasa 2011): rejected extensions follow the "
                              "cost gradient (thesis eq. 3.2)")


@hookimpl
def pliant_reproductions():
    """The thesis's Table 3.1 (``pliant experiment table-3.1``): T-RRT and GradienT-RRT on the cube-wall."""
    from pliant.api import Reproduction

    return [Reproduction("table-3.1", "Table 3.1: T-RRT and GradienT-RRT on the cube-wall",
                         "pliant_trrt.reproduce:table_31",
                         modes={"full": "30 runs per planner and nFailMax (10, 20), 1200 s budget, as the thesis",
                                "quick": "4 runs per planner and nFailMax (10, 20)",
                                "ci": "2 runs per planner at nFailMax 10"},
                         minutes={"full": 60, "quick": 1, "ci": 0.3})]
