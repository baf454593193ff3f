"""Entry point of the rigid-body robot plugin (light: names classes as strings)."""

from pliant.api import hookimpl


@hookimpl
def pliant_register(registrar):
    """Register the ``rigid`` robot (a free-flying rigid body)."""
    registrar.add("robot", "rigid", "pliant_rigid.body:RigidBody",
                  description="free-flying rigid body (r3 / se2 / se3) sampled as voxel-centre points")
