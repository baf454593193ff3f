"""Reading untrusted dictionaries (parsed TOML, user dicts) with errors that name the field.

:class:`Fields` wraps one table of a file.  Each accessor checks type and range and raises a
:class:`~pliant.errors.ConfigError` (or the subclass given) naming ``source:field`` and the value.
:meth:`Fields.finish` rejects keys nobody read, so that typos never pass silently.
"""

from __future__ import annotations

import math
import os
import stat
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from pliant.errors import ConfigError

_MISSING = object()


class Fields:
    """Typed, validated access to the keys of one table.

    Parameters
    ----------
    data:
        The table (a mapping).  Anything else raises at construction.
    source:
        Where the table came from (file path or ``"<dict>"``), used in error messages.
    prefix:
        Dotted path of this table inside the file (``""`` at the top level).
    error:
        The :class:`ConfigError` subclass to raise.
    """

    def __init__(self, data: Any, source: str, prefix: str = "", error: type[ConfigError] = ConfigError) -> None:
        self.source = source
        self.prefix = prefix
        self.error = error
        if not isinstance(data, Mapping):
            raise error("must be a table", source=source, field=prefix or "<top>", value=data)
        self.data = data
        self._read: set[str] = set()

    def path(self, key: str | int) -> str:
        """The dotted path of ``key`` inside the file."""
        if isinstance(key, int):
            return f"{self.prefix}[{key}]"
        return f"{self.prefix}.{key}" if self.prefix else key

    def fail(self, key: str, message: str, value: Any = _MISSING):
        """Raise this reader's error for ``key``."""
        if value is _MISSING:
            raise self.error(message, source=self.source, field=self.path(key))
        raise self.error(message, source=self.source, field=self.path(key), value=value)

    def has(self, key: str) -> bool:
        return key in self.data

    def raw(self, key: str, default: Any = _MISSING) -> Any:
        """The value of ``key`` unchecked; missing and no default raises."""
        self._read.add(key)
        if key not in self.data:
            if default is _MISSING:
                self.fail(key, "is required but missing")
            return default
        return self.data[key]

    def table(self, key: str, default: Any = _MISSING) -> Fields:
        value = self.raw(key, {} if default is _MISSING else default)
        if key not in self.data and default is _MISSING:
            self.fail(key, "is required but missing")
        return Fields(value, self.source, self.path(key), self.error)

    def tables(self, key: str, required: bool = False) -> list[Fields]:
        """An array of tables (``[[key]]`` in TOML); missing gives ``[]`` unless ``required``."""
        value = self.raw(key, _MISSING if required else [])
        if not isinstance(value, list):
            self.fail(key, "must be an array of tables", value)
        return [Fields(v, self.source, f"{self.path(key)}[{i}]", self.error) for i, v in enumerate(value)]

    def string(self, key: str, default: Any = _MISSING, choices=None) -> str:
        value = self.raw(key, default)
        if value is default and default is not _MISSING:
            return value
        if not isinstance(value, str) or not value:
            self.fail(key, "must be a non-empty string", value)
        if choices is not None and value not in choices:
            self.fail(key, f"must be one of {', '.join(sorted(choices))}", value)
        return value

    def boolean(self, key: str, default: Any = _MISSING) -> bool:
        value = self.raw(key, default)
        if not isinstance(value, bool):
            self.fail(key, "must be true or false", value)
        return value

    def integer(self, key: str, default: Any = _MISSING, minimum: int | None = None) -> int:
        value = self.raw(key, default)
        if value is default and default is not _MISSING and value is None:
            return value
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            self.fail(key, "must be an integer", value)
        if minimum is not None and value < minimum:
            self.fail(key, f"must be >= {minimum}", value)
        return int(value)

    def number(self, key: str, default: Any = _MISSING, *, minimum: float | None = None,
               maximum: float | None = None, positive: bool = False, allow_nan: bool = False) -> float:
        value = self.raw(key, default)
        if value is default and default is not _MISSING and value is None:
            return value
        return check_number(value, self.source, self.path(key), minimum=minimum, maximum=maximum,
                            positive=positive, allow_nan=allow_nan, error=self.error)

    def vector(self, key: str, size: int | None = None, default: Any = _MISSING, *,
               allow_nan: bool = False, positive: bool = False) -> np.ndarray:
        value = self.raw(key, default)
        if value is default and default is not _MISSING and value is None:
            return value
        return check_vector(value, self.source, self.path(key), size=size, allow_nan=allow_nan,
                            positive=positive, error=self.error)

    def finish(self) -> None:
        """Raise for any key that no accessor read (an unknown or misspelt field)."""
        unknown = sorted(set(self.data) - self._read)
        if unknown:
            self.fail(unknown[0], "is not a known field here", self.data[unknown[0]])


