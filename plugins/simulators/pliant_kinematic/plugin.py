"""Entry point of the kinematic simulator plugin."""

from pliant.api import hookimpl


@hookimpl
def pliant_register(registrar):
    """Register the ``kinematic`` simulator (fast kinematic simulation with contact and compliance)."""
    registrar.add("simulator", "kinematic", "pliant_kinematic.simulator:KinematicSimulator",
                  description="fast kinematic simulation with contact and compliance, batched (thesis app. B)")
