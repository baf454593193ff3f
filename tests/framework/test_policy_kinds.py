"""Policy.from_dict in a process that has not imported the planner yet: the policy kinds of every planner plugin
are loaded on demand, and an unknown kind names the known ones."""

from __future__ import annotations

import sys
import textwrap

import pytest
from pliant import registry
from pliant.errors import ConfigError
from pliant.results import Policy

MODULE = textwrap.dedent('''
    from pliant.interfaces import Planner
    from pliant.results import Policy


    class LatePolicy(Policy):
        kind = "late-policy"

        def __init__(self, steps):
            self.steps = steps

        def to_dict(self):
            return {"kind": self.kind, "steps": self.steps}

        @classmethod
        def from_dict(cls, data):
            return cls(data["steps"])


    class LatePlanner(Planner):
        def plan(self, problem, rng, termination=None):
            raise NotImplementedError
''')


def test_a_policy_kind_defined_by_a_planner_plugin_is_found_without_importing_it_first(tmp_path, monkeypatch):
    (tmp_path / "late_policy_plugin.py").write_text(MODULE)
    monkeypatch.syspath_prepend(str(tmp_path))
    registry.register("planner", "late", "late_policy_plugin:LatePlanner")
    try:
        assert "late_policy_plugin" not in sys.modules
        policy = Policy.from_dict({"kind": "late-policy", "steps": 3})
        assert type(policy).__name__ == "LatePolicy" and policy.steps == 3
    finally:
        registry.default_registry().unregister("planner", "late")
        Policy._kinds.pop("late-policy", None)
        sys.modules.pop("late_policy_plugin", None)


@pytest.mark.parametrize("data", [{"kind": "no-such-policy"}, {}, ["kind"]])
def test_an_unknown_policy_kind_is_a_config_error_naming_the_known_ones(data):
    with pytest.raises(ConfigError, match="policy") as info:
        Policy.from_dict(data)
    if isinstance(data, dict):
        assert "partial-policy" in str(info.value)
