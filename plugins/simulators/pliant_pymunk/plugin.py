"""Entry point of the pymunk backend (pymunk is imported only when the simulator is created)."""

from pliant.api import hookimpl


@hookimpl
def pliant_register(registrar):
    """Register the ``pymunk`` simulator (2-D rigid-body dynamics)."""
    registrar.add("simulator", "pymunk", "pliant_pymunk.simulator:PymunkSimulator",
                  description="2-D rigid-body dynamics (pymunk) for planar scenes: compliant control, friction")
