"""The straight-line planner: interpolate from start to goal and check every step."""
