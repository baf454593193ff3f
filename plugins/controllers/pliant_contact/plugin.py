"""Entry point of the controller plugin."""

from pliant.api import hookimpl


@hookimpl
def pliant_register(registrar):
    """Register the ``contact`` controller (P control with stuck detection and target adjustment)."""
    registrar.add("controller", "contact", "pliant_contact.controller:ContactMotionController",
                  description="P control with stuck detection and target adjustment (thesis app. C, eq. 8.6)")
