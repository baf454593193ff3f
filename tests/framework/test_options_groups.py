"""Option groups (nested options dataclasses), old flat spellings, and the help texts of every registered plugin."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import pytest
from pliant.errors import ConfigError
from pliant.interfaces import KINDS
from pliant.options import (
    OptionDeprecationWarning,
    build_options,
    describe_options,
    group,
    option,
    option_groups,
    options_dict,
)
from pliant.registry import default_registry

#: the most characters of an option's help text: what it does and its unit; figures and stories go to the docs
HELP_LIMIT = 200


@dataclass(frozen=True)
class Inner:
    share: float = option(0.75, "share of the budget (fraction)", minimum=0.0, maximum=1.0)
    depth: int = option(4, "most pushes", minimum=0)

    def validate(self):
        if self.depth > 100:
            raise ConfigError("too deep", field="depth", value=self.depth)


@dataclass(frozen=True)
class Outer:
    steps: int = option(3, "steps", minimum=1)
    improvement: Inner = group(Inner, "the improvement phase")  # noqa: RUF009 (a default_factory field)


def test_a_group_is_set_from_a_nested_table_or_dotted_keys():
    assert build_options(Outer, {"improvement": {"share": 0.5}}) == Outer(improvement=Inner(share=0.5))
    assert build_options(Outer, {"improvement.share": "0.5", "improvement.depth": "2"}) == \
        Outer(improvement=Inner(share=0.5, depth=2))
    assert build_options(Outer, {"improvement": Inner(depth=1)}).improvement == Inner(depth=1)
    assert build_options(Outer, {}) == Outer()


def test_the_later_setting_wins_whatever_the_spelling():
    # a file's table, then a command line's dotted key (pliant run --set planner.improvement.share=0.5)
    o = build_options(Outer, {"improvement": {"share": 0.25, "depth": 2}, "improvement.share": 0.5})
    assert o.improvement == Inner(share=0.5, depth=2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OptionDeprecationWarning)
        assert build_options(Outer, {"improvement": {"share": 0.25}, "share": 0.5}).improvement.share == 0.5
        assert build_options(Outer, {"share": 0.25, "improvement.share": 0.5}).improvement.share == 0.5


def test_an_old_flat_name_works_with_one_warning_naming_the_new_spelling():
    with pytest.warns(OptionDeprecationWarning) as warned:
        o = build_options(Outer, {"share": 0.5}, source="p.toml", prefix="planner")
    assert o.improvement.share == 0.5
    assert [str(w.message) for w in warned] == ["option 'planner.share' is deprecated: use 'planner.improvement.share'"]
    assert warned[0].filename == "p.toml"


@dataclass(frozen=True)
class WithDeprecated:
    table_friction: float | None = option(None, "old friction", minimum=0.0, deprecated="set the scene's friction")
    gain: float = option(1.0, "gain")


def test_a_deprecated_option_still_works_with_one_warning_saying_what_replaces_it():
    with pytest.warns(OptionDeprecationWarning) as warned:
        o = build_options(WithDeprecated, {"table_friction": 0.5, "gain": 2.0}, source="p.toml", prefix="simulator")
    assert (o.table_friction, o.gain) == (0.5, 2.0)
    assert [str(w.message) for w in warned] == [
        "option 'simulator.table_friction' is deprecated: set the scene's friction"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert build_options(WithDeprecated, {"gain": 2.0}).table_friction is None     # not given: no warning


@pytest.mark.parametrize(("values", "field", "text"), [
    ({"improvement.share": 2}, "planner.improvement.share", "<= 1.0"),
    ({"improvement": {"depth": "x"}}, "planner.improvement.depth", "integer"),
    ({"improvement.colour": 1}, "planner.improvement.colour", "unknown option"),
    ({"improvement": 3}, "planner.improvement", "table"),
    ({"improvement.depth": 1000}, "planner.improvement.depth", "too deep"),
    ({"nothing.share": 1}, "planner.nothing.share", "no option group"),
    ({"colour": 1}, "planner.colour", "unknown option"),
])
def test_bad_grouped_options_name_the_full_dotted_field(values, field, text):
    with pytest.raises(ConfigError) as info:
        build_options(Outer, values, source="p.toml", prefix="planner")
    assert f"p.toml:{field}:" in str(info.value) and text in str(info.value)


def test_describe_and_dict_flatten_and_nest_the_groups():
    rows = {r["name"]: r for r in describe_options(Outer)}
    assert set(rows) == {"steps", "improvement.share", "improvement.depth"}
    assert rows["improvement.share"]["maximum"] == 1.0
    assert option_groups(Outer) == {"improvement": Inner}
    assert options_dict(Outer()) == {"steps": 3, "improvement": {"share": 0.75, "depth": 4}}
    assert build_options(Outer, options_dict(Outer(steps=5))) == Outer(steps=5)


def _registered_options():
    registry = default_registry()
    for kind in KINDS:
        for name in registry.available(kind):
            cls = registry.entry(kind, name).load()
            options = getattr(cls, "Options", None)
            if options is not None:
                yield f"{kind} {name}", options


def test_every_registered_option_has_a_short_help_text():
    """Every option of every registered plugin (groups included) says what it does and its unit in at most
    ``HELP_LIMIT`` characters; measured figures and tuning stories belong on the plugin's docs page."""
    checked, bad = 0, []
    for who, options in _registered_options():
        for row in describe_options(options):
            checked += 1
            doc = row["doc"].strip()
            if not doc or len(doc) > HELP_LIMIT:
                bad.append(f"{who}: {row['name']} ({len(doc)} characters)")
    assert checked > 300
    assert not bad, "help texts empty or longer than 200 characters:\n" + "\n".join(bad)


def test_tsrrt_options_are_grouped():
    from pliant_tsrrt.options import TSRRTOptions

    assert set(option_groups(TSRRTOptions)) == {"push", "cost", "planning", "improvement", "execution", "learning"}
    rows = [r["name"] for r in describe_options(TSRRTOptions)]
    assert len(rows) >= 63 and sum("." not in name for name in rows) <= 10      # the problem and the budgets


def test_a_tsrrt_plan_saved_with_flat_options_still_loads_without_a_warning():
    from pliant_tsrrt.planner import options_from_dict

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        o = options_from_dict({"placement_noise": 0.004, "refine_share": 0.5, "max_time": 2.0, "gone": 1})
    assert o.push.placement_noise == 0.004 and o.improvement.refine_share == 0.5 and o.max_time == 2.0
    assert options_from_dict(options_dict(o)) == o
