"""pliant.files: atomic writes, strict JSON, logs that survive a torn last line."""

from __future__ import annotations

import json
import math
import os

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pliant.errors import ConfigError
from pliant.files import (
    append_jsonl,
    dumps,
    read_json,
    read_jsonl,
    rewrite_jsonl,
    strict,
    write_json,
    write_text,
)


def test_strict_json_has_no_bare_nan_and_reads_back_with_any_json_reader():
    data = {"cost": float("nan"), "inf": np.inf, "arr": np.array([1.0, np.nan]), "n": np.int64(3),
            "flag": np.bool_(True), 4: "key"}
    text = dumps(data)
    assert "NaN" not in text and "Infinity" not in text
    assert json.loads(text) == {"cost": None, "inf": None, "arr": [1.0, None], "n": 3, "flag": True, "4": "key"}


@settings(max_examples=200)
@given(st.recursive(st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=5),
                    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=4), inner,
                                                                                 max_size=4), max_leaves=20))
def test_strict_keeps_finite_data_and_nulls_only_the_non_finite(data):
    out = json.loads(dumps(data))

    def same(a, b):
        if isinstance(a, float) and not math.isfinite(a):
            return b is None
        if isinstance(a, dict):
            return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
        if isinstance(a, list):
            return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
        return a == b

    assert same(data, out) and strict(out) == out


def test_an_atomic_write_replaces_whole_or_not_at_all(tmp_path, monkeypatch):
    target = tmp_path / "deep" / "result.json"
    write_json(target, {"a": 1})
    assert json.loads(target.read_text()) == {"a": 1}

    def fail(*args):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", fail)
    with pytest.raises(OSError, match="disk full"):
        write_text(target, "x" * 1000)
    assert json.loads(target.read_text()) == {"a": 1}                   # the old file, intact
    assert [p.name for p in target.parent.iterdir()] == ["result.json"]  # no temporary left behind


def test_a_log_reads_back_what_was_appended_and_skips_only_a_torn_last_line(tmp_path):
    log = tmp_path / "runs.jsonl"
    assert read_jsonl(log) == ([], False)
    with log.open("a") as sink:
        for k in range(3):
            append_jsonl(sink, {"k": k, "x": float("nan")})
    assert read_jsonl(log) == ([{"k": 0, "x": None}, {"k": 1, "x": None}, {"k": 2, "x": None}], False)
    with log.open("a") as sink:
        sink.write('{"k": 3, "x"')                                      # the crash
    records, torn = read_jsonl(log)
    assert torn and [r["k"] for r in records] == [0, 1, 2]
    rewrite_jsonl(log, records)
    assert read_jsonl(log) == (records, False)
    log.write_text('{"k": 0}\n{"k": \n{"k": 2}\n')
    with pytest.raises(ConfigError, match="line 2: line 2 is not JSON"):
        read_jsonl(log)


def test_read_json_reads_what_write_json_wrote(tmp_path):
    data = {"a": [1.5, None, "x"], "b": {"c": True}}
    assert read_json(write_json(tmp_path / "d.json", data)) == data
    assert read_json(write_json(tmp_path / "l.json", [1, 2]), expect=list) == [1, 2]


@settings(max_examples=60, deadline=None)
@given(st.integers(min_value=0, max_value=10_000))
def test_a_json_file_cut_anywhere_is_one_error_naming_the_file_and_line(tmp_path_factory, cut):
    path = tmp_path_factory.mktemp("cut") / "result.json"
    text = dumps({"status": "solved", "path": {"configurations": [[0.25, 1.0, 2.0]] * 40}, "note": "a b c"},
                 indent=1)
    path.write_text(text[:cut % len(text)])
    with pytest.raises(ConfigError) as caught:
        read_json(path)
    message = str(caught.value)
    assert message.startswith(f"{path}:") and "\n" not in message and "cut off" in message


@pytest.mark.parametrize("content, expected", [
    (b"\xff\xfe\x00garbage", "not UTF-8"), (b"{\"a\": 1} trailing", "Extra data"), (b"[1, 2]", "an object"),
    (b"\"text\"", "an object"), (b"[" * 100_000, "nested too deeply|cut off"), (b"{\"a\": NaN", "cut off")])
def test_a_damaged_or_wrong_kind_of_json_file_is_one_config_error(tmp_path, content, expected):
    path = tmp_path / "f.json"
    path.write_bytes(content)
    with pytest.raises(ConfigError, match=expected) as caught:
        read_json(path)
    assert str(caught.value).startswith(str(path)) and "\n" not in str(caught.value).strip()


def test_read_json_of_a_directory_or_missing_file_names_it(tmp_path):
    for path in (tmp_path, tmp_path / "missing.json"):
        with pytest.raises(ConfigError, match="cannot be read"):
            read_json(path)


def test_a_path_name_must_name_something():
    from pliant.files import check_path_name

    assert check_path_name("out", "--output") == "out" and check_path_name(".", "--output") == "."
    for bad in ("", "   ", "a\x00b", None, 5):
        with pytest.raises(ConfigError, match=r"^--output: must"):
            check_path_name(bad, "--output")
