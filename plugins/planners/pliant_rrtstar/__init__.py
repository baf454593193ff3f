"""RRT*: asymptotically optimal sampling-based planning over a cost space (Karaman & Frazzoli 2011;
thesis 3.2.4, 4.3.4)."""
