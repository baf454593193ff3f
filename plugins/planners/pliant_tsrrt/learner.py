"""The learner ``push-models``: LEARN_MODEL (poster ICHR 2010) for every object class of the scene, in the pipeline's
simulator, with a held-out test of the models; writes the models file the ``tsrrt`` planner reads.

``fit`` returns, per class: the pushes spent per primitive and, per primitive, the mean displacement and its
standard deviation (object frame: m, m, rad), and the held-out prediction errors (m, rad) and the share of held-out
displacements inside the models' 95 % intervals.  The models themselves stay on the component (``models``) for a
``tsrrt`` planner in the same pipeline (``models = "auto"``) and go to the ``output`` file when it is set.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pliant.api import Learner, PlanningError, option

from pliant_tsrrt import domain
from pliant_tsrrt.domain import PushOptions
from pliant_tsrrt.learning import learn_models
from pliant_tsrrt.options import LearningOptions
from pliant_tsrrt.pushing import PRIMITIVES


@dataclass(frozen=True)
class PushModelsOptions(PushOptions, LearningOptions):
    """Options of :class:`PushModelsLearner`: the objects, the table and the ``push`` group (shared with the
    ``tsrrt`` planner), LEARN_MODEL's stopping rule (the planner's ``learning`` group, here at the top level), the
    held-out test and the output file."""

    holdout: int = option(5, "held-out pushes per class and primitive to measure the prediction error", minimum=0)
    output: str = option("", "models file to write (JSON); empty: keep them in the pipeline only")

    def validate(self) -> None:
        """No cross-field check here: the learner lets ``max_pushes`` cap ``min_pushes`` (a quick run sets only
        ``max_pushes``); the planner's ``learning`` group refuses ``min_pushes > max_pushes``."""


class PushModelsLearner(Learner):
    """LEARN_MODEL per object class and primitive in the pipeline's simulator (poster ICHR 2010, "Model Learning")."""

    Options = PushModelsOptions
    example_scene = "tsrrt-table"
    example_components = {"simulator": "pymunk"}
    example_data = ("can-1",)

    def bind(self, context) -> None:
        """Attach to the pipeline; a scene whose objects are rotated out of the plane, off the table or overlapping
        at the start (:func:`pliant_tsrrt.domain.check_scene`) is refused here, before any push."""
        super().bind(context)
        self.models = None
        if context is not None and context.scene is not None:
            domain.movable_names(context.scene, self.options.objects)
            domain.check_scene(context.scene, self.options)
        domain.placing_simulator(getattr(context, "simulator", None), required=False)    # refused when built

    def fit(self, data, rng: np.random.Generator) -> dict:
        """Learn the models by pushing in the simulator.  ``data``: ``None`` (the pipeline's case: the classes of the
        ``objects`` option, default every movable object) or the names of the objects whose classes to learn; an
        empty list is an error."""
        from pliant_tsrrt.planner import arena

        o = self.options
        scene = self.require("scene")
        world = domain.placing_simulator(self.require("simulator"))
        if data is not None:
            if isinstance(data, str) or not isinstance(data, (list, tuple)) or not data:
                raise PlanningError("push-models learns from a non-empty list of movable object names (or None)",
                                    field="data", value=data)
            names = domain.movable_names(scene, tuple(data))
        else:
            names = domain.movable_names(scene, o.objects)
        models, report = learn_models(arena(world, scene, o), o, rng, holdout=o.holdout, only=names)
        self.models = models
        if o.output:
            models.save(o.output)
        out: dict = {}
        for cls, per in models.models.items():
            entry: dict = {"pushes": int(sum(d.n for d in per))}
            for p, d in zip(PRIMITIVES, per):
                entry[f"{p} n"] = d.n
                entry[f"{p} mean"] = d.mean.tolist()
                entry[f"{p} std"] = d.std.tolist()
            for p, row in report["holdout"].get(cls, {}).items():
                entry[f"{p} holdout translation error (m)"] = row["translation_error"]
                entry[f"{p} holdout rotation error (rad)"] = row["rotation_error"]
                entry[f"{p} holdout coverage95"] = row["coverage95"]
            out[cls] = entry
        if o.output:
            out["models_file"] = o.output
        return out
