"""Entry point of the pybullet backend (pybullet is imported only when the simulator is created)."""

from pliant.api import hookimpl


@hookimpl
def pliant_register(registrar):
    """Register the ``pybullet`` simulator (3-D rigid-body dynamics, headless)."""
    registrar.add("simulator", "pybullet", "pliant_pybullet.simulator:PybulletSimulator",
                  description="3-D rigid-body dynamics (pybullet, headless): compliant force-limited control")
