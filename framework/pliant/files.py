"""Writing results so that nothing is lost or half-written, and reading logs a crash may have torn.

* :func:`write_text` / :func:`write_json` write to a temporary file in the same directory, flush and ``fsync`` it,
  then ``os.replace`` it over the target: a reader sees the old file or the new one, never a half-written one,
  whatever happens (Ctrl-C, kill -9, a full disk).
* :func:`strict` makes data strict JSON: NaN and infinities become ``null`` (``json.dumps`` would write the bare
  ``NaN`` that other JSON readers reject), numpy scalars and arrays become numbers and lists.  Readers of pliant's
  files (:class:`~pliant.results.PlanResult`, policies) read ``null`` back as NaN where a number is expected.
* :func:`append_jsonl` appends one record to a JSON-lines log and ``fsync`` s it, so a finished task survives a
  crash that follows; :func:`read_jsonl` reads such a log back, skipping a torn *last* line (the crash happened
  while writing it) and refusing a corrupt line elsewhere with an error naming the file and line.
* :func:`read_json` reads a JSON file a user may hand over damaged (cut off by a crash or a full disk, not text,
  the wrong kind of document): every such file is one :class:`~pliant.errors.ConfigError` naming the file, the line
  and the text where reading stopped -- never a ``JSONDecodeError`` traceback.
"""

from __future__ import annotations

import json
import math
import os
import re
import tempfile
from pathlib import Path
from typing import IO, Any

import numpy as np

from pliant.errors import ConfigError


def strict(data: Any) -> Any:
    """``data`` with non-finite floats as ``None`` and numpy values as Python ones, recursively (dicts, lists,
    tuples); anything else is returned as it is."""
    if isinstance(data, dict):
        return {str(k) if not isinstance(k, str) else k: strict(v) for k, v in data.items()}
    if isinstance(data, (list, tuple)):
        return [strict(v) for v in data]
    if isinstance(data, np.ndarray):
        return strict(data.tolist())
    if isinstance(data, (np.bool_,)):
        return bool(data)
    if isinstance(data, np.integer):
        return int(data)
    if isinstance(data, (float, np.floating)):
        value = float(data)
        return value if math.isfinite(value) else None
    return data


def dumps(data: Any, **kwargs: Any) -> str:
    """Strict JSON text of ``data`` (see :func:`strict`); ``kwargs`` go to :func:`json.dumps`."""
    return json.dumps(strict(data), allow_nan=False, **kwargs)


def read_json(path: str | Path, *, expect: type | tuple[type, ...] | None = dict) -> Any:
    """The JSON document in the file at ``path``.

    A file that cannot be read, is not UTF-8, is not JSON (for instance cut off by a crash while it was written) or
    whose top level is not ``expect`` (default: an object; None accepts any) is a
    :class:`~pliant.errors.ConfigError` naming the file, where reading stopped (``line L column C``) and the text
    there."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(f"is not UTF-8 text (byte {exc.start})", source=str(path), field="<file>",
                          value=exc.object[max(0, exc.start - 20):exc.start + 20]) from None
    except OSError as exc:
        raise ConfigError(f"cannot be read ({exc.strerror or exc})", source=str(path), field="<file>") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        # reading stopped in the text's last token (a number, a word, an escape) or in a string never closed: the
        # file is cut off (a crash or a full disk)
        cut = (not text.strip() or exc.msg.startswith("Unterminated string")
               or (exc.msg != "Extra data" and re.fullmatch(r"[\w.+\-\\]*\s*", text[exc.pos:]) is not None))
        why = "the file is empty or ends early: cut off while it was written?" if cut else exc.msg
        raise ConfigError(f"is not valid JSON ({why})", source=str(path),
                          field=f"line {exc.lineno} column {exc.colno}",
                          value=text[max(0, exc.pos - 40):exc.pos + 20]) from None
    except RecursionError:
        raise ConfigError("is nested too deeply to read", source=str(path), field="<file>") from None
    if expect is not None and not isinstance(data, expect):
        names = {dict: "an object", list: "an array", str: "a string"}
        wanted = " or ".join(names.get(t, t.__name__) for t in (expect if isinstance(expect, tuple) else (expect,)))
        raise ConfigError(f"must hold {wanted} at its top level", source=str(path), field="<top level>",
                          value=type(data).__name__)
    return data


def check_path_name(text: Any, field: str) -> str:
    """``text`` if it can name a file or directory: an empty or blank name (which ``Path`` reads as the current
    directory) or one holding a NUL is a :class:`~pliant.errors.ConfigError` naming ``field`` and the value."""
    if not isinstance(text, str) or not text.strip():
        raise ConfigError("must name a file or directory (the current directory is .)", field=field, value=text)
    if "\x00" in text:
        raise ConfigError("must not hold a NUL character", field=field, value=text)
    return text


def write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` to ``path`` atomically (temporary file, fsync, rename); parent directories are created."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(handle, "w", encoding="utf-8") as stream:
            stream.write(text)
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(temporary, path)
    except BaseException:
        try:
            os.unlink(temporary)
        except OSError:
            pass
        raise
    return path


def write_json(path: str | Path, data: Any, *, indent: int | None = 1, default=None) -> Path:
    """Write ``data`` as strict JSON (:func:`dumps`) to ``path`` atomically (:func:`write_text`)."""
    return write_text(path, dumps(data, indent=indent, default=default) + "\n")


def append_jsonl(stream: IO[str], record: Any) -> None:
    """Append ``record`` as one strict JSON line to the open log ``stream``, flushed and fsynced."""
    stream.write(dumps(record) + "\n")
    stream.flush()
    os.fsync(stream.fileno())


def read_jsonl(path: str | Path) -> tuple[list[dict], bool]:
    """The records of the JSON-lines log at ``path`` (none if it does not exist) and whether its last line was torn
    (unparseable and not ending in a newline: a crash while it was written; it is skipped).  Any other unparseable
    line is a :class:`~pliant.errors.ConfigError` naming the file and line number."""
    path = Path(path)
    if not path.exists():
        return [], False
    text = path.read_text(encoding="utf-8", errors="replace")
    lines = text.split("\n")
    records, torn = [], False
    for number, line in enumerate(lines, start=1):
        if not line.strip():
            continue
        try:
            records.append(json.loads(line))
        except json.JSONDecodeError as exc:
            last = number == len(lines) or (number == len(lines) - 1 and not lines[-1])
            if last and not text.endswith("\n"):
                torn = True
                continue
            raise ConfigError(f"line {number} is not JSON ({exc.msg}); the log is damaged (remove the line to "
                              "resume, or start afresh)", source=str(path), field=f"line {number}",
                              value=line[:80]) from None
    return records, torn


def rewrite_jsonl(path: str | Path, records: list[Any]) -> Path:
    """Replace the log at ``path`` by ``records`` atomically (after dropping a torn line, or forgetting tasks)."""
    return write_text(path, "".join(dumps(r) + "\n" for r in records))
