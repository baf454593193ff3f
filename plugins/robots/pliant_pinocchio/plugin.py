"""Entry point of the pinocchio robot plugin (light: pinocchio and coal load only when a robot is created)."""

from pliant.api import hookimpl


@hookimpl
def pliant_register(registrar):
    """Register the ``pinocchio`` robot (URDF robots through pinocchio and coal)."""
    registrar.add("robot", "pinocchio", "pliant_pinocchio.robot:PinocchioRobot",
                  description="URDF robots (pr2, baxter, iiwa or a file) via pinocchio + coal: FK, point Jacobians")
