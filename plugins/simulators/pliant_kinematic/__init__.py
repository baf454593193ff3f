"""The fast kinematic simulator with contact and compliance (thesis app. B)."""
