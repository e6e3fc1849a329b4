"""A scenario's criteria evaluated while the run streams, in memory that does not grow with
the flight's length.

Each criterion is an online evaluator fed chunk by chunk by the run's trace stream
(hil/analysis/trace_stream.py) through its signal's source (hil/analysis/signal_stream.py); at the end,
:meth:`CriteriaStream.results` gives what :func:`hil.analysis.criteria.evaluate` gives on the whole-run
trace (the batch reference: tests compare the two on random traces). What each keeps:

| metric | held |
|---|---|
| max_abs, rms, mean, min, max, final, increase, amplitude, std, rms_delta, fraction_saturated, fraction_in, fraction_finite, rms_change_pct | running aggregates (hil/analysis/online_stats.py ``Moments``): one row |
| phase_lag_deg | two least-squares factors, 4x4 each (``SineFit``) |
| overshoot, settling_time, rise_time | the step's levels as running sums; after the step, running max, the time after the last sample outside the band, the first 10 % and 90 % crossings |
| p99_abs | every finite |value| in its window, 8 bytes each (a percentile needs them): the one metric whose memory grows with its window |

Each evaluator counts the samples of its window and the finite ones: more non-finite samples
than the criterion tolerates fail it (``check_finite``, as the batch does).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from functools import partial

import numpy as np

from hil.analysis.criteria import CriterionResult, check_arrived, check_finite, failed, result_of
from hil.analysis.online_stats import ExactSum, Moments, SineFit, finite_rows
from hil.config.scenario import Criterion
from hil.analysis.signal_stream import Source, held_names, resolve
from hil.analysis.trace_stream import Chunk, TraceStream

POOLED = frozenset({"max_abs", "rms", "mean", "min", "max", "final", "p99_abs", "amplitude", "std", "rms_delta",
                    "fraction_saturated", "increase", "fraction_in", "fraction_finite"})
STEP = frozenset({"overshoot", "settling_time", "rise_time"})


def _window(t_s: np.ndarray, values: np.ndarray, window: tuple[float, float] | None) -> tuple[np.ndarray, np.ndarray]:
    if window is None:
        return t_s, values
    mask = (t_s >= window[0]) & (t_s <= window[1])
    return t_s[mask], values[mask]


def pooled_value(metric: str, m: Moments, kept: list[np.ndarray] | None = None) -> float:
    """A pooled metric from its aggregates (``kept``: p99_abs's |values|)."""
    if metric == "fraction_finite":
        return m.rows / m.samples if m.samples else math.nan
    if m.samples == 0 or m.rows == 0:
        return math.nan
    if metric == "max_abs":
        return m.max_abs
    if metric == "rms":
        return math.sqrt(m.total_sq / m.n)
    if metric == "mean":
        return m.total / m.n
    if metric == "min":
        return m.min
    if metric == "max":
        return m.max
    if metric == "final":
        assert m.last is not None
        return float(np.mean(m.last))
    if metric == "increase":
        assert m.first is not None and m.last is not None
        return float(np.mean(m.last)) - float(np.mean(m.first))
    if metric == "p99_abs":
        assert kept is not None
        return float(np.percentile(np.concatenate(kept), 99))
    if metric == "amplitude":
        return (m.max - m.min) / 2
    if metric == "std":
        return math.sqrt(max(m.m2, 0.0) / m.n)
    if metric == "rms_delta":
        return math.sqrt(m.delta_sq / m.delta_n) if m.delta_n else 0.0
    if metric == "fraction_saturated":
        return m.saturated / m.rows
    if metric == "fraction_in":
        return m.inside / m.rows
    raise ValueError(f"unknown metric {metric}")


class _Arrivals:
    """Samples of each series a signal holds on the tick grid, stamped in a window."""

    def __init__(self, source: Source, window: tuple[float, float] | None) -> None:
        self.window = window
        self.count = dict.fromkeys(held_names(source), 0) if window is not None else {}

    def feed(self, chunk: Chunk) -> None:
        for name in self.count:
            pts = chunk.points.get(name)
            if pts is not None:
                assert self.window is not None
                t_s = pts[0] / 1e9
                self.count[name] += int(np.count_nonzero((t_s >= self.window[0]) & (t_s <= self.window[1])))


class _Evaluator:
    """One criterion: ``feed`` every chunk, then ``value``; ``sources`` are checked at the end."""

    sources: list[Source]

    def feed(self, chunk: Chunk) -> None:
        raise NotImplementedError

    def value(self) -> float:
        raise NotImplementedError


class _Pooled(_Evaluator):
    def __init__(self, c: Criterion, source: Source) -> None:
        self.c, self.sources = c, [source]
        lo = -math.inf if c.lo is None else c.lo
        hi = math.inf if c.hi is None else c.hi
        self.m = Moments(lo, hi)
        self.kept: list[np.ndarray] | None = [] if c.metric == "p99_abs" else None
        self.arrivals = _Arrivals(source, c.window_s)

    def feed(self, chunk: Chunk) -> None:
        self.arrivals.feed(chunk)
        _, v = _window(*self.sources[0].block(chunk), self.c.window_s)
        flat = self.m.add(v)
        if self.kept is not None and flat.size:
            self.kept.append(np.abs(flat).ravel())

    def value(self) -> float:
        check_arrived(self.c, self.arrivals.count)
        if self.c.metric != "fraction_finite":  # which measures just that
            check_finite(self.c, self.m.samples, self.m.rows)
        return pooled_value(self.c.metric, self.m, self.kept)


class _RmsChange(_Evaluator):
    def __init__(self, c: Criterion, source: Source) -> None:
        assert c.baseline_window_s is not None
        self.c, self.sources = c, [source]
        self.after, self.before = Moments(), Moments()

    def feed(self, chunk: Chunk) -> None:
        t_s, v = self.sources[0].block(chunk)
        self.after.add(_window(t_s, v, self.c.window_s)[1])
        self.before.add(_window(t_s, v, self.c.baseline_window_s)[1])

    def value(self) -> float:
        check_finite(self.c, self.after.samples + self.before.samples, self.after.rows + self.before.rows)
        rms_after, rms_before = pooled_value("rms", self.after), pooled_value("rms", self.before)
        return 100.0 * (rms_after / rms_before - 1.0) if rms_before > 0.0 else math.nan


class _PhaseLag(_Evaluator):
    def __init__(self, c: Criterion, fields: Mapping[str, Mapping[str, int]]) -> None:
        assert c.reference is not None and c.freq_hz is not None
        self.c = c
        # the signal as ``signal`` names it (checked first, as the batch does), then each at
        # its own instants: holding a 50 Hz series on the 400 Hz grid would add half a frame
        # (10 ms, 7 deg at 2 Hz) of lag
        self.ref = resolve(fields, c.reference, samples=True)
        self.sig = resolve(fields, c.signal, samples=True)
        self.sources = [resolve(fields, c.signal), self.ref, self.sig]
        self.fit_ref, self.fit_sig = SineFit(c.freq_hz), SineFit(c.freq_hz)
        self.samples = 0  # both signals' samples in the window, finite or not

    def feed(self, chunk: Chunk) -> None:
        for source, fit in ((self.ref, self.fit_ref), (self.sig, self.fit_sig)):
            t_s, v = _window(*source.block(chunk), self.c.window_s)
            if v.ndim != 1:
                raise ValueError(f"criterion {self.c.name!r}: phase_lag_deg needs one-column signals")
            ok = np.isfinite(v)
            self.samples += v.size
            fit.add(t_s[ok], v[ok])

    def value(self) -> float:
        check_finite(self.c, self.samples, self.fit_ref.n + self.fit_sig.n)
        if self.fit_ref.n < 8 or self.fit_sig.n < 8:
            return math.nan
        lag = self.fit_ref.phase_rad() - self.fit_sig.phase_rad()
        return math.degrees(math.remainder(lag, 2.0 * math.pi))


class _Step(_Evaluator):
    """overshoot, settling_time, rise_time (hil/analysis/criteria.py ``_metric``'s step branch)."""

    def __init__(self, c: Criterion, source: Source) -> None:
        self.c, self.sources = c, [source]
        self.samples = 0  # rows in the window
        self.finite = 0  # of which every column is finite
        self.pre = ExactSum()  # over [step_t - pre_step_s, step_t)
        self.levels: tuple[float, float] | None = None  # (start, target) once known
        self.waiting: list[tuple[np.ndarray, np.ndarray]] = []  # after the step, levels unknown
        self.config_error = ""  # raised by value() where the batch raises it
        self.n_after = 0
        self.vmax = -math.inf
        self.band = math.nan
        self.outside = False  # the last sample so far was outside the band
        self.t_settled: float | None = None  # the time after the last sample outside the band
        self.start = math.nan  # of the rise (the level before the step, or the first sample after)
        self.t10: float | None = None
        self.t90: float | None = None
        self.arrivals = _Arrivals(source, c.window_s)

    def feed(self, chunk: Chunk) -> None:
        c = self.c
        self.arrivals.feed(chunk)
        t_raw, v_raw = self.sources[0].block(chunk)
        t_s, v = _window(t_raw, v_raw, c.window_s)
        self.samples += v.shape[0]
        self.finite += finite_rows(v).shape[0]
        if c.step_t_s is None:
            return
        v1 = v if v.ndim == 1 else v.mean(axis=1)
        ok = np.isfinite(v1)  # the tolerated non-finite samples are left out
        t_s, v1 = t_s[ok], v1[ok]
        before = (t_s >= c.step_t_s - c.pre_step_s) & (t_s < c.step_t_s)
        self.pre.add(v1[before])
        after = t_s >= c.step_t_s
        if np.any(after):
            if self.levels is None:
                self.waiting.append((t_s[after], v1[after]))
            else:
                self._after(t_s[after], v1[after])
        if self.levels is None and (chunk.final or self._levels_known(t_raw)):
            self._set_levels()

    def _levels_known(self, t_raw: np.ndarray) -> bool:
        """Every sample the levels average has been fed (time order)."""
        c = self.c
        if t_raw.size == 0:
            return False
        assert c.step_t_s is not None
        last = float(t_raw[-1])
        return last >= c.step_t_s

    def _set_levels(self) -> None:
        c = self.c
        if c.step_size is None:
            if c.target is None:
                self.config_error = f"criterion {c.name!r}: metric {c.metric} needs target or step_size"
                self.levels = (math.nan, math.nan)
            else:
                self.levels = ((math.nan if c.start is None else c.start), c.target)
        elif not self.pre.count:
            self.levels = (math.nan, math.nan)
        else:
            level = self.pre.mean()
            self.levels = (level, level + c.step_size)
        start0, target = self.levels
        if c.band_fraction is not None:
            step = target - start0 if math.isfinite(start0) else math.nan
            self.band = c.band_fraction * abs(step)
        else:
            self.band = c.band if c.band is not None else 0.25
        self.start = start0
        waiting, self.waiting = self.waiting, []
        for t_s, v1 in waiting:
            self._after(t_s, v1)

    def _after(self, ts: np.ndarray, vs: np.ndarray) -> None:
        """Samples after the step, levels known."""
        assert self.levels is not None
        _, target = self.levels
        if self.n_after == 0 and not math.isfinite(self.start):
            self.start = float(vs[0])
        self.n_after += vs.size
        self.vmax = max(self.vmax, float(np.max(vs)))
        if math.isfinite(self.band):
            out = np.nonzero(np.abs(vs - target) > self.band)[0]
            if self.outside:
                self.t_settled = float(ts[0])
                self.outside = False
            if out.size:
                last = int(out[-1])
                self.outside = last == vs.size - 1
                self.t_settled = None if self.outside else float(ts[last + 1])
        span = target - self.start
        if self.t10 is None:
            hit = np.nonzero((vs - self.start) >= 0.1 * span)[0]
            self.t10 = float(ts[hit[0]]) if hit.size else None
        if self.t90 is None:
            hit = np.nonzero((vs - self.start) >= 0.9 * span)[0]
            self.t90 = float(ts[hit[0]]) if hit.size else None

    def value(self) -> float:
        c = self.c
        check_arrived(c, self.arrivals.count)
        check_finite(c, self.samples, self.finite)
        if self.samples == 0 or self.finite == 0:
            return math.nan
        if c.step_t_s is None:
            raise ValueError(f"criterion {c.name!r}: metric {c.metric} needs step_t_s")
        if self.levels is None:
            self._set_levels()
        assert self.levels is not None
        if self.config_error:
            raise ValueError(self.config_error)
        if not math.isfinite(self.levels[1]) or self.n_after == 0:
            return math.nan
        if c.metric == "overshoot":
            return self.vmax - self.levels[1]
        if c.metric == "settling_time":
            if not math.isfinite(self.band):
                raise ValueError(f"criterion {c.name!r}: band_fraction needs start or step_size")
            if self.outside:
                return math.inf
            if self.t_settled is None:
                return 0.0
            return self.t_settled - c.step_t_s
        if self.t10 is None or self.t90 is None:
            return math.inf
        return self.t90 - self.t10


def _evaluator(c: Criterion, fields: Mapping[str, Mapping[str, int]]) -> _Evaluator:
    if c.metric == "phase_lag_deg":
        return _PhaseLag(c, fields)
    source = resolve(fields, c.signal)
    if c.metric == "rms_change_pct":
        return _RmsChange(c, source)
    if c.metric in STEP:
        return _Step(c, source)
    return _Pooled(c, source)


class CriteriaStream:
    """A scenario's criteria, subscribed to the run's trace stream."""

    def __init__(self, criteria: list[Criterion], stream: TraceStream) -> None:
        self.stream = stream
        self.criteria = list(criteria)
        self._evaluators: list[_Evaluator | None] = []
        self._errors: list[Exception | None] = []
        for c in self.criteria:
            try:
                self._evaluators.append(_evaluator(c, stream.fields))
                self._errors.append(None)
            except (KeyError, ValueError) as exc:
                self._evaluators.append(None)
                self._errors.append(exc)
        # One subscriber per criterion: a deferred stream (realtime) hands chunks over one
        # call at a time in the ticks' spare time, and one criterion's work fits in it where
        # all of them (up to 2.3 ms) did not.
        for i in range(len(self.criteria)):
            stream.subscribe(partial(self._feed_one, i))

    def _feed_one(self, i: int, chunk: Chunk) -> None:
        e = self._evaluators[i]
        if e is None or self._errors[i] is not None:
            return
        try:
            e.feed(chunk)
        except Exception as exc:  # noqa: BLE001 - fails its criterion (with the reason), never the flight
            self._errors[i] = exc

    def results(self) -> list[CriterionResult]:
        """Every criterion's verdict (the stream is finished first)."""
        self.stream.finish()
        out: list[CriterionResult] = []
        for c, e, err in zip(self.criteria, self._evaluators, self._errors, strict=True):
            try:
                if e is not None:
                    for source in e.sources:
                        source.check(self.stream)
                if err is not None:
                    raise err
                assert e is not None
                value = e.value()
            except Exception as exc:  # noqa: BLE001 - an unknown signal, a bad parameter: this criterion fails
                out.append(failed(c, exc))
                continue
            out.append(result_of(c, value))
        return out
