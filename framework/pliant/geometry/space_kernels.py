"""numba kernel of SE(2)'s distance (:meth:`pliant.spaces.SE2Space.distance`), the most frequent call of a planner
in the plane: every nearest-neighbour scan of a tree and every edge asks it, and the numpy formulation spent most
of its time in seven array operations' overhead and temporaries.

It performs the numpy formulation's floating-point operations in the same order (the angle wrapped as
``(d + pi) % (2 pi) - pi`` with Python's and numpy's modulo, the squares as products), so the distances are
equal bit for bit (``tests/framework/test_spaces.py``).
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def se2_distances(a, b, translation_squared, rotation, out):
    """``out[i]`` (m): the SE(2) distance between ``a[i]`` and ``b[i]`` (``(n, 3)`` or ``(1, 3)`` each, a single row
    broadcast), ``sqrt(translation_squared (dx^2 + dy^2) + (rotation dtheta)^2)`` with ``dtheta`` wrapped to
    ``[-pi, pi)``."""
    one_a, one_b = a.shape[0] == 1, b.shape[0] == 1
    two_pi = 2 * np.pi
    for i in range(out.shape[0]):
        ia = 0 if one_a else i
        ib = 0 if one_b else i
        dx = a[ia, 0] - b[ib, 0]
        dy = a[ia, 1] - b[ib, 1]
        dth = (a[ia, 2] - b[ib, 2] + np.pi) % two_pi - np.pi
        turn = rotation * dth
        out[i] = np.sqrt(translation_squared * (dx * dx + dy * dy) + turn * turn)
