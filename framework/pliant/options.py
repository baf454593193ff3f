"""Options dataclasses: building them from untrusted dictionaries with clear errors.

Every component declares one ``Options`` dataclass (DESIGN rule 4).  Each field carries its
documentation in ``metadata``: ``doc`` (what it is, with units), and optionally ``minimum`` /
``maximum`` (inclusive range) and ``choices``.  :func:`build_options` turns a dict from a pipeline
file, the command line or Python keyword arguments into an instance, converting and checking types
and ranges and rejecting unknown names.

A large option set is split into *groups*: a field declared with :func:`group` holds another options
dataclass, set from a nested table (``[planner.improvement] refine_share = 0.5``) or a dotted key
(``--set planner.improvement.refine_share=0.5``); errors name the full dotted field.  An option that moved
into a group keeps working under its old flat name (``refine_share = 0.5``), with one
:class:`OptionDeprecationWarning` line naming the new spelling.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
import warnings
from typing import Any

from pliant.errors import ConfigError


@dataclasses.dataclass(frozen=True)
class NoOptions:
    """Options of a component that takes none."""


def option(default: Any, doc: str, *, minimum: float | None = None, maximum: float | None = None,
           choices: tuple | None = None, default_factory=None, deprecated: str | None = None) -> Any:
    """A documented dataclass field for an ``Options`` class (``doc`` states units).

    ``deprecated``: what replaces the option (e.g. "set the scene's [physics.support] friction"); setting it still
    works, with one :class:`OptionDeprecationWarning` line ``option 'NAME' is deprecated: <deprecated>``."""
    meta = {"doc": doc, "minimum": minimum, "maximum": maximum, "choices": choices, "deprecated": deprecated}
    if default_factory is not None:
        return dataclasses.field(default_factory=default_factory, metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


class OptionDeprecationWarning(FutureWarning):
    """An option was set under an old spelling (shown to users by default; one line naming the new one)."""


def group(options_cls: type, doc: str) -> Any:
    """A dataclass field holding a group of options (another options dataclass; ``doc``: what it groups).

    Set from a nested table or dotted keys; its defaults are ``options_cls()``'s."""
    return dataclasses.field(default_factory=options_cls, metadata={"doc": doc, "group": True})


def option_groups(options_cls: type) -> dict[str, type]:
    """The group fields of ``options_cls`` (those holding another options dataclass), by name."""
    hints = typing.get_type_hints(options_cls)
    return {f.name: hints[f.name] for f in dataclasses.fields(options_cls)
            if dataclasses.is_dataclass(hints.get(f.name)) and isinstance(hints.get(f.name), type)}


def describe_options(options_cls: type, prefix: str = "") -> list[dict]:
    """One row per option (a group's options as ``group.name``): name, type, default, doc, range; for
    ``pliant plugins --options`` and docs."""
    rows = []
    hints = typing.get_type_hints(options_cls)
    groups = option_groups(options_cls)
    for f in dataclasses.fields(options_cls):
        if f.name in groups:
            rows += describe_options(groups[f.name], prefix=f"{prefix}{f.name}.")
            continue
        default = f.default if f.default is not dataclasses.MISSING else (
            f.default_factory() if f.default_factory is not dataclasses.MISSING else None)
        rows.append({"name": prefix + f.name, "type": _type_name(hints.get(f.name)), "default": default,
                     "doc": f.metadata.get("doc", ""), "minimum": f.metadata.get("minimum"),
                     "maximum": f.metadata.get("maximum"), "choices": f.metadata.get("choices")})
    return rows


def options_dict(options: Any) -> dict[str, Any]:
    """An options instance as a plain dict (groups as nested dicts; tuples as lists): what a result records and
    what :func:`build_options` reads back."""
    out = {}
    for f in dataclasses.fields(options):
        value = getattr(options, f.name)
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            value = options_dict(value)
        elif isinstance(value, tuple):
            value = list(value)
        out[f.name] = value
    return out


