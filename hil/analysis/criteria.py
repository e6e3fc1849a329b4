"""Pass/fail criteria of a scenario, evaluated on a whole-run trace (batch).

A run evaluates its criteria as it streams (hil/analysis/criteria_stream.py), in flat memory; this
batch evaluation on a kept :class:`~hil.analysis.trace.Trace` is the reference the streaming one is
tested against, and what a test can run on ``RunResult.trace``. The verdict helpers
(:func:`result_of`, :func:`failed`) are shared by both.

Metrics (all over the criterion's window, sim seconds):

| metric | value |
|---|---|
| max_abs, rms, mean, min, max, final, p99_abs | of the signal (all columns pooled) |
| amplitude | (max - min) / 2 |
| increase | last - first sample of the window (a counter's count within the window, not since boot) |
| rms_delta | RMS of the sample-to-sample change (control activity; chatter shows here) |
| std | standard deviation (about the window's mean; an altitude hold's spread) |
| overshoot | max(signal) - target after ``step_t_s`` (the step's direction is up) |
| settling_time | time after ``step_t_s`` from which the signal stays within ``band`` of ``target`` |
| rise_time | 10 % -> 90 % time of the step from ``start`` to ``target`` after ``step_t_s`` |
| fraction_saturated | fraction of samples with any column <= ``lo`` or >= ``hi`` |
| fraction_in | fraction of samples with every column in [``lo``, ``hi``] (a reported mode: ``lo = hi`` = its number) |
| fraction_finite | fraction of samples that are finite (a downlink that must say "no value": ``max = 0``); non-finite samples are what it counts, so they never fail it |
| phase_lag_deg | phase of ``reference`` minus phase of ``signal`` at ``freq_hz`` (least-squares sine fit over the window, each at its own sample instants; positive = the signal lags) |
| rms_change_pct | 100 (RMS over ``window_s`` / RMS over ``baseline_window_s`` - 1) |

Step metrics judge the commanded step: their target is either absolute (``target``,
``start``) or relative to the level before the step (``step_size``: target = mean over
``pre_step_s`` before ``step_t_s`` + step_size, start = that mean), never the level the
signal reached (a step of the wrong size would define its own target). ``band_fraction``
sets the settling band as a fraction of the commanded step; ``overshoot`` is negative when
the signal never reaches the target, and needs ``min`` as well as ``max``.

Non-finite samples (NaN, inf) in a criterion's window fail it, unless the criterion states
the share it tolerates (``nonfinite_fraction_max``); the tolerated ones are left out of the
metric. A whole row counts as non-finite when any of its columns is.

A window with no sample of its signal fails, naming the window. An irregular series (the
telemetry, ``tm.*``) is held on the tick grid; a window in which none of its samples arrived
fails too (:class:`NoArrival`): the held value is an older reading, and a flight code that
stopped reporting must not pass on what it said before.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hil.analysis.online_stats import ExactSum
from hil.config.scenario import Criterion
from hil.analysis.trace import Trace


@dataclass(frozen=True)
class CriterionResult:
    name: str
    signal: str
    metric: str
    value: float
    bound: str
    passed: bool
    detail: str = ""
    #: False: the criterion could not be judged (a compute budget on a rig without a calibrated
    #: ``cpu_scale``); it does not fail the run, and the summary shows "not judged", never "pass"
    judged: bool = True
    #: signed distance from the nearest bound in the metric's units, >= 0 when it passes (a
    #: near-miss shows as a small number of either sign); -inf when no value could be judged,
    #: +inf when no bound limits it; NaN when not judged
    margin: float = math.nan

    @property
    def verdict(self) -> str:
        """"pass", "FAIL" or "not judged"."""
        if not self.judged:
            return "not judged"
        return "pass" if self.passed else "FAIL"


class NonFinite(ValueError):
    """More non-finite samples in a criterion's window than it tolerates."""


class NoArrival(ValueError):
    """No sample of an irregular series (telemetry) arrived in a criterion's window: the values
    held on the tick grid there are an older reading, and judging them would judge the past."""

    def __init__(self, c: Criterion, series: str) -> None:
        assert c.window_s is not None
        super().__init__(f"no sample of {series} arrived in [{c.window_s[0]:g}, {c.window_s[1]:g}] s "
                         "(a value held from before is not a reading)")


def check_arrived(c: Criterion, arrived: dict[str, int]) -> None:
    """Raise :class:`NoArrival` for the first held series with no sample in ``c``'s window
    (``arrived``: series -> samples stamped in it)."""
    for series, n in arrived.items():
        if n == 0 and c.window_s is not None:
            raise NoArrival(c, series)


def check_finite(c: Criterion, samples: int, finite: int) -> None:
    """Raise :class:`NonFinite` when more of ``samples`` rows are non-finite than ``c`` tolerates."""
    bad = samples - finite
    if bad > 0 and bad > c.nonfinite_fraction_max * samples:
        raise NonFinite(f"{bad} of {samples} samples non-finite (tolerates a share of {c.nonfinite_fraction_max:g})")


