"""pytest plugin of pliant (registered through the ``pytest11`` entry point).

Fixtures:

``pliant_conformance``
    The :mod:`pliant.testing` module, so a test can call ``pliant_conformance.check_component(...)``.
``pliant_rng``
    A seeded ``numpy.random.Generator`` (seed 0), for reproducible tests.
"""

from __future__ import annotations

import pytest


@pytest.fixture
def pliant_conformance():
    """The :mod:`pliant.testing` module (the conformance kit)."""
    import pliant.testing

    return pliant.testing


@pytest.fixture
def pliant_rng():
    """A ``numpy.random.Generator`` seeded with 0."""
    import numpy as np

    return np.random.default_rng(0)
