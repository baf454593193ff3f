"""Controllers: the contact motion controller of thesis app. C."""
