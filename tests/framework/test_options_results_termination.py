"""Options conversion, result round trips and termination rules."""

from __future__ import annotations

import math
import signal
from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from pliant.errors import ConfigError
from pliant.options import build_options, describe_options, option
from pliant.results import Path, PlanResult, Status
from pliant.termination import Termination


@dataclass(frozen=True)
class Opts:
    step: float = option(0.1, "step (m)", minimum=0.0)
    count: int = option(3, "count", minimum=1)
    mode: str = option("a", "mode", choices=("a", "b"))
    flag: bool = option(False, "flag")
    weights: tuple[float, ...] = option((), "weights")
    limit: float | None = option(None, "optional limit (s)")

    def validate(self):
        if self.count > 100:
            raise ConfigError("too many", field="count", value=self.count)


def test_strings_from_the_command_line_convert():
    o = build_options(Opts, {"step": "0.5", "count": "7", "flag": "true", "weights": "1,2.5", "limit": "none"})
    assert o == Opts(step=0.5, count=7, flag=True, weights=(1.0, 2.5), limit=None)


@pytest.mark.parametrize(("values", "field", "text"), [
    ({"step": -1}, "planner.step", ">= 0.0"),
    ({"count": 0.5}, "planner.count", "integer"),
    ({"mode": "c"}, "planner.mode", "one of a, b"),
    ({"flag": "maybe"}, "planner.flag", "true or false"),
    ({"step": float("nan")}, "planner.step", "finite"),
    ({"colour": 1}, "planner.colour", "unknown option"),
    ({"count": 1000}, "planner.count", "too many"),
])
def test_bad_options_name_the_field(values, field, text):
    with pytest.raises(ConfigError) as info:
        build_options(Opts, values, source="p.toml", prefix="planner")
    assert f"p.toml:{field}:" in str(info.value) and text in str(info.value)


def test_describe_options_lists_docs():
    rows = {r["name"]: r for r in describe_options(Opts)}
    assert rows["step"]["doc"] == "step (m)" and rows["step"]["minimum"] == 0.0


@given(arrays(np.float64, st.tuples(st.integers(1, 6), st.integers(1, 7)),
              elements=st.floats(-1e6, 1e6, allow_nan=False)),
       st.floats(allow_nan=True, allow_infinity=False), st.sampled_from(list(Status)))
def test_result_round_trip(tmp_path_factory, configs, cost, status):
    result = PlanResult(status, path=Path(configs, space_kind="rn"), cost=cost, seed=3, planner="x",
                        statistics={"iterations": 5, "history": np.array([[0.0, 1.0]]), "ratio": np.float64(0.5)})
    path = tmp_path_factory.mktemp("r") / "result.json"
    result.save(path)
    loaded = PlanResult.load(path)
    assert loaded.status is status and loaded.seed == 3
    assert np.array_equal(loaded.path.configurations, configs)
    assert (math.isnan(loaded.cost) and math.isnan(cost)) or loaded.cost == cost
    assert loaded.statistics["history"] == [[0.0, 1.0]]


def test_unknown_status_is_an_error():
    with pytest.raises(ConfigError, match="status"):
        PlanResult.from_dict({"status": "victorious"})


def test_termination_rules():
    t = Termination(max_iterations=10)
    t.start()
    assert not t.should_stop(9) and t.should_stop(10)
    t = Termination(max_time=0.0)
    t.start()
    assert t.should_stop(0)
    t = Termination(callback=lambda i, c: c < 1.0)
    t.start()
    assert not t.should_stop(0, 2.0) and t.should_stop(1, 0.5)
    t = Termination(stop_on_first=True)
    t.start()
    assert t.should_stop(0, solved=True) and not t.should_stop(0)


def test_ctrl_c_sets_interrupted_inside_watch(python_sigint):
    t = Termination()
    with t.watch():
        signal.raise_signal(signal.SIGINT)
        assert t.interrupted and t.should_stop(0)
    with pytest.raises(KeyboardInterrupt):   # the previous handler is restored afterwards
        signal.raise_signal(signal.SIGINT)
