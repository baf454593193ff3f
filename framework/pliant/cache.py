"""A content-addressed cache of preprocessing results (voxel grids, distance fields, contact tables).

A result is a dict of numpy arrays built by a pure function of some inputs.  :func:`cached_arrays` names it by a
hash of *everything the result depends on* -- a ``kind`` (what is built), an algorithm ``version`` string (bumped
when the algorithm changes) and the inputs themselves, reduced to bytes by :func:`fingerprint` (numbers, strings,
numpy arrays, lists, dicts and dataclasses such as a scene's objects) -- and keeps it twice:

* in this process (a memo of the last 16 results built, at most 512 MB: the second build in one run, e.g. the
  validity checker's grid after the simulator's, is a dictionary look-up), and
* on disk, one ``.npz`` file per result under :func:`cache_dir` (default ``~/.cache/pliant``, or
  ``$PLIANT_CACHE_DIR``), so that the next run, and every experiment worker, loads it instead of building it.

Writes are atomic (a temporary file in the same directory, then ``os.replace``), so a reader never sees half a file;
a build holds a lock file (``fcntl.flock``) so that concurrent experiment workers wanting the same result wait for
one build and then read it.  A file that cannot be read, lacks an
array or was written under another key is ignored and rebuilt, never an error.  ``PLIANT_CACHE=0`` turns the disk
cache and the memo off (every result is built).  The directory is bounded: past ``PLIANT_CACHE_MAX_BYTES``
(default 4 GB) the least recently used files are deleted after a write.  Clear it with :func:`clear` or by
deleting the directory.

This module is part of the core's base: it imports numpy, the standard library and :mod:`pliant.errors` only.
"""

from __future__ import annotations

import dataclasses
import hashlib
import logging
import math
import os
import struct
import tempfile
import threading
import weakref
from collections import OrderedDict
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from pliant.errors import ConfigError

log = logging.getLogger(__name__)

#: environment variable: the cache directory (default ``~/.cache/pliant``)
DIR_VARIABLE = "PLIANT_CACHE_DIR"
#: environment variable: ``0`` (or ``false``, ``no``, ``off``) disables the cache
ENABLE_VARIABLE = "PLIANT_CACHE"
#: environment variable: the most bytes the cache directory may hold before old files are deleted
MAX_BYTES_VARIABLE = "PLIANT_CACHE_MAX_BYTES"
#: default bound of the directory (bytes)
DEFAULT_MAX_BYTES = 4 * 1024**3
#: results and bytes kept in this process's memo (the least recently used beyond either are dropped)
MEMO_ENTRIES = 16
MEMO_BYTES = 512 * 1024**2

_KEY_ARRAY = "__pliant_cache_key__"
_NAMES_ARRAY = "__pliant_cache_names__"
_lock = threading.Lock()
#: what happened to each request of this process: ``memo``, ``disk`` or ``built`` (tests and the benchmark read it)
counts = {"memo": 0, "disk": 0, "built": 0}


def enabled() -> bool:
    """Whether the cache is on (``PLIANT_CACHE`` unset or not one of ``0``, ``false``, ``no``, ``off``)."""
    return os.environ.get(ENABLE_VARIABLE, "1").strip().lower() not in ("0", "false", "no", "off")


def cache_dir() -> Path:
    """The cache directory: ``$PLIANT_CACHE_DIR`` or ``~/.cache/pliant`` (``$XDG_CACHE_HOME/pliant`` when set)."""
    configured = os.environ.get(DIR_VARIABLE, "").strip()
    if configured:
        return Path(configured).expanduser()
    base = os.environ.get("XDG_CACHE_HOME", "").strip()
    return (Path(base) if base else Path.home() / ".cache") / "pliant"


def _max_bytes() -> int:
    text = os.environ.get(MAX_BYTES_VARIABLE, "").strip()
    if not text:
        return DEFAULT_MAX_BYTES
    try:
        value = int(float(text))
    except ValueError:
        raise ConfigError("must be a number of bytes", field=MAX_BYTES_VARIABLE, value=text) from None
    if value < 0:
        raise ConfigError("must be >= 0", field=MAX_BYTES_VARIABLE, value=text)
    return value


