"""OMPL's geometric planners as pliant planners (the ``ompl`` wheel's Python bindings; docs/plugins/ompl.md)."""
