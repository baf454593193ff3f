"""The conformance kit: check a component against its interface contract.

Use it from any test suite (also a third-party plugin's)::

    from pliant.testing import check_component
    def test_my_planner_conforms():
        check_component("planner", "mine")

or through the pytest plugin (installed with pliant, entry point ``pytest11``), whose
``pliant_conformance`` fixture exposes the same checks.  Each check asserts shapes, dtypes, clear
errors on bad input (a :class:`~pliant.errors.PliantError`) and determinism under a seed.
"""

from pliant.testing.conformance import (
    CHECKED_KINDS,
    ConformanceFailure,
    build_context,
    check_component,
    check_cost,
    check_driver,
    check_learner,
    check_metric,
    check_planner,
    check_robot,
    check_space,
)

__all__ = ["CHECKED_KINDS", "ConformanceFailure", "build_context", "check_component", "check_cost", "check_driver",
           "check_learner", "check_metric", "check_planner", "check_robot", "check_space"]
