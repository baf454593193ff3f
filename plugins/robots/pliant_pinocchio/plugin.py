from pliant.hookspecs import hookimpl


@hookimpl
def pliant_register(registrar):
    """Registers nothing yet."""