def _moved_name(options_cls: type, name: str) -> str | None:
    """The dotted spelling of an option ``name`` that moved into a group of ``options_cls`` (one group only)."""
    found = []
    for group_name, group_cls in option_groups(options_cls).items():
        if name in {f.name for f in dataclasses.fields(group_cls)} and name not in option_groups(group_cls):
            found.append(f"{group_name}.{name}")
        deeper = _moved_name(group_cls, name)
        if deeper is not None:
            found.append(f"{group_name}.{deeper}")
    return found[0] if len(found) == 1 else None


def _set_path(tree: dict, path: list[str], value: Any) -> None:
    for part in path[:-1]:
        sub = tree.get(part)
        if not isinstance(sub, dict):
            sub = {}
            tree[part] = sub
        tree = sub
    tree[path[-1]] = value


def _group_values(options_cls: type, values: dict[str, Any], *, source: str, prefix: str) -> dict[str, Any]:
    """``values`` with dotted keys, old flat spellings and nested tables of groups merged into one nested dict per
    group (in the order given: a later setting of the same option wins)."""
    groups = option_groups(options_cls)
    if not groups:
        return values
    names = {f.name for f in dataclasses.fields(options_cls)}
    out: dict[str, Any] = {}
    for key, raw in values.items():
        key = str(key)
        path = key.split(".")
        if path[0] not in names and len(path) == 1:
            moved = _moved_name(options_cls, key)
            if moved is not None:
                here = f"{prefix}." if prefix else ""
                # reported at the file that used the old name, on one line (no source line to quote)
                warnings.warn_explicit(f"option '{here}{key}' is deprecated: use '{here}{moved}'",
                                       OptionDeprecationWarning, filename=source or "<options>", lineno=0)
                path = moved.split(".")
        if path[0] in groups:
            sub = out.get(path[0])
            if not isinstance(sub, dict):
                sub = {}
                out[path[0]] = sub
            if len(path) > 1:
                _set_path(sub, path[1:], raw)
            elif isinstance(raw, dict):
                sub.update(raw)
            elif dataclasses.is_dataclass(raw) and not isinstance(raw, type):
                sub.update({f.name: getattr(raw, f.name) for f in dataclasses.fields(raw)})
            else:
                raise ConfigError("must be a table of options", source=source,
                                  field=f"{prefix}.{path[0]}" if prefix else path[0], value=raw)
        elif len(path) > 1:
            known = ", ".join(sorted(groups)) or "none"
            raise ConfigError(f"names no option group (groups: {known})", source=source,
                              field=f"{prefix}.{key}" if prefix else key, value=raw)
        else:
            out[key] = raw
    return out


def build_options(options_cls: type, values: dict[str, Any] | None, *, source: str = "<options>",
                  prefix: str = "") -> Any:
    """An ``options_cls`` instance from ``values``; raises :class:`ConfigError` naming the field.

    Strings from the command line (``"5"``, ``"true"``, ``"0.5,0.2"``) are converted to the declared
    type.  After construction the instance's ``validate()`` (if any) runs for cross-field checks.
    """
    if isinstance(values, options_cls):
        return values
    values = dict(values or {})
    names = {f.name: f for f in dataclasses.fields(options_cls)}
    hints = typing.get_type_hints(options_cls)
    groups = option_groups(options_cls)
    values = _group_values(options_cls, values, source=source, prefix=prefix)
    kwargs = {}
    for key, raw in values.items():
        field_name = f"{prefix}.{key}" if prefix else key
        if key not in names:
            known = ", ".join(sorted(names)) or "none"
            raise ConfigError(f"unknown option (known options: {known})", source=source, field=field_name, value=raw)
        if key in groups:
            kwargs[key] = build_options(groups[key], raw, source=source, prefix=field_name)
            continue
        f = names[key]
        value = _convert(raw, hints[key], source, field_name)
        meta = f.metadata
        if meta.get("deprecated") and value is not None:
            warnings.warn_explicit(f"option '{field_name}' is deprecated: {meta['deprecated']}",
                                   OptionDeprecationWarning, filename=source or "<options>", lineno=0)
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            if meta.get("minimum") is not None and value < meta["minimum"]:
                raise ConfigError(f"must be >= {meta['minimum']}", source=source, field=field_name, value=raw)
            if meta.get("maximum") is not None and value > meta["maximum"]:
                raise ConfigError(f"must be <= {meta['maximum']}", source=source, field=field_name, value=raw)
        if meta.get("choices") is not None and value not in meta["choices"]:
            raise ConfigError(f"must be one of {', '.join(map(str, meta['choices']))}", source=source,
                              field=field_name, value=raw)
        kwargs[key] = value
    try:
        instance = options_cls(**kwargs)
    except TypeError as exc:
        raise ConfigError(f"cannot build options: {exc}", source=source, field=prefix or "<options>") from None
    validate = getattr(instance, "validate", None)
    if callable(validate):
        try:
            validate()
        except ConfigError as exc:
            raise ConfigError(exc.message, source=source,
                              field=f"{prefix}.{exc.field}" if prefix and exc.field else (exc.field or prefix),
                              **({"value": exc.value} if exc.has_value else {})) from None
    return instance


