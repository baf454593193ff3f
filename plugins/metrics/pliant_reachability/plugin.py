"""Entry point of the reachable-volume path-quality metrics (thesis ch. 6)."""

from pliant.hookspecs import hookimpl

_MODULE = "pliant_reachability.metrics"


@hookimpl
def pliant_register(registrar):
    registrar.add("metric", "reachable-volume", f"{_MODULE}:ReachableVolumeMetric",
                  description="P_exec of a path from reachable-volume sampling and sample images (thesis 6.4)")
    registrar.add("metric", "sampling-driven", f"{_MODULE}:SamplingDrivenMetric",
                  description="P_exec simulated only past the last reachable volume with a stuck sample (thesis 6.5)")
    registrar.add("metric", "simulation", f"{_MODULE}:SimulationMetric",
                  description="P_exec from many kinematic-simulator executions (thesis 6.5's Simulation baseline)")
    registrar.add("metric", "simulation-scaled", f"{_MODULE}:ScaledSimulationMetric",
                  description="P_exec from as many executions as the largest reachable volume has samples (6.5)")
