"""A 2-D dynamic simulator backend for planar scenes, through pymunk (Chipmunk2D)."""
