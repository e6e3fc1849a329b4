"""A named signal of the run, chunk by chunk: what ``Trace.signal``/``Trace.samples`` give for
the whole run, given piecewise as the trace streams (hil/analysis/trace_stream.py).

:func:`resolve` turns a signal name into a :class:`Source`; ``source.block(chunk)`` returns
``(t_s, values)`` of the samples the chunk adds (values shape (m,) or (m, columns)), so that
the blocks of all chunks, concatenated, are the whole-run arrays of ``Trace``. A source holds
at most one tick's values between chunks (a held value, the previous tick's row).

Names (as ``Trace.signal``): ``<group>.<field>`` and ``<group>.<field>[i]`` on the tick grid;
an irregular series (``tm.roll_ref_deg``) held on the tick grid (NaN before its first point);
``"a - b"`` the difference, at the irregular series' own instants when one side is one, the
tick side taken at the tick at or before each point. ``samples=True``: an irregular series at
its own instants (as ``Trace.samples``). A name that is not a group's field is taken for an
irregular series; if none arrived by the end, :meth:`Source.check` raises the KeyError the
whole-run trace raises.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

import numpy as np

from hil.analysis.trace_stream import Chunk, TraceStream

_COLUMN = re.compile(r"^(?P<base>.+)\[(?P<idx>\d+)\]$")
_EMPTY_T = np.zeros(0)


class Source:
    """A signal, chunk by chunk. ``on_ticks``: one sample per tick (else one per point)."""

    on_ticks = True

    def block(self, chunk: Chunk) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError

    def series(self) -> list[str]:
        """The irregular series it reads (checked at the end)."""
        return []

    def check(self, stream: TraceStream) -> None:
        """KeyError (as ``Trace.signal``) if a series it reads never arrived."""
        for name in self.series():
            if name not in stream.series:
                known = [f"{g}.{f}" for g, fields in stream.fields.items() for f in fields] + list(stream.series)
                raise KeyError(f"unknown signal {name!r} (known: {', '.join(known)})")


class Field(Source):
    """A group's field (all its columns, or one) at every tick."""

    def __init__(self, group: str, start: int, width: int, col: int | None) -> None:
        self.group, self.start, self.width, self.col = group, start, width, col

    def block(self, chunk: Chunk) -> tuple[np.ndarray, np.ndarray]:
        t_s = chunk.t_ns / 1e9
        rows = chunk.rows.get(self.group)
        if rows is None or rows.shape[0] == 0:
            return t_s, np.zeros(0) if self.width == 1 or self.col is not None else np.zeros((0, self.width))
        cols = rows[:, self.start : self.start + self.width]
        if self.col is not None:
            return t_s, cols[:, self.col]
        return t_s, cols[:, 0] if self.width == 1 else cols


class Held(Source):
    """An irregular series held on the tick grid (zero-order hold; NaN before its first point)."""

    def __init__(self, name: str) -> None:
        self.name = name
        self._held = np.nan  # the last point before this chunk

    def series(self) -> list[str]:
        return [self.name]

    def block(self, chunk: Chunk) -> tuple[np.ndarray, np.ndarray]:
        t_s = chunk.t_ns / 1e9
        pts = chunk.points.get(self.name)
        if pts is None:
            return t_s, np.full(t_s.shape, self._held)
        pt_ns, pv = pts
        idx = np.searchsorted(pt_ns, chunk.t_ns, side="right") - 1
        values = np.where(idx >= 0, pv[np.clip(idx, 0, None)], self._held)
        self._held = float(pv[-1])
        return t_s, values


class Points(Source):
    """An irregular series at its own instants."""

    on_ticks = False

    def __init__(self, name: str) -> None:
        self.name = name

    def series(self) -> list[str]:
        return [self.name]

    def block(self, chunk: Chunk) -> tuple[np.ndarray, np.ndarray]:
        pts = chunk.points.get(self.name)
        if pts is None:
            return _EMPTY_T, np.zeros(0)
        return pts[0] / 1e9, pts[1]