def _finite_count(v: np.ndarray) -> int:
    if v.ndim == 1:
        return int(np.count_nonzero(np.isfinite(v)))
    return int(np.count_nonzero(np.all(np.isfinite(v), axis=1)))


def _window(t_s: np.ndarray, values: np.ndarray, window: tuple[float, float] | None) -> tuple[np.ndarray, np.ndarray]:
    if window is None:
        return t_s, values
    mask = (t_s >= window[0]) & (t_s <= window[1])
    return t_s[mask], values[mask]


def _sine_phase_rad(t_s: np.ndarray, v: np.ndarray, freq_hz: float) -> float:
    """Phase of the ``freq_hz`` component of ``v`` (least squares on sin, cos and an offset)."""
    w = 2.0 * math.pi * freq_hz
    a = np.column_stack([np.sin(w * t_s), np.cos(w * t_s), np.ones_like(t_s)])
    (s, c, _), *_ = np.linalg.lstsq(a, v, rcond=None)
    return math.atan2(float(c), float(s))


def _mean(v: np.ndarray) -> float:
    """The mean rounded once (the streaming criteria's is the same to the bit)."""
    total = ExactSum()
    total.add(v)
    return total.mean()


def _step_levels(c: Criterion, t_s: np.ndarray, v: np.ndarray) -> tuple[float, float]:
    """(start, target) of a step criterion (absolute or relative to the pre-step level)."""
    assert c.step_t_s is not None
    before = (t_s >= c.step_t_s - c.pre_step_s) & (t_s < c.step_t_s)
    if c.step_size is None:
        if c.target is None:
            raise ValueError(f"criterion {c.name!r}: metric {c.metric} needs target or step_size")
        return (math.nan if c.start is None else c.start), c.target
    if not np.any(before):
        return math.nan, math.nan
    level = _mean(v[before])
    return level, level + c.step_size


def _metric(c: Criterion, t_s: np.ndarray, v: np.ndarray) -> float:
    if v.size == 0:
        return math.nan
    if c.metric == "fraction_finite":
        return _finite_count(v) / v.shape[0]
    flat = v[np.isfinite(v)] if v.ndim == 1 else v[np.all(np.isfinite(v), axis=1)]
    if flat.size == 0:
        return math.nan
    m = c.metric
    if m == "max_abs":
        return float(np.max(np.abs(flat)))
    if m == "rms":
        return float(np.sqrt(np.mean(np.square(flat))))
    if m == "mean":
        return float(np.mean(flat))
    if m == "min":
        return float(np.min(flat))
    if m == "max":
        return float(np.max(flat))
    if m == "final":
        return float(np.mean(flat[-1]))
    if m == "increase":
        return float(np.mean(flat[-1]) - np.mean(flat[0]))
    if m == "p99_abs":
        return float(np.percentile(np.abs(flat), 99))
    if m == "amplitude":
        return float((np.max(flat) - np.min(flat)) / 2)
    if m == "std":
        return float(np.std(flat))
    if m == "rms_delta":
        d = np.diff(flat, axis=0)
        return float(np.sqrt(np.mean(np.square(d)))) if d.size else 0.0
    if m == "fraction_saturated":
        lo = -math.inf if c.lo is None else c.lo
        hi = math.inf if c.hi is None else c.hi
        sat = (flat <= lo) | (flat >= hi)
        if sat.ndim == 2:
            sat = np.any(sat, axis=1)
        return float(np.mean(sat))
    if m == "fraction_in":
        lo = -math.inf if c.lo is None else c.lo
        hi = math.inf if c.hi is None else c.hi
        inside = (flat >= lo) & (flat <= hi)
        if inside.ndim == 2:
            inside = np.all(inside, axis=1)
        return float(np.mean(inside))
    # step metrics
    if c.step_t_s is None:
        raise ValueError(f"criterion {c.name!r}: metric {m} needs step_t_s")
    v1 = v if v.ndim == 1 else v.mean(axis=1)
    ok = np.isfinite(v1)  # the tolerated non-finite samples are left out
    t_s, v1 = t_s[ok], v1[ok]
    start0, target = _step_levels(c, t_s, v1)
    if not math.isfinite(target):
        return math.nan
    after = t_s >= c.step_t_s
    ts, vs = t_s[after], v1[after]
    if vs.size == 0:
        return math.nan
    if m == "overshoot":
        return float(np.max(vs) - target)
    if m == "settling_time":
        if c.band_fraction is not None:
            step = target - start0 if math.isfinite(start0) else math.nan
            band = c.band_fraction * abs(step)
            if not math.isfinite(band):
                raise ValueError(f"criterion {c.name!r}: band_fraction needs start or step_size")
        else:
            band = c.band if c.band is not None else 0.25
        outside = np.nonzero(np.abs(vs - target) > band)[0]
        if outside.size == 0:
            return 0.0
        last = outside[-1]
        if last == vs.size - 1:
            return math.inf
        return float(ts[last + 1] - c.step_t_s)
    if m == "rise_time":
        start = start0 if math.isfinite(start0) else float(vs[0])
        span = target - start
        at_10 = np.nonzero((vs - start) >= 0.1 * span)[0]
        at_90 = np.nonzero((vs - start) >= 0.9 * span)[0]
        if at_10.size == 0 or at_90.size == 0:
            return math.inf
        return float(ts[at_90[0]] - ts[at_10[0]])
    raise ValueError(f"unknown metric {m}")


