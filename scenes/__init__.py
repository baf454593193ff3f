"""Bundled scenes and pipelines of pliant (data only; installed as the package ``pliant_scenes``)."""
