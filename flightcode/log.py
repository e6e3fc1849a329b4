"""Structured one-line logging to stderr in logfmt.

Every line is ``t_s=<sensor time> level=<level> event=<name> key=value ...``:

* ``t_s`` is sensor time in seconds since the first IMU sample (the IMU's SampleTimeFine,
  so it lines up with the bench's sim time); it reads ``0.000000`` during boot, which happens
  before the first sample.
* values with spaces, quotes, ``=`` or nothing at all are double-quoted, with ``\\`` and ``"``
  escaped (the common logfmt convention, e.g. go-logfmt); floats use 6 significant digits.

Writing is line-buffered and cheap; the loop logs events and a periodic stats line, never
per tick.
"""

from __future__ import annotations

import sys
from enum import IntEnum, unique
from typing import TextIO


@unique
class Level(IntEnum):
    """Severity, lowest first."""

    DEBUG = 10
    INFO = 20
    WARNING = 30
    ERROR = 40


def _format_value(value: object) -> str:
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, float):
        text = format(value, ".6g")
    elif isinstance(value, IntEnum):
        text = value.name.lower()
    else:
        text = str(value)
    if text == "" or any(c in text for c in ' ="\\\n\t'):
        text = '"' + text.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'
    return text


def format_line(t_s: float, level: Level, event: str, fields: dict[str, object]) -> str:
    """One logfmt line (without the newline)."""
    parts = [f"t_s={t_s:.6f}", f"level={level.name.lower()}", f"event={_format_value(event)}"]
    parts += [f"{key}={_format_value(value)}" for key, value in fields.items()]
    return " ".join(parts)


class Logger:
    """logfmt logger with a sensor-time stamp the loop keeps up to date.

    Args:
        stream: where lines go (stderr by default).
        level: lines below this level are dropped.
    """

    def __init__(self, stream: TextIO | None = None, level: Level = Level.INFO) -> None:
        self._stream = stream if stream is not None else sys.stderr
        self.level = level
        #: Sensor time of the current sample, ns since the first sample (0 during boot).
        self.t_ns = 0

    def log(self, level: Level, event: str, **fields: object) -> None:
        """Write one line if ``level`` passes the filter."""
        if level < self.level:
            return
        self._stream.write(format_line(self.t_ns / 1e9, level, event, fields) + "\n")
        self._stream.flush()

    def debug(self, event: str, **fields: object) -> None:
        self.log(Level.DEBUG, event, **fields)

    def info(self, event: str, **fields: object) -> None:
        self.log(Level.INFO, event, **fields)

    def warning(self, event: str, **fields: object) -> None:
        self.log(Level.WARNING, event, **fields)

    def error(self, event: str, **fields: object) -> None:
        self.log(Level.ERROR, event, **fields)
