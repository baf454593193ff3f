"""The geometry layer: what the world is made of, independent of any robot or algorithm.

- :mod:`pliant.geometry.rotations`: quaternions, rotations and poses (batched);
- :mod:`pliant.geometry.shapes`: solid shapes of objects and robot parts, with batched point-membership tests;
- :mod:`pliant.geometry.voxelgrid`: a scene's voxelised environment (thesis 3.2.1);
- :mod:`pliant.geometry.topology`: topology of voxel objects, puncture and cut detection (thesis 4.3.4);
- :mod:`pliant.geometry.tetmesh`: tetrahedral meshes of boxes and their volumes (soft bodies, appendix A).
"""