class PointDiff(Source):
    """``sign * (tick signal - series)`` at the series' instants, the tick signal taken at the
    tick at or before each point (points before the first tick dropped)."""

    on_ticks = False

    def __init__(self, ticks: Source, name: str, sign: float) -> None:
        if not ticks.on_ticks:
            raise ValueError("a difference of two irregular signals at their own instants is not supported")
        self.ticks, self.name, self.sign = ticks, name, sign
        self._last: np.ndarray | None = None  # the tick signal at the last tick so far, shape (1, ...)

    def series(self) -> list[str]:
        return [self.name, *self.ticks.series()]

    def block(self, chunk: Chunk) -> tuple[np.ndarray, np.ndarray]:
        _, a = self.ticks.block(chunk)  # every chunk: the tick source may hold state
        before = self._last
        if a.shape[0]:
            self._last = a[-1:].copy()
        pts = chunk.points.get(self.name)
        if pts is None:
            return _EMPTY_T, np.zeros(0)
        pt_ns, pv = pts
        # index into [previous chunk's last tick, this chunk's ticks...]; -1: before any tick
        grid = a if before is None else np.concatenate([before, a])
        idx = np.searchsorted(chunk.t_ns, pt_ns, side="right") - (1 if before is None else 0)
        ok = idx >= 0
        return pt_ns[ok] / 1e9, self.sign * (grid[idx[ok]] - pv[ok])


class TickDiff(Source):
    """Difference of two signals on the tick grid."""

    def __init__(self, a: Source, b: Source) -> None:
        if not (a.on_ticks and b.on_ticks):
            raise ValueError("a difference with an irregular signal's difference is not supported")
        self.a, self.b = a, b

    def series(self) -> list[str]:
        return self.a.series() + self.b.series()

    def block(self, chunk: Chunk) -> tuple[np.ndarray, np.ndarray]:
        t_s, a = self.a.block(chunk)
        _, b = self.b.block(chunk)
        return t_s, a - b


def held_names(source: Source) -> list[str]:
    """The irregular series ``source`` holds on the tick grid (as ``Trace.held_series``)."""
    if isinstance(source, Held):
        return [source.name]
    if isinstance(source, TickDiff):
        return held_names(source.a) + held_names(source.b) if isinstance(source.a, Held) and isinstance(
            source.b, Held) else []
    return []


def _field(fields: Mapping[str, Mapping[str, int]], name: str) -> Field | None:
    col = None
    m = _COLUMN.match(name)
    if m:
        name, col = m.group("base"), int(m.group("idx"))
    group, _, field = name.partition(".")
    widths = fields.get(group)
    if widths is None or field not in widths:
        return None
    names = list(widths)
    start = sum(widths[f] for f in names[: names.index(field)])
    if col is not None and col >= widths[field]:
        raise ValueError(f"signal {name}[{col}]: {name} has {widths[field]} column(s)")
    return Field(group, start, widths[field], col)


def _is_series(fields: Mapping[str, Mapping[str, int]], name: str) -> bool:
    return " - " not in name and not _COLUMN.match(name) and _field(fields, name) is None


def resolve(fields: Mapping[str, Mapping[str, int]], name: str, *, samples: bool = False) -> Source:
    """The source of signal ``name`` given the trace's groups (``fields``: group -> field ->
    columns). ``samples``: as ``Trace.samples`` (a series at its own instants)."""
    if " - " in name:
        left, right = (part.strip() for part in name.split(" - ", 1))
        if _is_series(fields, right) and not _is_series(fields, left):
            return PointDiff(resolve(fields, left), right, 1.0)
        if _is_series(fields, left) and not _is_series(fields, right):
            return PointDiff(resolve(fields, right), left, -1.0)
        return TickDiff(resolve(fields, left), resolve(fields, right))
    if samples and _is_series(fields, name):
        return Points(name)
    found = _field(fields, name)
    if found is not None:
        return found
    m = _COLUMN.match(name)
    return Held(m.group("base") if m else name)
