"""Entry point: registers the ``path-length`` metric.  Light on purpose: the class is named as a string."""

from pliant.api import hookimpl


@hookimpl
def pliant_register(registrar):
    registrar.add("metric", "path-length", "pliant_example.metric:PathLength",
                  description="length, largest step and waypoint count of a path (example plugin)")