# --- keys ---------------------------------------------------------------------------------------------------------


def _feed(h, value: Any) -> None:
    """Feed ``value``'s canonical encoding to hash ``h`` (type-tagged, so ``1``, ``1.0``, ``"1"`` differ)."""
    if value is None:
        h.update(b"N")
    elif isinstance(value, (bool, np.bool_)):
        h.update(b"T" if value else b"F")
    elif isinstance(value, (int, np.integer)):
        text = str(int(value)).encode()
        h.update(b"i%d:" % len(text) + text)
    elif isinstance(value, (float, np.floating)):
        f = float(value)
        h.update(b"f" + (b"nan" if math.isnan(f) else struct.pack("<d", f + 0.0)))   # -0.0 and 0.0 alike
    elif isinstance(value, str):
        data = value.encode()
        h.update(b"s%d:" % len(data) + data)
    elif isinstance(value, bytes):
        h.update(b"b%d:" % len(value) + value)
    elif isinstance(value, Path):
        _feed(h, ("path", str(value)))
    elif isinstance(value, np.ndarray):
        array = np.ascontiguousarray(value)
        if array.dtype.hasobject:
            _feed(h, ("object-array", array.shape, array.tolist()))
            return
        h.update(b"a" + array.dtype.str.encode() + repr(array.shape).encode())
        h.update(memoryview(array.reshape(-1).view(np.uint8)))
    elif isinstance(value, (list, tuple)):
        h.update(b"l%d:" % len(value))
        for item in value:
            _feed(h, item)
    elif isinstance(value, Mapping):
        items = sorted(value.items(), key=lambda kv: repr(kv[0]))
        h.update(b"d%d:" % len(items))
        for k, v in items:
            _feed(h, k)
            _feed(h, v)
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        cls = type(value)
        _feed(h, f"{cls.__module__}.{cls.__qualname__}")
        fields = [f for f in dataclasses.fields(value) if f.compare or f.init]
        h.update(b"o%d:" % len(fields))
        for f in fields:
            _feed(h, f.name)
            _feed(h, getattr(value, f.name))
    else:
        raise TypeError(f"cannot fingerprint a {type(value).__name__}: give its content (numbers, strings, arrays, "
                        f"lists, dicts, dataclasses)")


def fingerprint(*parts: Any) -> str:
    """A SHA-256 hex digest of ``parts``' content: equal content, equal digest, in any process on any machine.

    Numbers, strings, bytes, paths, numpy arrays (dtype, shape and bytes), lists, tuples, dicts (in key order) and
    dataclasses (class name and fields) are encoded; anything else is a ``TypeError`` (a key must not depend on an
    object's identity)."""
    h = hashlib.sha256()
    _feed(h, parts)
    return h.hexdigest()


# --- the cache ----------------------------------------------------------------------------------------------------


def _path(kind: str, key: str) -> Path:
    return cache_dir() / kind / f"{key}.npz"


def _copy(arrays: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    return {name: np.array(a, copy=True) for name, a in arrays.items()}


def _read(path: Path, key: str, names: tuple[str, ...] | None) -> dict[str, np.ndarray] | None:
    """The arrays of ``path`` when it is a whole cache file of ``key`` holding every array it lists (or ``names``,
    when given); else None."""
    try:
        with np.load(path, allow_pickle=False) as data:
            if _KEY_ARRAY not in data.files or str(data[_KEY_ARRAY]) != key or _NAMES_ARRAY not in data.files:
                log.warning("pliant cache: %s belongs to another key; rebuilding it", path)
                return None
            names = names if names is not None else tuple(str(n) for n in data[_NAMES_ARRAY])
            arrays = {name: data[name] for name in data.files if name not in (_KEY_ARRAY, _NAMES_ARRAY)}
    except FileNotFoundError:
        return None
    except Exception as exc:   # torn, truncated, not a zip, not npy: rebuild it, never fail on a cache file
        log.warning("pliant cache: cannot read %s (%s: %s); rebuilding it", path, type(exc).__name__, exc)
        return None
    if names is not None and set(names) - set(arrays):
        log.warning("pliant cache: %s lacks %s; rebuilding it", path, sorted(set(names) - set(arrays)))
        return None
    return arrays


def _write(path: Path, key: str, arrays: Mapping[str, np.ndarray]) -> None:
    """Write ``arrays`` to ``path`` atomically; a failure (read-only or full disk) is logged, not raised."""
    tmp = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.stem[:16]}-", suffix=".tmp", dir=path.parent)
        with os.fdopen(fd, "wb") as stream:
            np.savez(stream, **{_KEY_ARRAY: np.array(key), _NAMES_ARRAY: np.array(sorted(arrays), dtype=str)},
                     **arrays)
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(tmp, path)
        tmp = None
    except OSError as exc:
        log.warning("pliant cache: cannot write %s (%s); continuing without it", path, exc)
    finally:
        if tmp is not None:
            try:
                os.unlink(tmp)
            except OSError:
                pass
    _prune()


