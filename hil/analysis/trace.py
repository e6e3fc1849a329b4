"""The run's trace: named time series kept in memory for the criteria and the summary.

Per-tick signals (plant truth, ESC pulses, throttles) are appended as rows of floats on
the tick path (one ``array.extend`` per group); irregular series (telemetry at 50 Hz, device
counters) are appended with their own sim times. ``signal(name)`` returns any of them on
the tick grid (zero-order hold for irregular series), as numpy arrays.

Storage is flat typed arrays (``array('d')`` values, ``array('q')`` times), 8 bytes a value:
a row kept as a tuple of Python floats cost about 3.5x that (a float object each), about
0.6 MB per simulated second of the bench's memory. Numpy reads them without a copy; a row
appended while such a view is alive goes to a fresh copy of the storage (the view keeps the
old one), so views stay valid.

Signal names are ``<group>.<field>``; multi-column fields are addressed as a whole
(``esc.pulse_us``, shape (n, 4)) or by column (``esc.pulse_us[2]``).
"""

from __future__ import annotations

import re
from array import array

import numpy as np

_COLUMN = re.compile(r"^(?P<base>.+)\[(?P<idx>\d+)\]$")


class _Rows:
    """One per-tick group: field widths, and its times and flattened rows as typed arrays."""

    __slots__ = ("fields", "width", "times", "values", "exported")

    def __init__(self, fields: dict[str, int]) -> None:
        self.fields = dict(fields)
        self.width = sum(self.fields.values())
        self.times = array("q")
        self.values = array("d")
        self.exported = False  # a numpy view of the arrays may be alive: copy before growing

    def append(self, t_ns: int, values: tuple[float, ...]) -> None:
        if len(values) != self.width:
            raise ValueError(f"a row of {len(values)} values for a group of {self.width} columns")
        if self.exported:
            self.times, self.values, self.exported = array("q", self.times), array("d", self.values), False
        self.times.append(t_ns)
        self.values.extend(values)


class Trace:
    """Columnar store of the run's signals."""

    def __init__(self) -> None:
        self._groups: dict[str, _Rows] = {}
        self._series: dict[str, tuple[array[int], array[float]]] = {}
        self._cache: dict[str, np.ndarray] = {}

    # -- writing ----------------------------------------------------------------------------
    def define(self, group: str, fields: dict[str, int]) -> None:
        """Declare a per-tick group: field name -> number of columns, in row order."""
        self._groups[group] = _Rows(fields)

    def row(self, group: str, t_ns: int, values: tuple[float, ...]) -> None:
        """Append one row of a group (values in the declared field order, flattened)."""
        self._groups[group].append(t_ns, values)
        if self._cache:
            self._cache.clear()

    def point(self, name: str, t_ns: int, value: float) -> None:
        """Append one sample of an irregular scalar series."""
        series = self._series.get(name)
        if series is None:
            series = self._series[name] = (array("q"), array("d"))
        series[0].append(t_ns)
        series[1].append(float(value))
        if self._cache:
            self._cache.clear()

    # -- reading ----------------------------------------------------------------------------
    def names(self) -> list[str]:
        out: list[str] = []
        for group, rows in self._groups.items():
            out += [f"{group}.{f}" for f in rows.fields]
        return out + list(self._series)

    def tick_times_s(self, group: str = "truth") -> np.ndarray:
        return np.array(self._groups[group].times, dtype=np.int64) / 1e9

    def _group_array(self, group: str) -> np.ndarray:
        key = f"__{group}"
        if key not in self._cache:
            rows = self._groups[group]
            if rows.times:
                rows.exported = True  # a view, no copy of the whole run
                arr = np.frombuffer(rows.values, dtype=np.float64).reshape(len(rows.times), rows.width)
            else:
                arr = np.zeros((0, 0))
            self._cache[key] = arr
        return self._cache[key]

    def samples(self, name: str, grid: str = "truth") -> tuple[np.ndarray, np.ndarray]:
        """(t_s, values) of a signal at its own instants: an irregular series as recorded (no
        hold), anything else as ``signal`` gives it."""
        if name in self._series:
            times, values = self._series[name]
            # copies: a view would pin the growing array.array buffers (BufferError on append)
            return np.array(times, dtype=np.int64) / 1e9, np.array(values, dtype=float)
        return self.signal(name, grid)

    def held_series(self, name: str) -> list[str]:
        """The irregular series that signal ``name`` holds on the tick grid (a series alone, or
        both sides of a difference of two; a difference with one series is taken at its own
        instants, not held)."""
        sides = [part.strip() for part in name.split(" - ", 1)] if " - " in name else [name]
        series = [m.group("base") if (m := _COLUMN.match(side)) else side for side in sides]
        held = [s for s in series if s in self._series]
        return held if len(held) == len(sides) else []

    def signal(self, name: str, grid: str = "truth") -> tuple[np.ndarray, np.ndarray]:
        """(t_s, values) of a signal on the tick grid of ``grid``; KeyError if unknown.

        ``"a - b"`` is the difference of two signals (e.g. a tracking error
        ``truth.roll_deg - tm.roll_ref_deg``); when one side is an irregular series it is
        taken at that series' own instants, the tick signal at the tick at or before each.
        """
        if " - " in name:
            left, right = (part.strip() for part in name.split(" - ", 1))
            if right in self._series and left not in self._series:
                # compare at the irregular series' own instants (e.g. 50 Hz telemetry):
                # holding it on the 400 Hz grid would add its sample-and-hold error
                series_t, series_v = self._series[right]
                st_ns = np.array(series_t, dtype=np.int64)
                t_grid, a = self.signal(left, grid)
                grid_ns = np.rint(t_grid * 1e9).astype(np.int64)
                idx = np.searchsorted(grid_ns, st_ns, side="right") - 1
                ok = idx >= 0
                return st_ns[ok] / 1e9, a[idx[ok]] - np.array(series_v, dtype=float)[ok]
            if left in self._series and right not in self._series:
                # the same, mirrored (e.g. an estimate against truth: ``tm.z_hat_m - truth.h_m``)
                t_s, d = self.signal(f"{right} - {left}", grid)
                return t_s, -d
            t_s, a = self.signal(left, grid)
            _, b = self.signal(right, grid)
            return t_s, a - b
        col = None
        m = _COLUMN.match(name)
        if m:
            name, col = m.group("base"), int(m.group("idx"))
        if name in self._series:
            t_s = self.tick_times_s(grid)
            series_t, series_v = self._series[name]
            st = np.array(series_t, dtype=np.int64) / 1e9
            v = np.array(series_v, dtype=float)
            idx = np.searchsorted(st, t_s, side="right") - 1
            held = np.where(idx >= 0, v[np.clip(idx, 0, None)], np.nan) if len(v) else np.full_like(t_s, np.nan)
            return t_s, held
        group, _, field = name.partition(".")
        if group not in self._groups:
            raise KeyError(f"unknown signal {name!r} (known: {', '.join(self.names())})")
        widths = self._groups[group].fields
        if field not in widths:
            raise KeyError(f"unknown signal {name!r} (known: {', '.join(self.names())})")
        names = list(widths)
        start = sum(widths[f] for f in names[: names.index(field)])
        arr = self._group_array(group)
        block = arr[:, start : start + widths[field]] if arr.size else np.zeros((0, widths[field]))
        values = block[:, 0] if widths[field] == 1 else block
        if col is not None:
            values = block[:, col]
        return self.tick_times_s(group), values
