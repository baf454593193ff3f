"""T-RRT and GradienT-RRT: sampling-based planning over a cost space (thesis 3.2.4, 3.3.3)."""
