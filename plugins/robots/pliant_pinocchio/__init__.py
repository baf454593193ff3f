"""URDF robots through pinocchio and coal: PR2 and Baxter (example-robot-data), the KUKA LBR iiwa (pybullet_data)."""
