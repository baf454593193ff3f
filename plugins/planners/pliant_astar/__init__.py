"""A* over 3-D translations with the deformation-aware objective of thesis Algorithm 1, and Pareto sweeps."""
