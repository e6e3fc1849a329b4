"""Pass/fail criteria of a scenario, evaluated on the run's trace.

Metrics (all over the criterion's window, sim seconds):

| metric | value |
|---|---|
| max_abs, rms, mean, min, max, final, p99_abs | of the signal (all columns pooled) |
| amplitude | (max - min) / 2 |
| rms_delta | RMS of the sample-to-sample change (control activity; chatter shows here) |
| overshoot | max(signal) - target after ``step_t_s`` (the step's direction is up) |
| settling_time | time after ``step_t_s`` from which the signal stays within ``band`` of ``target`` |
| rise_time | 10 % -> 90 % time of the step from ``start`` to ``target`` after ``step_t_s`` |
| fraction_saturated | fraction of samples with any column <= ``lo`` or >= ``hi`` |
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hil.scenario import Criterion
from hil.trace import Trace


@dataclass(frozen=True)
class CriterionResult:
    name: str
    signal: str
    metric: str
    value: float
    bound: str
    passed: bool
    detail: str = ""


def _window(t_s: np.ndarray, values: np.ndarray, window: tuple[float, float] | None) -> tuple[np.ndarray, np.ndarray]:
    if window is None:
        return t_s, values
    mask = (t_s >= window[0]) & (t_s <= window[1])
    return t_s[mask], values[mask]


def _metric(c: Criterion, t_s: np.ndarray, v: np.ndarray) -> float:
    if v.size == 0:
        return math.nan
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
    if m == "p99_abs":
        return float(np.percentile(np.abs(flat), 99))
    if m == "amplitude":
        return float((np.max(flat) - np.min(flat)) / 2)
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
    # step metrics
    if c.target is None or c.step_t_s is None:
        raise ValueError(f"criterion {c.name!r}: metric {m} needs target and step_t_s")
    after = t_s >= c.step_t_s
    ts, vs = t_s[after], (v if v.ndim == 1 else v.mean(axis=1))[after]
    if vs.size == 0:
        return math.nan
    if m == "overshoot":
        return float(np.max(vs) - c.target)
    if m == "settling_time":
        band = c.band if c.band is not None else 0.25
        outside = np.nonzero(np.abs(vs - c.target) > band)[0]
        if outside.size == 0:
            return 0.0
        last = outside[-1]
        if last == vs.size - 1:
            return math.inf
        return float(ts[last + 1] - c.step_t_s)
    if m == "rise_time":
        start = c.start if c.start is not None else float(vs[0])
        span = c.target - start
        at_10 = np.nonzero((vs - start) >= 0.1 * span)[0]
        at_90 = np.nonzero((vs - start) >= 0.9 * span)[0]
        if at_10.size == 0 or at_90.size == 0:
            return math.inf
        return float(ts[at_90[0]] - ts[at_10[0]])
    raise ValueError(f"unknown metric {m}")


def evaluate(criteria: list[Criterion], trace: Trace) -> list[CriterionResult]:
    """Evaluate every criterion; an unknown signal or a NaN value fails (with a reason)."""
    results: list[CriterionResult] = []
    for c in criteria:
        bound = " and ".join(
            s for s in (f">= {c.min:g}" if c.min is not None else "", f"<= {c.max:g}" if c.max is not None else "") if s
        )
        try:
            t_s, values = trace.signal(c.signal)
            t_w, v_w = (t_s, values) if c.metric in {"overshoot", "settling_time", "rise_time"} else _window(
                t_s, values, c.window_s
            )
            if c.metric in {"overshoot", "settling_time", "rise_time"} and c.window_s is not None:
                t_w, v_w = _window(t_s, values, c.window_s)
            value = _metric(c, t_w, v_w)
        except (KeyError, ValueError) as exc:
            results.append(CriterionResult(c.name, c.signal, c.metric, math.nan, bound, False, str(exc)))
            continue
        ok = math.isfinite(value) or (value == math.inf and c.max is None)
        if c.max is not None and not value <= c.max:
            ok = False
        if c.min is not None and not value >= c.min:
            ok = False
        detail = "" if math.isfinite(value) else "no data in the window" if math.isnan(value) else "never settled"
        results.append(CriterionResult(c.name, c.signal, c.metric, value, bound, bool(ok), detail))
    return results