def _type_name(tp) -> str:
    if tp is None:
        return "any"
    return getattr(tp, "__name__", str(tp)).replace("typing.", "")


def _convert(raw: Any, tp: Any, source: str, field: str) -> Any:
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    if origin in (typing.Union, types.UnionType):
        if raw is None and type(None) in args:
            return None
        if isinstance(raw, str) and raw.lower() in ("none", "null") and type(None) in args:
            return None
        errors = []
        for arg in args:
            if arg is type(None):
                continue
            try:
                return _convert(raw, arg, source, field)
            except ConfigError as exc:
                errors.append(exc)
        raise errors[0]
    if tp is typing.Any:
        return raw
    if tp is bool:
        if isinstance(raw, bool):
            return raw
        if isinstance(raw, str) and raw.lower() in ("true", "false", "yes", "no", "1", "0"):
            return raw.lower() in ("true", "yes", "1")
        raise ConfigError("must be true or false", source=source, field=field, value=raw)
    if tp is int:
        if isinstance(raw, str):
            try:
                raw = int(raw)
            except ValueError:
                raise ConfigError("must be an integer", source=source, field=field, value=raw) from None
        if isinstance(raw, bool) or not isinstance(raw, int):
            if isinstance(raw, float) and raw.is_integer():
                return int(raw)
            raise ConfigError("must be an integer", source=source, field=field, value=raw)
        return raw
    if tp is float:
        if isinstance(raw, str):
            try:
                raw = float(raw)
            except ValueError:
                raise ConfigError("must be a number", source=source, field=field, value=raw) from None
        if isinstance(raw, bool) or not isinstance(raw, (int, float)):
            raise ConfigError("must be a number", source=source, field=field, value=raw)
        if not math.isfinite(raw):
            raise ConfigError("must be finite", source=source, field=field, value=raw)
        return float(raw)
    if tp is str:
        if not isinstance(raw, str):
            raise ConfigError("must be a string", source=source, field=field, value=raw)
        return raw
    if origin in (tuple, list):
        if isinstance(raw, str):
            raw = [p for p in raw.replace("[", "").replace("]", "").split(",") if p.strip()]
        if not isinstance(raw, (list, tuple)):
            raise ConfigError("must be a list", source=source, field=field, value=raw)
        item = args[0] if args else typing.Any
        converted = [_convert(v.strip() if isinstance(v, str) else v, item, source, f"{field}[{i}]")
                     for i, v in enumerate(raw)]
        return tuple(converted) if origin is tuple else converted
    if origin is dict or tp is dict:
        if not isinstance(raw, dict):
            raise ConfigError("must be a table", source=source, field=field, value=raw)
        return dict(raw)
    return raw
