"""The scene's and robot's collision checker, under its first name; it lives in :mod:`pliant.components.validity`
(the planning request, :class:`~pliant.components.problem.PlanningProblem`, carries one)."""

from __future__ import annotations

from pliant.components.validity import ValidityChecker, Verdict

__all__ = ["ValidityChecker", "Verdict"]
