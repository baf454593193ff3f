"""A one-line progress display for long runs (DESIGN rule 8: long work is visible).

Shown on a terminal (rewritten in place at most every ``interval`` seconds); elsewhere (CI, files)
it logs at INFO level through :mod:`logging`, so runs stay quiet unless asked.
"""

from __future__ import annotations

import logging
import sys
import time

log = logging.getLogger("pliant.progress")


class ProgressLine:
    """``update(**fields)`` shows ``label: key value, ...``; ``close()`` ends the line.

    ``enabled`` None (the default) means: when ``stream`` is a terminal.
    """

    def __init__(self, label: str, interval: float = 0.5, stream=None, enabled: bool | None = None) -> None:
        self.label = label
        self.interval = interval
        self.stream = stream if stream is not None else sys.stderr
        self.enabled = bool(enabled) if enabled is not None else bool(getattr(self.stream, "isatty", lambda: False)())
        self._last = 0.0
        self._shown = False

    @staticmethod
    def _format(fields: dict) -> str:
        parts = []
        for key, value in fields.items():
            text = f"{value:.4g}" if isinstance(value, float) else str(value)
            parts.append(f"{key} {text}")
        return ", ".join(parts)

    def update(self, force: bool = False, **fields) -> None:
        """Show the fields if ``interval`` has passed since the last display (or ``force``)."""
        now = time.perf_counter()
        if not force and now - self._last < self.interval:
            return
        self._last = now
        text = f"{self.label}: {self._format(fields)}"
        if self.enabled:
            self.stream.write("\r" + text[:160].ljust(80))
            self.stream.flush()
            self._shown = True
        else:
            log.info(text)

    def close(self) -> None:
        """End the line on a terminal."""
        if self.enabled and self._shown:
            self.stream.write("\n")
            self.stream.flush()
            self._shown = False
