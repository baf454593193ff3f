"""Random streams per stage (DESIGN rule 12): one :class:`numpy.random.SeedSequence` per run, split into independent
streams for learning, planning, metrics, execution and each experiment task.

A run's seed (the pipeline's ``seed``) is the entropy of one ``SeedSequence``; every stage draws from its own child,
named by a fixed spawn key, never by the order in which stages ask::

    streams = Streams(seed)
    learner.fit(data, streams.rng("learning"))            # SeedSequence(seed, spawn_key=(0,))
    planner.plan(problem, streams.rng("planning"))         # SeedSequence(seed, spawn_key=(1,))
    metric.evaluate(path, problem, streams.rng("metrics"))  # (2,)
    execute(..., streams.rng("execution"))                  # (3,)
    streams.rng("task", 7, 2)                               # experiment task 7, plan 2: (4, 7, 2)

``SeedSequence(seed, spawn_key=(k,))`` is exactly the ``k``-th child of ``SeedSequence(seed).spawn(...)``, so the
streams are statistically independent (numpy's guarantee for spawned sequences), and because the keys are fixed,
adding or removing a stage -- a metric, a learner -- changes no other stage's numbers.  A key may hold strings
(``streams.rng("task", "clearance", 3)``): a string becomes a stable 32-bit number (CRC-32 of its UTF-8 bytes).

:meth:`Streams.layout` is what a result records (``result.json``: ``streams: {"planning": [seed, 1], ...}``, the
entropy followed by the spawn key): enough to rebuild any stage's generator with :func:`stream_from_layout`.

Code that takes an integer seed rather than a Generator gets one from :func:`derived_seed` (the first 32-bit word of
the stream's state), never from a hand-picked offset such as ``10_000 + seed``.
"""

from __future__ import annotations

import zlib
from collections.abc import Sequence

import numpy as np

from pliant.errors import ConfigError

#: the fixed spawn key of each stage of a run (new stages take new numbers; existing ones never change)
STAGES: dict[str, int] = {"learning": 0, "planning": 1, "metrics": 2, "execution": 3, "task": 4}

Key = int | str


def _key_part(part: Key) -> int:
    if isinstance(part, (bool, np.bool_)):
        raise ConfigError("a stream key is an integer or a string", field="seeds.key", value=part)
    if isinstance(part, (int, np.integer)):
        if part < 0:
            raise ConfigError("a stream key must be >= 0", field="seeds.key", value=part)
        return int(part)
    if isinstance(part, str):
        return zlib.crc32(part.encode("utf-8"))
    raise ConfigError("a stream key is an integer or a string", field="seeds.key", value=part)


def _check_seed(seed) -> int:
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ConfigError("must be a non-negative integer", field="seed", value=seed)
    return int(seed)


def spawn_key(stage: str, *key: Key) -> tuple[int, ...]:
    """The spawn key of ``stage`` (a name of :data:`STAGES`) and its sub-key: ``("task", 7, 2)`` -> ``(4, 7, 2)``."""
    if stage not in STAGES:
        raise ConfigError(f"not a stream (streams: {', '.join(STAGES)})", field="seeds.stage", value=stage)
    return (STAGES[stage], *(_key_part(k) for k in key))


def sequence(seed: int, stage: str, *key: Key) -> np.random.SeedSequence:
    """The :class:`~numpy.random.SeedSequence` of ``stage`` (and sub-key) of the run seeded ``seed``."""
    return np.random.SeedSequence(_check_seed(seed), spawn_key=spawn_key(stage, *key))


def stream(seed: int, stage: str, *key: Key) -> np.random.Generator:
    """A fresh Generator on the stream of ``stage`` (and sub-key) of the run seeded ``seed``."""
    return np.random.default_rng(sequence(seed, stage, *key))


def derived_seed(seed: int, stage: str, *key: Key) -> int:
    """A 32-bit integer seed from the stream of ``stage`` (and sub-key), for code that takes an int seed."""
    return int(sequence(seed, stage, *key).generate_state(1, dtype=np.uint32)[0])


def stream_from_layout(entry: Sequence[int]) -> np.random.Generator:
    """The Generator a recorded layout entry (``[seed, *spawn_key]``, :meth:`Streams.layout`) describes."""
    entry = [int(x) for x in entry]
    if not entry:
        raise ConfigError("a layout entry is [seed, *spawn_key]", field="streams", value=entry)
    return np.random.default_rng(np.random.SeedSequence(_check_seed(entry[0]), spawn_key=tuple(entry[1:])))


class Streams:
    """The random streams of one run seeded ``seed``: :meth:`rng` hands out a fresh Generator per stage (and
    sub-key) and remembers which were handed out, for :meth:`layout`."""

    def __init__(self, seed: int) -> None:
        self.seed = _check_seed(seed)
        self._used: dict[str, tuple[int, ...]] = {}

    def sequence(self, stage: str, *key: Key) -> np.random.SeedSequence:
        """The ``SeedSequence`` of ``stage`` and sub-key."""
        keys = spawn_key(stage, *key)
        self._used[".".join([stage, *map(str, key)])] = keys
        return np.random.SeedSequence(self.seed, spawn_key=keys)

    def rng(self, stage: str, *key: Key) -> np.random.Generator:
        """A fresh Generator on the stream of ``stage`` and sub-key (the same numbers every time it is asked)."""
        return np.random.default_rng(self.sequence(stage, *key))

    def derived_seed(self, stage: str, *key: Key) -> int:
        """An integer seed from the stream of ``stage`` and sub-key (:func:`derived_seed`)."""
        return int(self.sequence(stage, *key).generate_state(1, dtype=np.uint32)[0])

    def stages(self) -> dict[str, list[int]]:
        """The layout of a run's stages (learning, planning, metrics, execution), whether or not they ran: what
        ``result.json`` records as ``streams``."""
        return {name: [self.seed, key] for name, key in STAGES.items() if name != "task"}

    def layout(self) -> dict[str, list[int]]:
        """The streams handed out so far: ``{"planning": [seed, 1], "task.7.2": [seed, 4, 7, 2], ...}``."""
        return {name: [self.seed, *keys] for name, keys in self._used.items()}

    def __repr__(self) -> str:
        return f"Streams(seed={self.seed})"


__all__ = ["STAGES", "Streams", "derived_seed", "sequence", "spawn_key", "stream", "stream_from_layout"]
