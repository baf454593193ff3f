"""Free-flying rigid bodies (R^3 translation, SE(2), SE(3)) built from scene shapes."""
