"""The learner components ``piirl`` and ``active-piirl`` (thesis ch. 4).

``piirl``: ``fit(demonstrations)`` improves each demonstration with the local optimiser, draws sample paths
around it and the straight insertions of its task (:mod:`pliant_piirl.alternatives`), reads every path's
per-object deformation and recovers the sensitivities (:mod:`pliant_piirl.piirl`: by default a ranking of each
demonstration against its samples and those alternatives; eq. 4.1 and the PIIRL likelihood are options).

``active-piirl``: ``fit(None)`` runs the whole loop unattended: Algorithm 2 chooses the object pairs, Algorithm 3
generates a task for each, the simulated expert (who alone reads the scene's sensitivities, as the ground truth)
demonstrates it, and ``piirl`` recovers the sensitivities from the demonstrations collected.  Algorithm 2 reads a
demonstration's preference as the chapter does ("the preferentially deformed object receives a lower ranking"):
of the pair, the object the demonstration deformed more than the straight insertion along the funnel's axis
would have is the less sensitive.
``fit(demonstrations)`` skips the asking and learns from the given ones.

Both need a rigid robot with a tip (``tip``, body frame, m): the probe of the ``hollow-cube`` scene by default.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np
from pliant.api import ConfigError, Learner, option

from pliant_piirl.alternatives import straight_alternatives
from pliant_piirl.demonstration import Demonstration, check_demonstrations, load_demonstrations
from pliant_piirl.expert import ExpertOptions, SimulatedExpert, funnel_frame
from pliant_piirl.piirl import RecoveryOptions, recover
from pliant_piirl.sampling import PathSampler, SampleOptions
from pliant_piirl.tasks import TaskOptions, TaskSpace, rotation_onto


def _merged(name: str, doc: str, *parts: type, extra: list | None = None) -> type:
    fields, seen = [], set()
    for part in parts:
        for f in dataclasses.fields(part):
            if f.name not in seen:
                seen.add(f.name)
                fields.append((f.name, f.type, dataclasses.field(default=f.default, metadata=f.metadata)))
    def validate(self) -> None:
        # the parts' cross-field checks (e.g. RecoveryOptions: lower <= initial <= upper), on the merged options
        for part in parts:
            check = getattr(part, "validate", None)
            if check is not None:
                check(_part(self, part))

    cls = dataclasses.make_dataclass(name, (extra or []) + fields, frozen=True, namespace={"validate": validate})
    cls.__doc__ = doc
    cls.__module__ = __name__
    return cls


def _part(options, cls: type):
    return cls(**{f.name: getattr(options, f.name) for f in dataclasses.fields(cls)})


_TIP = [("tip", tuple[float, float, float],
         option((0.0, 0.0, -0.06), "the robot point that must touch the target, in the body frame (m)")),
        ("demonstrations", str | None,
         option(None, "a demonstrations file to learn from when fit() is given no data (pipelines)"))]

PiirlOptions = _merged("PiirlOptions", "Options of the ``piirl`` learner: samples (sampling), the recovery.",
                       SampleOptions, RecoveryOptions, extra=_TIP)
ActivePiirlOptions = _merged(
    "ActivePiirlOptions", "Options of the ``active-piirl`` learner: those of ``piirl``, task generation and the "
    "simulated expert (the funnel openings are also the expert's search range).",
    SampleOptions, RecoveryOptions, TaskOptions, ExpertOptions, extra=_TIP + [
        ("max_demonstrations", int | None, option(None, "most demonstrations to ask for (default: every pair)",
                                                  minimum=1))])


class PiirlLearner(Learner):
    """PIIRL sensitivity recovery (thesis 4.3.1 and 4.3.3) from demonstrations in the bound scene.

    ``fit(data, rng)``: ``data`` is a list of :class:`Demonstration` or a demonstrations file.  Returns
    ``sensitivities`` ``{object: S}`` (dimensionless, within [lower, upper]: only ratios are meaningful),
    ``objective``, ``used`` (demonstrations that carried information), ``replaced`` (local optimiser
    replacements per demonstration), ``demonstrations`` (the improved ones, as dicts of the file format) and
    ``features`` (their per-object deformation).  Wall times of the last fit are in :attr:`timing` (s):
    ``seconds`` (all of it), ``samples_seconds`` (local optimiser, sample paths, alternatives and their features)
    and ``recovery_seconds`` (the recovery's solve).
    """

    Options = PiirlOptions
    example_scene = "hollow-cube"
    example_options = {"samples": 10, "rounds": 1}
    example_data = staticmethod(lambda: example_demonstrations())

    def bind(self, context) -> None:
        super().bind(context)
        from pliant_piirl.features import DeformationFeatures

        self.scene = self.require("scene")
        if self.require("robot").rigid_placement(self.scene.start[None]) is None:
            raise ConfigError("PIIRL's sample paths need a rigid robot with a tip", field="robot",
                              value=self.scene.robot.kind)
        reach = float(np.linalg.norm(np.asarray(self.scene.upper) - np.asarray(self.scene.lower)))
        if np.linalg.norm(self.options.tip) > reach:
            # the body and a tip on a target could not both lie in the workspace (and a sample moved to put such a
            # tip on its target would leave it by that much)
            raise ConfigError(f"the tip lies farther from the body frame's origin than the workspace's diagonal "
                              f"({reach:.4g} m)", field="learner.tip", value=list(self.options.tip))
        self.features = DeformationFeatures(self.scene)
        self.sampler = PathSampler(self.features, self.options.tip, _part(self.options, SampleOptions))
        # the funnel openings and insertion length the alternatives span: the simulated expert's (its options, where
        # the learner has them)
        self.funnel = ExpertOptions(**{f.name: getattr(self.options, f.name) for f in dataclasses.fields(ExpertOptions)
                                       if hasattr(self.options, f.name)})

    def fit(self, data, rng: np.random.Generator) -> dict:
        """See the class docstring; ``data`` None reads the ``demonstrations`` option's file."""
        started = time.perf_counter()
        demonstrations = self._demonstrations(data)
        improved, replaced, demo_features, sample_features, alternatives = [], [], [], [], []
        # only the ranking compares with alternatives: for the other objectives they would be drawn for nothing
        o = self.options
        grid = o.alternatives if o.objective == "ranking" and o.alternative_weight > 0 else 0
        for demonstration in demonstrations:
            # the local optimiser's last round drew its samples around the demonstration it returns: they are the
            # fit's samples (a fresh draw only when it stopped otherwise), so each path is measured once
            better, count, mine, drawn_features = self.sampler.improve_with_samples(demonstration, rng)
            if drawn_features is None:
                _, drawn_features = self.sampler.draw_with_features(better, rng)
            improved.append(better)
            replaced.append(count)
            demo_features.append(mine)
            sample_features.append(drawn_features)
            alternatives.append(straight_alternatives(self.sampler, demonstration, grid, self.funnel))
        fitted_at = time.perf_counter()
        result = recover(np.array(demo_features).reshape(len(demonstrations), -1), sample_features,
                         _part(self.options, RecoveryOptions), rng, alternatives)
        names = self.features.names
        self.timing = {"seconds": time.perf_counter() - started, "samples_seconds": fitted_at - started,
                       "recovery_seconds": time.perf_counter() - fitted_at}
        return {"sensitivities": dict(zip(names, map(float, result["sensitivities"]))),
                "objective": result["objective"], "used": result["used"], "iterations": result["iterations"],
                "message": result["message"], "temperatures": result["temperatures"], "replaced": replaced,
                "demonstrations": [d.to_dict() for d in improved],
                "features": {"names": names, "demonstrations": np.array(demo_features).tolist()}}

    def _demonstrations(self, data) -> list[Demonstration]:
        """The demonstrations to learn from (a list, or a file), checked against the scene and the robot's space
        (:func:`~pliant_piirl.demonstration.check_demonstrations`) before anything is computed from them."""
        source, field_name = None, "learner.data"
        if data is None and self.options.demonstrations is not None:
            data, field_name = self.options.demonstrations, "learner.demonstrations"
        if isinstance(data, (str, bytes)) or hasattr(data, "__fspath__"):
            source, field_name = str(data), "demonstrations"
            scene, data = load_demonstrations(data, dim=len(self.scene.start))
            if scene != self.scene.name:
                raise ConfigError(f"the demonstrations were shown in scene {scene!r}, not {self.scene.name!r}",
                                  source=source, field="scene", value=scene)
        if not isinstance(data, (list, tuple)) or not data or not all(isinstance(d, Demonstration) for d in data):
            raise ConfigError("must be a non-empty list of demonstrations or a demonstrations file",
                              source=source, field=field_name, value=type(data).__name__)
        return check_demonstrations(data, self.scene, self.require("robot").space, source=source,
                                    field_name=field_name)


def example_demonstrations(pairs=(("L1", "M1"), ("M1", "H1")), seed: int = 0) -> list[Demonstration]:
    """Two simulated-expert demonstrations in ``hollow-cube`` (coarse search): the conformance kit's data."""
    from pliant import api

    from pliant_piirl.features import DeformationFeatures, true_sensitivities

    scene = api.load_scene("hollow-cube")
    features = DeformationFeatures(scene)
    tip = np.array([0.0, 0.0, -0.06])
    expert = SimulatedExpert(features, true_sensitivities(scene), tip, ExpertOptions(grid=7, refine=1))
    tasks = TaskSpace(scene)
    rng = np.random.default_rng(seed)
    return [expert.demonstrate(tasks.generate_task(a, b, rng, tip, rotation_onto), rng) for a, b in pairs]


class ActivePiirlLearner(PiirlLearner):
    """The whole ch. 4 loop, unattended: Algorithm 2 + Algorithm 3 + the simulated expert + PIIRL.

    ``fit(None, rng)`` returns what ``piirl`` returns plus ``asked`` (the object pairs, in order), ``preferences``
    (``[less, more]`` sensitive per demonstration, or None), ``ranking`` (least sensitive first) and
    ``demonstrations_asked``.
    """

    Options = ActivePiirlOptions
    example_options = {"samples": 10, "rounds": 1, "grid": 7, "refine": 1}

    def bind(self, context) -> None:
        super().bind(context)
        from pliant_piirl.features import true_sensitivities

        self.tasks = TaskSpace(self.scene, _part(self.options, TaskOptions))
        expert_options = _part(self.options, ExpertOptions)
        self.expert = SimulatedExpert(self.features, true_sensitivities(self.scene), self.options.tip, expert_options)

    def fit(self, data, rng: np.random.Generator) -> dict:
        if data is not None or self.options.demonstrations is not None:
            return super().fit(data, rng)
        from pliant_piirl.active import collect_demonstrations

        started = time.perf_counter()
        shown: list[Demonstration] = []

        def collect(first: str, second: str) -> dict[str, float]:
            # "preferentially deformed": deformed more than the straight insertion along the funnel's axis would
            task = self.tasks.generate_task(first, second, rng, np.asarray(self.options.tip), rotation_onto)
            demonstration = self.expert.demonstrate(task, rng)
            shown.append(demonstration)
            neutral = self.expert.path(task, (0.0, 0.0), funnel_frame(task))
            change = self.features.of_path(demonstration.path) - self.features.of_path(neutral)
            return dict(zip(self.features.names, change))

        asked = collect_demonstrations(self.tasks.adjacency(), collect, rng, self.options.max_demonstrations)
        result = super().fit(shown, rng)
        result.update({"asked": [list(p) for p in asked.asked],
                       "preferences": [list(p) if p else None for p in asked.preferences],
                       "ranking": asked.graph.ranking(), "demonstrations_asked": len(shown)})
        self.timing["seconds"] = time.perf_counter() - started
        return result
