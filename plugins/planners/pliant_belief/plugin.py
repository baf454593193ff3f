"""Entry point of the belief-space planner plugin (thesis ch. 5); heavy modules load when a planner is created."""

from pliant.hookspecs import hookimpl


@hookimpl
def pliant_register(registrar):
    registrar.add("planner", "belief", "pliant_belief.planner:BeliefPlanner",
                  description="belief-space RRT over particles with partial policies (thesis 5.3); "
                              "mode=contact / simple: the Contact RRT and Simple RRT baselines")
