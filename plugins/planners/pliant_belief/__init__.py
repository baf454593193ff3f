"""Planning with actuation uncertainty: belief-space RRT, particle clustering and partial policies (thesis ch. 5)."""