def _ours(path: Path) -> bool:
    """Whether ``path`` is one of this cache's files (``<64 hex>.npz`` / ``.lock``, or a temporary file of one), not
    another tool's file in the same directory (the viewer keeps its meshes in ``~/.cache/pliant/viewer``)."""
    name = path.name
    if name.startswith(".") and name.endswith(".tmp"):
        return all(c in "0123456789abcdef" for c in name[1:17]) and name[17:18] == "-"
    return path.suffix in (".npz", ".lock") and len(path.stem) == 64 and \
        all(c in "0123456789abcdef" for c in path.stem)


def _prune() -> None:
    """Delete the least recently used files while the directory holds more than ``PLIANT_CACHE_MAX_BYTES``."""
    limit = _max_bytes()
    try:
        files = []
        for path in cache_dir().glob("*/*.npz"):
            if not _ours(path):
                continue
            try:
                st = path.stat()
            except OSError:
                continue
            files.append((st.st_atime if st.st_atime > st.st_mtime else st.st_mtime, st.st_size, path))
    except OSError:
        return
    total = sum(size for _, size, _ in files)
    for _, size, path in sorted(files):
        if total <= limit:
            break
        try:
            path.unlink()
            total -= size
        except OSError:
            pass


@contextmanager
def _build_lock(path: Path) -> Iterator[None]:
    """Hold an exclusive lock on ``path``'s lock file while building it, so that concurrent experiment workers
    wait for one build instead of each building; without file locks (or a writable directory) nothing is held."""
    try:
        import fcntl
    except ImportError:        # not POSIX: every worker builds, the atomic write still keeps the file whole
        yield
        return
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        handle = open(path.with_suffix(".lock"), "a")
    except OSError:
        yield
        return
    try:
        fcntl.flock(handle.fileno(), fcntl.LOCK_EX)
        yield
    finally:
        handle.close()       # releases the lock


def _check_kind(kind: str) -> None:
    if not kind or not all(c.isalnum() or c in "-_." for c in kind) or kind.startswith("."):
        raise ConfigError("a cache kind is a name of letters, digits, '-', '_' and '.'", field="kind", value=kind)


def cached_arrays(kind: str, version: str, inputs: Any, build: Callable[[], Mapping[str, np.ndarray]]
                  ) -> dict[str, np.ndarray]:
    """The arrays ``build()`` returns for ``inputs``, built once per content and kept (see the module docstring).

    ``kind``: what is built (a directory name, e.g. ``"voxelgrid"``).  ``version``: the algorithm's version string;
    change it whenever ``build`` would return something else for the same inputs.  ``inputs``: everything the
    result depends on, as :func:`fingerprint` encodes it.  ``build``: returns ``{name: array}`` (no object arrays).
    The caller receives its own copies: changing them changes no cached result."""
    _check_kind(kind)
    if not enabled():
        counts["built"] += 1
        return dict(build())
    key = fingerprint(kind, version, inputs)
    hit = _memo.peek(key)
    if hit is not None:
        counts["memo"] += 1
        return _copy(hit)
    path = _path(kind, key)
    arrays = _read(path, key, None)
    if arrays is not None:
        counts["disk"] += 1
        try:
            os.utime(path)     # recently used: kept longest when the directory is pruned
        except OSError:
            pass
        return arrays          # freshly read: the caller's own (the memo keeps built results only)
    with _build_lock(path):
        # another process may have built it while this one waited for the lock: one build per content
        arrays = _read(path, key, None)
        if arrays is not None:
            counts["disk"] += 1
            return arrays
        counts["built"] += 1
        arrays = {name: np.asarray(a) for name, a in build().items()}
        for name, a in arrays.items():
            if a.dtype.hasobject:
                raise TypeError(f"cached array {name!r} holds Python objects")
        _write(path, key, arrays)
    _memo.put(key, arrays)
    return _copy(arrays)


