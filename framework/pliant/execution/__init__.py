"""The execution layer: what every execution world (a simulator or a robot) shares.

- :mod:`pliant.execution.loop`: the one execution loop (:func:`~pliant.execution.loop.follow`), which steps a world
  for a path, a policy or a plan alike (thesis 5.4, app. C);
- :mod:`pliant.execution.strategy`: what the loop follows -- a strategy's directives (place, drive, move, done) and
  the path's strategy;
- :mod:`pliant.execution.record`: the typed execution record and its outcome enum;
- :mod:`pliant.execution.actuation`: the actuator model (which tangent directions rotate, velocity limits);
- :mod:`pliant.execution.noise`: actuation noise models (thesis 5.4.1-5.4.2, eq. 6.14-6.15);
- :mod:`pliant.execution.stepping`: shared machinery of dynamic simulator backends.

Commands to real robots also pass :mod:`pliant.hardware` (limits, the safety layer, ruckig smoothing).
"""
