"""pliant's spaces as OMPL state spaces, and configurations to and from OMPL states.

* R^n (a point robot's positions, a URDF robot's joints): ``RealVectorStateSpace`` over the *weighted*
  coordinates ``w * q`` (bounds ``w * lower``, ``w * upper``), so OMPL's Euclidean distance is exactly pliant's
  ``|| w * (a - b) ||``;
* SE(2): ``SE2StateSpace`` with pliant's translation and rotation weights as subspace weights;
* SE(3): ``SE3StateSpace``, the SO(3) weight doubled because OMPL's SO(3) distance is ``acos |<q1, q2>|`` (half
  the rotation angle) while pliant's is the angle.

OMPL's compound distance is the weighted *sum* of the parts' distances where pliant's is the root of the sum of
squares: the same for pure translations and pure rotations, up to sqrt(2) larger for mixed SE(2)/SE(3) motions.
The metric only steers OMPL's search; validity, cost and the result are pliant's.
"""

from __future__ import annotations

import numpy as np
from pliant.api import ConfigError

#: the pliant space kinds this module maps
KINDS = ("rn", "se2", "se3")


class OMPLSpace:
    """One pliant space and its OMPL counterpart; :meth:`state` / :meth:`configuration` convert."""

    def __init__(self, space) -> None:
        from ompl import base as ob

        self.space = space
        self.kind = space.kind
        if self.kind == "rn":
            self.scale = np.asarray(space.weights, dtype=np.float64)
            self.ompl = ob.RealVectorStateSpace(space.dim)
            bounds = ob.RealVectorBounds(space.dim)
            for i in range(space.dim):
                bounds.setLow(i, float(space.lower[i] * self.scale[i]))
                bounds.setHigh(i, float(space.upper[i] * self.scale[i]))
            self.ompl.setBounds(bounds)
        elif self.kind in ("se2", "se3"):
            n = 2 if self.kind == "se2" else 3
            self.ompl = ob.SE2StateSpace() if n == 2 else ob.SE3StateSpace()
            bounds = ob.RealVectorBounds(n)
            for i in range(n):
                bounds.setLow(i, float(space.lower[i]))
                bounds.setHigh(i, float(space.upper[i]))
            self.ompl.setBounds(bounds)
            self.ompl.setSubspaceWeight(0, float(space.translation_weight))
            self.ompl.setSubspaceWeight(1, float(space.rotation_weight) * (1.0 if n == 2 else 2.0))
        else:
            raise ConfigError(f"the ompl planner plans in {', '.join(KINDS)} spaces; this robot's space is "
                              f"{self.kind}", field="planner", value=self.kind)
        self.dim = space.dim

    def configuration(self, s) -> np.ndarray:
        """The pliant configuration ``(d,)`` of an OMPL state."""
        if self.kind == "rn":
            return np.array([s[i] for i in range(self.dim)], dtype=np.float64) / self.scale
        if self.kind == "se2":
            return np.array([s.getX(), s.getY(), s.getYaw()], dtype=np.float64)
        r = s.rotation()
        return np.array([s.getX(), s.getY(), s.getZ(), r.x, r.y, r.z, r.w], dtype=np.float64)

    def write(self, q: np.ndarray, s) -> None:
        """Set the OMPL state ``s`` to the pliant configuration ``q``."""
        q = np.asarray(q, dtype=np.float64)
        if self.kind == "rn":
            w = q * self.scale
            for i in range(self.dim):
                s[i] = float(w[i])
        elif self.kind == "se2":
            s.setXY(float(q[0]), float(q[1]))
            s.setYaw(float(q[2]))
        else:
            s.setXYZ(float(q[0]), float(q[1]), float(q[2]))
            r = s.rotation()
            r.x, r.y, r.z, r.w = (float(v) for v in q[3:7])

    def state(self, q: np.ndarray):
        """A new OMPL state holding ``q`` (owned by the OMPL space)."""
        s = self.ompl.allocState()
        self.write(q, s)
        return s
