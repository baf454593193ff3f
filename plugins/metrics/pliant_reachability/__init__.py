"""Path-quality metrics from reachable volumes (thesis ch. 6) and their simulation baselines."""
