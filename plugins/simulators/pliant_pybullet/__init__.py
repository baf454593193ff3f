"""A 3-D dynamic simulator backend through pybullet (Bullet physics), headless by default."""
