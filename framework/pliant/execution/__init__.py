"""The execution layer: what every execution world (a simulator or a robot) shares.

- :mod:`pliant.execution.loop`: executing a path with a controller step by step, and its record (thesis 5.4, app. C);
- :mod:`pliant.execution.actuation`: the actuator model (which tangent directions rotate, velocity limits);
- :mod:`pliant.execution.noise`: actuation noise models (thesis 5.4.1-5.4.2, eq. 6.14-6.15);
- :mod:`pliant.execution.stepping`: shared machinery of dynamic simulator backends.

Commands to real robots also pass :mod:`pliant.hardware` (limits, the safety layer, ruckig smoothing).
"""