def _phase_lag_deg(c: Criterion, trace: Trace, t_s: np.ndarray, values: np.ndarray) -> float:
    assert c.reference is not None and c.freq_hz is not None
    # each at its own instants: holding a 50 Hz series on the 400 Hz grid would add half a
    # frame (10 ms, 7 deg at 2 Hz) of lag
    t_r, ref = trace.samples(c.reference)
    t_s, values = trace.samples(c.signal)
    t_a, a = _window(t_s, values, c.window_s)
    t_b, b = _window(t_r, ref, c.window_s)
    ok_a, ok_b = np.isfinite(a), np.isfinite(b)
    check_finite(c, a.size + b.size, int(np.count_nonzero(ok_a)) + int(np.count_nonzero(ok_b)))
    if np.count_nonzero(ok_a) < 8 or np.count_nonzero(ok_b) < 8:
        return math.nan
    lag = _sine_phase_rad(t_b[ok_b], b[ok_b], c.freq_hz) - _sine_phase_rad(t_a[ok_a], a[ok_a], c.freq_hz)
    return math.degrees(math.remainder(lag, 2.0 * math.pi))


def bound_text(c: Criterion) -> str:
    """The criterion's bounds as the summary shows them (">= 1 and <= 3")."""
    return " and ".join(
        s for s in (f">= {c.min:g}" if c.min is not None else "", f"<= {c.max:g}" if c.max is not None else "") if s
    )


def margin_of(value: float, lo: float | None, hi: float | None) -> float:
    """Signed margin of ``value`` inside ``[lo, hi]`` (either may be absent), in its units: the
    distance to the nearest bound, >= 0 inside. NaN and -inf never pass (-inf); +inf passes
    only with no upper bound."""
    if math.isnan(value) or value == -math.inf:
        return -math.inf
    margin = math.inf
    if lo is not None:
        margin = min(margin, value - lo)
    if hi is not None:
        margin = min(margin, hi - value)
    return margin


def no_data_detail(c: Criterion) -> str:
    """Why a criterion has no value: its window held no sample of its signal."""
    where = f"in [{c.window_s[0]:g}, {c.window_s[1]:g}] s" if c.window_s is not None else "in the run"
    return f"no sample of {c.signal} {where}"


def result_of(c: Criterion, value: float) -> CriterionResult:
    """The verdict on a metric's value: NaN fails (naming the empty window); +inf passes only
    with no upper bound. It passes exactly when its margin is >= 0."""
    margin = margin_of(value, c.min, c.max)
    detail = "" if math.isfinite(value) else no_data_detail(c) if math.isnan(value) else "never settled"
    return CriterionResult(c.name, c.signal, c.metric, value, bound_text(c), margin >= 0.0, detail, margin=margin)


def failed(c: Criterion, exc: Exception) -> CriterionResult:
    """A criterion that could not be evaluated (an unknown signal, a missing parameter)."""
    return CriterionResult(c.name, c.signal, c.metric, math.nan, bound_text(c), False, str(exc), margin=-math.inf)


def evaluate(criteria: list[Criterion], trace: Trace) -> list[CriterionResult]:
    """Evaluate every criterion on the whole-run trace; an unknown signal, a NaN value or
    non-finite samples beyond the criterion's tolerance fail (with a reason). The reference for the streaming criteria (hil/analysis/criteria_stream.py)."""
    results: list[CriterionResult] = []
    for c in criteria:
        try:
            t_s, values = trace.signal(c.signal)
            if c.metric == "phase_lag_deg":
                value = _phase_lag_deg(c, trace, t_s, values)
            elif c.metric == "rms_change_pct":
                assert c.baseline_window_s is not None
                _, after = _window(t_s, values, c.window_s)
                _, before = _window(t_s, values, c.baseline_window_s)
                check_finite(c, after.shape[0] + before.shape[0], _finite_count(after) + _finite_count(before))
                rms_after = _metric(c.model_copy(update={"metric": "rms"}), t_s, after)
                rms_before = _metric(c.model_copy(update={"metric": "rms"}), t_s, before)
                value = 100.0 * (rms_after / rms_before - 1.0) if rms_before > 0.0 else math.nan
            else:
                if c.window_s is not None:
                    check_arrived(c, {name: _window(*trace.samples(name), c.window_s)[1].shape[0]
                                      for name in trace.held_series(c.signal)})
                t_w, v_w = _window(t_s, values, c.window_s)
                if c.metric != "fraction_finite":  # which measures just that
                    check_finite(c, v_w.shape[0], _finite_count(v_w))
                value = _metric(c, t_w, v_w)
        except (KeyError, ValueError) as exc:
            results.append(failed(c, exc))
            continue
        results.append(result_of(c, value))
    return results