_process_memos: list[weakref.ref] = []       # every ProcessMemo of this process, for forget()


class ProcessMemo:
    """A memo of results derived in this process, for what the disk cache should not keep (results too large to be
    worth a file, or Python objects such as a parsed robot model): :meth:`get` builds a result once per key and
    hands the same object to every later caller, so callers must treat it as read-only (make arrays read-only).

    Bounded: at most ``entries`` results, and at most ``max_bytes`` bytes of the numpy arrays in them (a result that
    is an array or a dict of arrays; other results count 0); the least recently used are dropped.  Off with
    ``PLIANT_CACHE=0`` (every call builds), and emptied by :func:`forget` like the cache's own memo.  ``key``: any
    hashable value naming everything the result depends on (e.g. a :func:`fingerprint`)."""

    def __init__(self, entries: int, max_bytes: int | None = None) -> None:
        if isinstance(entries, bool) or not isinstance(entries, int) or entries < 1:
            raise ConfigError("must be a positive integer", field="entries", value=entries)
        self.entries = entries
        self.max_bytes = max_bytes
        self._items: OrderedDict = OrderedDict()
        self._lock = threading.Lock()
        with _lock:
            _process_memos.append(weakref.ref(self))

    def get(self, key: Any, build: Callable[[], Any]) -> Any:
        """The result for ``key``: remembered, or ``build()`` (then remembered)."""
        if not enabled():
            return build()
        value = self.peek(key)
        if value is None:
            value = build()
            self.put(key, value)
        return value

    def peek(self, key: Any) -> Any:
        """The result remembered for ``key`` (now the most recently used), or None."""
        with self._lock:
            if key not in self._items:
                return None
            self._items.move_to_end(key)
            return self._items[key]

    def put(self, key: Any, value: Any) -> None:
        """Remember ``value`` for ``key``, then drop the least recently used results beyond the bounds (never the
        newest)."""
        with self._lock:
            self._items[key] = value
            self._items.move_to_end(key)
            while len(self._items) > 1 and (len(self._items) > self.entries or (
                    self.max_bytes is not None and self.nbytes() > self.max_bytes)):
                self._items.popitem(last=False)

    def nbytes(self) -> int:
        """Bytes of the numpy arrays held."""
        def size(value) -> int:
            if isinstance(value, np.ndarray):
                return value.nbytes
            if isinstance(value, Mapping):
                return sum(v.nbytes for v in value.values() if isinstance(v, np.ndarray))
            return 0
        return sum(size(v) for v in self._items.values())

    def clear(self) -> None:
        """Forget every result."""
        with self._lock:
            self._items.clear()

    def __len__(self) -> int:
        return len(self._items)


#: this process's memo of the results :func:`cached_arrays` built (one :class:`ProcessMemo` among those registered)
_memo = ProcessMemo(MEMO_ENTRIES, MEMO_BYTES)


def forget() -> None:
    """Empty this process's memo and every :class:`ProcessMemo` (the files stay)."""
    with _lock:
        memos = [ref() for ref in _process_memos]
        _process_memos[:] = [ref for ref, memo in zip(_process_memos, memos) if memo is not None]
    for memo in memos:
        if memo is not None:
            memo.clear()


def clear(kind: str | None = None) -> int:
    """Delete the cache's files (of one ``kind``, or all; other tools' files in the directory stay) and the memo;
    returns how many results were deleted."""
    forget()
    root = cache_dir()
    if kind is not None:
        _check_kind(kind)
    pattern = f"{kind}/*" if kind is not None else "*/*"
    removed = 0
    for path in root.glob(pattern):
        if _ours(path) and path.is_file():
            try:
                path.unlink()
                removed += path.suffix == ".npz"
            except OSError:
                pass
    return removed
