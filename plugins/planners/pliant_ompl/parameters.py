"""An OMPL planner's declared parameters: read, checked and set by name.

OMPL planners declare their parameters (``Planner::params()``, e.g. RRTConnect's ``range`` and
``intermediate_states``); the Python bindings do not expose the parameter set itself, but ``printSettings()``
lists every declared parameter with its value and each has a setter and a getter.  A parameter is checked against
that list (an unknown name is an error naming the declared ones), converted to the getter's type (bool, int or
float; a value of another type is an error), set, and read back from ``printSettings()`` -- a value OMPL did not take
is an error too.  Every error names the field (``planner.parameters.<name>``) and the value.
"""

from __future__ import annotations

import math

from pliant.api import ConfigError

#: declared names whose setters the bindings spell differently (name -> setter suffixes tried in order)
ALIASES = {
    "delay_rewiring_to_first_solution": ("DelayRewiringUntilInitialSolution",),
    "drop_unconnected_samples_on_prune": ("DropSamplesOnPrune",),
    "find_approximate_solutions": ("ConsiderApproximateSolutions",),
    "prune_threshold_as_fractional_cost_change": ("PruneThresholdFraction",),
    "stop_on_each_solution_improvement": ("StopOnSolnImprovement",),
    "use_graph_pruning": ("Pruning",),
    "use_just_in_time_sampling": ("JustInTimeSampling",),
    "use_strict_queue_ordering": ("StrictQueueOrdering",),
    "delay_collision_checking": ("DelayCC",),
    "number_sampling_attempts": ("NumSamplingAttempts",),
    "ordering_batch_size": ("BatchSize",),
    "use_k_nearest": ("UseKNearest", "KNearest", "NearestK"),
    "failed_expansion_score_factor": ("FailedExpansionCellScoreFactor",),
    "use_admissible_heuristic": ("AdmissibleCostToCome",),
}


def declared(planner) -> dict[str, str]:
    """The planner's declared parameters and their current values, as OMPL prints them."""
    out = {}
    for line in planner.printSettings().splitlines()[1:]:
        name, sep, value = line.partition(" = ")
        if sep:
            out[name.strip()] = value.strip()
    return out


def _accessor(planner, prefix: str, name: str):
    methods = {m.lower(): m for m in dir(planner) if m.startswith(prefix)}
    for suffix in (name.replace("_", ""), *ALIASES.get(name, ())):
        found = methods.get((prefix + suffix).lower())
        if found is not None:
            return getattr(planner, found)
    return None


def _convert(value, kind: type, field: str):
    if isinstance(value, str):          # from the command line (--set planner.parameters.range=0.05)
        text = value.strip().lower()
        if text in ("true", "false"):
            value = text == "true"
        else:
            try:
                value = int(text) if text.lstrip("+-").isdigit() else float(text)
            except ValueError:
                pass
    if kind is bool:
        if isinstance(value, bool) or (isinstance(value, int) and value in (0, 1)):
            return bool(value)
        raise ConfigError("must be true or false", field=field, value=value)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigError(f"must be a finite {'integer' if kind is int else 'number'}", field=field, value=value)
    if kind is int:
        if not float(value).is_integer() or value < 0:
            raise ConfigError("must be a non-negative integer", field=field, value=value)
        return int(value)
    return float(value)


def _same(printed: str, value) -> bool:
    try:
        shown = float(printed)
    except ValueError:
        return False
    return math.isclose(shown, float(value), rel_tol=1e-5, abs_tol=1e-9)


def apply(planner, parameters: dict, algorithm: str) -> dict[str, str]:
    """Set ``parameters`` on ``planner`` (after its ``setup``); returns the declared parameters as set."""
    known = declared(planner)
    for name, value in parameters.items():
        field = f"planner.parameters.{name}"
        if name not in known:
            names = ", ".join(sorted(known)) or "none"
            raise ConfigError(f"OMPL's {algorithm} declares no such parameter (it declares: {names})", field=field,
                              value=value)
        setter, getter = _accessor(planner, "set", name), _accessor(planner, "get", name)
        if setter is None:
            raise ConfigError(f"OMPL's {algorithm} declares this parameter, but its Python bindings have no setter "
                              "for it", field=field, value=value)
        current = getter() if getter is not None else None
        kind = bool if isinstance(current, bool) else int if isinstance(current, int) else float
        converted = _convert(value, kind, field)
        try:
            setter(converted)
        except (TypeError, ValueError, RuntimeError) as exc:
            raise ConfigError(f"OMPL's {algorithm} refused it: {exc}", field=field, value=value) from None
        after = declared(planner).get(name)
        if after is None or not _same(after, converted):
            raise ConfigError(f"OMPL's {algorithm} did not take it (it reads back {after})", field=field, value=value)
    return declared(planner)
