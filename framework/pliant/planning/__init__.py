"""The planning layer: the machinery sampling planners share, so that each planner plugin keeps only its algorithm.

- :mod:`pliant.planning.tree`: a growing tree of configurations with batched nearest-neighbour queries;
- :mod:`pliant.planning.clustering`: particle clustering into beliefs (thesis 5.3.3; the belief planner and the
  path metric's reachability check of 6.7);
- :mod:`pliant.planning.shortcut`: cost-aware shortcutting of a path.
"""
