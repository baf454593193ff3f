"""The voxel deformation model: the cost of deformation of thesis ch. 3 (eq. 3.1, 3.2)."""
