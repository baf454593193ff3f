"""Entry point of the voxel deformation-cost plugin."""

from pliant.api import hookimpl


@hookimpl
def pliant_register(registrar):
    """Register the ``voxel`` cost (deformation over a voxel model, with its gradient)."""
    registrar.add("cost", "voxel", "pliant_voxel.cost:VoxelDeformationCost",
                  description="cost of deformation over a voxel model (thesis eq. 3.1), with gradient (eq. 3.2)")