def check_number(value: Any, source: str, field: str, *, minimum=None, maximum=None, positive=False,
                 allow_nan=False, error: type[ConfigError] = ConfigError) -> float:
    """``value`` as a float, or ``error`` naming ``source:field`` and the value."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise error("must be a number", source=source, field=field, value=value)
    v = float(value)
    if math.isnan(v):
        if allow_nan:
            return v
        raise error("must not be NaN", source=source, field=field, value=value)
    if math.isinf(v):
        raise error("must be finite", source=source, field=field, value=value)
    if positive and v <= 0:
        raise error("must be positive", source=source, field=field, value=value)
    if minimum is not None and v < minimum:
        raise error(f"must be >= {minimum}", source=source, field=field, value=value)
    if maximum is not None and v > maximum:
        raise error(f"must be <= {maximum}", source=source, field=field, value=value)
    return v


def check_vector(value: Any, source: str, field: str, *, size: int | None = None, allow_nan=False,
                 positive=False, error: type[ConfigError] = ConfigError) -> np.ndarray:
    """``value`` as a float64 ``(size,)`` array of finite numbers, or ``error`` naming the field."""
    if not isinstance(value, (list, tuple, np.ndarray)):
        raise error("must be a list of numbers", source=source, field=field, value=value)
    items = list(value)
    if size is not None and len(items) != size:
        raise error(f"must have {size} entries", source=source, field=field, value=value)
    if not items:
        raise error("must not be empty", source=source, field=field, value=value)
    for i, item in enumerate(items):
        check_number(item, source, f"{field}[{i}]", allow_nan=allow_nan, positive=positive, error=error)
    return np.asarray(items, dtype=np.float64)


#: the largest scene or pipeline file read (bytes); raise it with the environment variable PLIANT_MAX_TOML_BYTES
MAX_TOML_BYTES = 16 * 2**20


def size_limit(name: str, default: int) -> int:
    """The limit ``default``, or the integer in the environment variable ``name`` when set (documented per limit in
    docs/conventions.md, "Limits")."""
    text = os.environ.get(name)
    if text is None:
        return default
    try:
        value = int(text)
    except ValueError:
        raise ConfigError("must be an integer", field=name, value=text) from None
    if value <= 0:
        raise ConfigError("must be positive", field=name, value=text)
    return value


def check_regular_file(path: Path, *, max_bytes: int, limit_name: str, error: type[ConfigError] = ConfigError,
                       source: str | None = None, field: str = "<file>") -> Path:
    """``path`` if it is a regular file of at most ``max_bytes`` bytes, else ``error`` naming it: a directory, a
    FIFO (reading one would wait forever), a device or a missing file is refused before it is opened, and a file
    over the limit says which limit (``limit_name``, an environment variable) raises it."""
    path = Path(path)
    try:
        info = path.stat()
    except (OSError, ValueError) as exc:
        raise error(f"cannot read file: {getattr(exc, 'strerror', None) or exc}", source=source or str(path),
                    field=field, value=str(path)) from None
    if not stat.S_ISREG(info.st_mode):
        kind = "a directory" if stat.S_ISDIR(info.st_mode) else "not a regular file (a FIFO, socket or device)"
        raise error(f"is {kind}", source=source or str(path), field=field, value=str(path))
    if info.st_size > max_bytes:
        raise error(f"is {info.st_size:,} bytes, more than the limit of {max_bytes:,} (set {limit_name} to raise "
                    "it)", source=source or str(path), field=field, value=str(path))
    return path


def read_toml(path: Path, error: type[ConfigError] = ConfigError) -> dict:
    """Parse a TOML file; unreadable, oversized (:data:`MAX_TOML_BYTES`), non-regular or invalid files (including
    nesting deeper than Python's recursion allows) raise ``error`` naming the file."""
    check_regular_file(path, max_bytes=size_limit("PLIANT_MAX_TOML_BYTES", MAX_TOML_BYTES),
                       limit_name="PLIANT_MAX_TOML_BYTES", error=error)
    try:
        return tomllib.loads(Path(path).read_text())
    except tomllib.TOMLDecodeError as exc:
        raise error(f"not valid TOML: {exc}", source=str(path), field="<file>") from None
    except RecursionError:
        raise error("not valid TOML here: nested too deeply to read", source=str(path), field="<file>") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise error(f"cannot read file: {exc}", source=str(path), field="<file>") from None


#: characters kept as they are in a folder name made from a user's name; every other character becomes ``_``
_SAFE_CHARACTERS = frozenset("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789-_.+=,@")


def safe_name(text: str, *, limit: int = 100) -> str:
    """``text`` as one safe path component, for the folders pliant names after a pipeline or scene.

    Letters, digits and ``-_.+=,@`` are kept; every other character (``/``, ``\\``, NUL, spaces, anything
    non-ASCII) becomes ``_``; leading dots become ``_`` (no ``..``, no hidden folders); at most ``limit``
    characters; an empty result is ``_``.  So ``safe_name("../../etc") == "___.._etc"`` stays inside the folder it
    is joined to.  Paths a user gives explicitly (``--output``) are theirs and are not changed.
    """
    name = "".join(c if c in _SAFE_CHARACTERS else "_" for c in str(text))[:limit]
    stripped = name.lstrip(".")
    name = "_" * (len(name) - len(stripped)) + stripped
    return name or "_"
