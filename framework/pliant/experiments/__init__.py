"""The experiment layer: many seeded tasks, where they run, and what they leave behind.

- :mod:`pliant.experiments.runs`: resumable experiments (settings checks, ``runs.jsonl``, :func:`run_tasks`);
- :mod:`pliant.experiments.executor`: where tasks run: a local process pool or a Ray cluster;
- :mod:`pliant.experiments.ompl`: results in OMPL's benchmark log and database formats;
- :mod:`pliant.experiments.benchfile`: ``pliant bench FILE.toml``, planners x problems x seeds x budgets from a file;
- :mod:`pliant.experiments.reproduce`: ``pliant experiment``, every thesis table by one command.
"""
