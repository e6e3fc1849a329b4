"""The streaming criteria give what the batch criteria give on the whole-run trace.

Property tests (hypothesis): random traces (tick groups with NaNs, an irregular series whose
points arrive late, as telemetry does) fed at once to the whole-run ``Trace`` (the batch
reference, hil/analysis/criteria.py) and to the ``TraceStream`` with its ``CriteriaStream``, in chunks
of random size; every criterion's value agrees to rounding.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from hil.analysis.criteria import CriterionResult, evaluate
from hil.analysis.criteria_stream import CriteriaStream
from hil.config.scenario import Criterion
from hil.analysis.trace import Trace
from hil.analysis.trace_stream import TraceStream, TraceTee

TICK_NS = 25_000_000  # coarse ticks: a few hundred cover seconds of windows and steps
METRICS = ["max_abs", "rms", "mean", "min", "max", "final", "p99_abs", "amplitude", "std", "rms_delta",
           "overshoot", "settling_time", "fraction_saturated", "rise_time", "phase_lag_deg", "rms_change_pct", "increase",
           "fraction_in", "fraction_finite"]
SIGNALS = ["truth.a", "truth.b", "esc.p", "esc.p[1]", "tm.x", "truth.a - tm.x", "tm.x - truth.b",
           "truth.a - truth.b", "truth.a - esc.p[2]", "tm.missing", "truth.nope"]
#: one-column signals (a phase fit of a 3-column field is an error in both, differently)
SCALARS = [s for s in SIGNALS if s != "esc.p"]

values = st.one_of(st.floats(-50, 50, allow_nan=False), st.sampled_from([0.0, 1.0, 2.0, -1.0]))
values_nan = st.one_of(values, st.just(math.nan))
times_s = st.floats(-0.5, 8.0, allow_nan=False)


@st.composite
def windows(draw) -> tuple[float, float] | None:
    if draw(st.booleans()):
        return None
    a, b = sorted((draw(times_s), draw(times_s)))
    return (a, b)


@st.composite
def criteria(draw) -> Criterion:
    metric = draw(st.sampled_from(METRICS))
    signals = SCALARS if metric == "phase_lag_deg" else SIGNALS
    kw: dict[str, object] = {"name": "c", "signal": draw(st.sampled_from(signals)), "metric": metric, "max": 1.0}
    if metric == "overshoot":
        kw["min"] = -1.0
    kw["window_s"] = draw(windows())
    kw["nonfinite_fraction_max"] = draw(st.sampled_from([0.0, 0.0, 0.3, 1.0]))
    if metric in ("fraction_saturated", "fraction_in"):
        kw["lo"], kw["hi"] = draw(st.sampled_from([None, -1.0, 0.0])), draw(st.sampled_from([None, 1.0, 2.0, 30.0]))
    if metric in ("overshoot", "settling_time", "rise_time"):
        kw["step_t_s"] = None if draw(st.integers(0, 9)) == 0 else draw(times_s)
        kind = draw(st.sampled_from(["target", "step_size", "none"]))
        if kind == "target":
            kw["target"] = draw(st.floats(-10, 10))
        elif kind == "step_size":
            kw["step_size"] = draw(st.floats(-10, 10))
        kw["start"] = draw(st.one_of(st.none(), st.floats(-10, 10)))
        kw["pre_step_s"] = draw(st.floats(0.05, 3.0))
        kw["band"] = draw(st.one_of(st.none(), st.floats(0.0, 5.0)))
        kw["band_fraction"] = draw(st.one_of(st.none(), st.floats(0.01, 0.5)))
    if metric == "phase_lag_deg":
        kw["reference"] = draw(st.sampled_from(SCALARS))
        kw["freq_hz"] = draw(st.floats(0.2, 3.0))
    if metric == "rms_change_pct":
        kw["window_s"] = draw(windows().filter(lambda w: w is not None))
        kw["baseline_window_s"] = draw(windows().filter(lambda w: w is not None))
    try:
        return Criterion(**kw)
    except ValueError:
        assume(False)
        raise


@st.composite
def flights(draw) -> dict[str, object]:
    n = draw(st.integers(0, 320))
    t0_ns = draw(st.sampled_from([0, TICK_NS // 2, 3 * TICK_NS]))
    v = draw(st.sampled_from([values, values_nan]))  # a NaN anywhere makes most step metrics NaN
    truth = draw(st.lists(st.tuples(v, v), min_size=n, max_size=n))
    esc = draw(st.lists(st.tuples(v, v, v), min_size=n, max_size=n))
    # an irregular series: stamps in order, each arriving up to max_delay later, in order
    max_delay_ns = draw(st.sampled_from([0, TICK_NS, 7 * TICK_NS]))
    stamps = sorted(draw(st.lists(st.integers(-TICK_NS, (n + 3) * TICK_NS), max_size=60)))
    points, arrival = [], -(10**18)
    for stamp in stamps:
        arrival = max(arrival, stamp + draw(st.integers(0, max_delay_ns)))
        points.append((arrival, stamp, draw(v)))
    return {"n": n, "t0_ns": t0_ns, "truth": truth, "esc": esc, "points": points, "max_delay_ns": max_delay_ns,
            "chunk_ticks": draw(st.integers(1, 40))}


Results = list[CriterionResult]


def fly(flight: dict[str, object], crits: list[Criterion],
        calls_per_tick: int | None = None) -> tuple[Results, Results, TraceStream]:
    """Batch and streamed results of ``crits`` on one synthetic flight; ``calls_per_tick``:
    a deferred stream (realtime), pumped this many subscriber calls after every tick."""
    trace = Trace()
    stream = TraceStream(horizon_ns=int(flight["max_delay_ns"]) + TICK_NS, chunk_ticks=int(flight["chunk_ticks"]),
                         deferred=calls_per_tick is not None)
    sink = TraceTee(trace, stream)
    sink.define("truth", {"a": 1, "b": 1})
    sink.define("esc", {"p": 3})
    streamed = CriteriaStream(crits, stream)
    points = list(flight["points"])  # type: ignore[call-overload]
    for k in range(int(flight["n"])):
        t_ns = int(flight["t0_ns"]) + k * TICK_NS
        while points and points[0][0] <= t_ns:  # arrived before this tick's rows
            _, stamp, v = points.pop(0)
            sink.point("tm.x", stamp, v)
        sink.row("truth", t_ns, flight["truth"][k])  # type: ignore[index]
        sink.row("esc", t_ns, flight["esc"][k])  # type: ignore[index]
        if calls_per_tick is not None:
            budget = iter(range(calls_per_tick))
            stream.pump(lambda: next(budget, None) is not None)
    for _, stamp, v in points:
        sink.point("tm.x", stamp, v)
    return evaluate(crits, trace), streamed.results(), stream


def assert_same(batch: list[CriterionResult], streamed: list[CriterionResult]) -> None:
    assert len(batch) == len(streamed)
    for b, s in zip(batch, streamed, strict=True):
        assert b.detail == s.detail, (b, s)
        if math.isnan(b.value) or math.isinf(b.value):
            assert b.value == s.value or (math.isnan(b.value) and math.isnan(s.value)), (b, s)
        else:
            assert math.isclose(b.value, s.value, rel_tol=1e-7, abs_tol=1e-7), (b, s)
            if not math.isclose(b.value, 1.0, rel_tol=1e-6):  # the bound: rounding may land either side
                assert b.passed == s.passed, (b, s)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(flight=flights(), crits=st.lists(criteria(), min_size=1, max_size=4))
def test_streaming_equals_batch(flight: dict[str, object], crits: list[Criterion]) -> None:
    batch, streamed, stream = fly(flight, crits)
    assert stream.late_points == 0
    assert_same(batch, streamed)


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(flight=flights(), crits=st.lists(criteria(), min_size=1, max_size=4), calls=st.integers(0, 3))
def test_a_deferred_stream_pumped_in_slices_equals_batch(flight: dict[str, object], crits: list[Criterion],
                                                        calls: int) -> None:
    """Realtime: the criteria's chunks reach them a few calls a tick (none at all: at the end)."""
    batch, streamed, stream = fly(flight, crits, calls_per_tick=calls)
    assert stream.late_points == 0 and stream.queued_chunks == 0
    assert_same(batch, streamed)


bounds = st.sampled_from([(None, 1.0), (0.5, None), (-5.0, 10.0), (0.0, 0.0), (1.0, 1.0), (None, 0.0)])


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(flight=flights(), crits=st.lists(criteria(), min_size=1, max_size=4), limits=st.lists(bounds, min_size=4,
                                                                                           max_size=4))
def test_the_margins_sign_is_the_verdict(flight: dict[str, object], crits: list[Criterion],
                                         limits: list[tuple[float | None, float | None]]) -> None:
    """On random traces, batch and streamed: a criterion passes exactly when its margin is >= 0,
    and the margin is the value's distance to its nearest bound, in the metric's units."""
    crits = [c.model_copy(update={"min": lo, "max": hi}) for c, (lo, hi) in zip(crits, limits, strict=False)]
    batch, streamed, _ = fly(flight, crits)
    for c, r in [*zip(crits, batch, strict=True), *zip(crits, streamed, strict=True)]:
        assert r.passed == (r.margin >= 0.0), r
        if math.isfinite(r.value):
            nearest = min(r.value - c.min if c.min is not None else math.inf,
                          c.max - r.value if c.max is not None else math.inf)
            assert r.margin == nearest, r
        elif math.isnan(r.value):
            assert r.margin == -math.inf and not r.passed, r
        else:  # +inf (never settled, never rose): only an unbounded side passes it
            assert r.passed == (c.max is None and r.value > 0), r


@st.composite
def sines(draw) -> dict[str, object]:
    """A reference sine and a lagged, noisy copy, over at least one period."""
    freq_hz = draw(st.floats(0.3, 3.0))
    n = draw(st.integers(int(1.2 / freq_hz / (TICK_NS / 1e9)) + 10, 400))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    lag_rad = draw(st.floats(-3.0, 3.0))
    t = np.arange(n) * TICK_NS / 1e9
    w = 2 * math.pi * freq_hz
    a = draw(st.floats(0.5, 20.0))
    ref = a * np.sin(w * t) + draw(st.floats(-5, 5))
    sig = 0.8 * a * np.sin(w * t - lag_rad) + rng.normal(0, 0.1 * a, n)
    return {"n": n, "t0_ns": 0, "truth": list(zip(sig.tolist(), ref.tolist(), strict=True)),
            "esc": [(0.0, 0.0, 0.0)] * n,
            "points": [(int(k * TICK_NS), int(k * TICK_NS), float(ref[k])) for k in range(0, n, 3)],
            "max_delay_ns": 0, "chunk_ticks": draw(st.integers(1, 60)), "freq_hz": freq_hz}


@settings(max_examples=100, deadline=None)
@given(flight=sines(), reference=st.sampled_from(["truth.b", "tm.x"]))
def test_phase_lag_streaming_equals_batch(flight: dict[str, object], reference: str) -> None:
    c = Criterion(name="lag", signal="truth.a", metric="phase_lag_deg", reference=reference,
                  freq_hz=float(flight["freq_hz"]), max=180.0)  # type: ignore[arg-type]
    batch, streamed, _ = fly(flight, [c])
    assert math.isfinite(batch[0].value)
    assert math.isclose(batch[0].value, streamed[0].value, abs_tol=1e-6), (batch, streamed)


def test_a_late_point_is_counted() -> None:
    stream = TraceStream(horizon_ns=TICK_NS, chunk_ticks=1)
    stream.define("truth", {"a": 1})
    for k in range(10):
        stream.row("truth", k * TICK_NS, (float(k),))
    stream.point("tm.x", 0, 1.0)  # stamped at a tick that left long ago
    stream.finish()
    assert stream.late_points == 1


def test_groups_off_the_grid_are_refused() -> None:
    stream = TraceStream(horizon_ns=0, chunk_ticks=1)
    stream.define("truth", {"a": 1})
    stream.define("esc", {"p": 1})
    stream.row("esc", 5, (1.0,))
    with pytest.raises(ValueError, match="tick grid"):
        stream.row("truth", 0, (1.0,))
        stream.finish()


def test_what_the_batch_crashes_on_fails_the_criterion() -> None:
    """A column past the field's width (the batch raises IndexError out of evaluate) and a phase
    fit of a multi-column signal fail their criterion with a reason."""
    flight = {"n": 50, "t0_ns": 0, "truth": [(1.0, 2.0)] * 50, "esc": [(1.0, 2.0, 3.0)] * 50, "points": [],
              "max_delay_ns": 0, "chunk_ticks": 7}
    stream = TraceStream(chunk_ticks=7)
    stream.define("truth", {"a": 1, "b": 1})
    stream.define("esc", {"p": 3})
    crits = [Criterion(name="col", signal="esc.p[5]", metric="max", max=1.0),
             Criterion(name="lag", signal="esc.p", metric="phase_lag_deg", reference="truth.a", freq_hz=1.0, max=1.0)]
    streamed = CriteriaStream(crits, stream)
    for k in range(int(flight["n"])):
        stream.row("truth", k * TICK_NS, (1.0, 2.0))
        stream.row("esc", k * TICK_NS, (1.0, 2.0, 3.0))
    col, lag = streamed.results()
    assert not col.passed and "esc.p has 3 column(s)" in col.detail
    assert not lag.passed and "one-column" in lag.detail


@st.composite
def steps(draw) -> tuple[dict[str, object], list[Criterion]]:
    """A damped step response with noise, and step criteria of every kind on it."""
    n = draw(st.integers(40, 320))
    step_t_s = draw(st.floats(0.5, 4.0))
    level, size = draw(st.floats(-5, 5)), draw(st.floats(-4, 4).filter(lambda x: abs(x) > 0.1))
    damping, noise = draw(st.floats(0.5, 4.0)), draw(st.floats(0.0, 0.2))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    t = np.arange(n) * TICK_NS / 1e9
    tau = np.clip(t - step_t_s, 0, None)
    h = level + size * (1 - np.exp(-damping * tau) * (np.cos(2 * tau) + 0.75 * np.sin(2 * tau))) * (t >= step_t_s)
    h = h + rng.normal(0, noise, n)
    flight = {"n": n, "t0_ns": 0, "truth": [(0.0, float(x)) for x in h], "esc": [(float(x), 0.0, 0.0) for x in h],
              "points": [(int(k * TICK_NS), int(k * TICK_NS), float(h[k])) for k in range(0, n, 4)],
              "max_delay_ns": 0, "chunk_ticks": draw(st.integers(1, 60))}
    crits = []
    for metric in ("overshoot", "settling_time", "rise_time"):
        window = None if draw(st.booleans()) else (0.0, float(t[-1]) * draw(st.floats(0.5, 1.0)))
        kw: dict[str, object] = {"name": metric, "metric": metric, "max": 100.0, "min": -100.0, "step_t_s": step_t_s, "window_s": window,
                                 "signal": draw(st.sampled_from(["truth.b", "tm.x", "esc.p[0]", "truth.b - truth.a"]))}
        if draw(st.booleans()):
            kw["target"], kw["start"] = level + size, draw(st.one_of(st.none(), st.just(level)))
        else:
            kw["step_size"] = size
        if draw(st.booleans()):
            kw["band_fraction"] = draw(st.floats(0.02, 0.3))
        else:
            kw["band"] = draw(st.floats(0.01, 1.0))
        crits.append(Criterion(**kw))
    return flight, crits


@settings(max_examples=150, deadline=None)
@given(case=steps())
def test_step_metrics_streaming_equals_batch(case: tuple[dict[str, object], list[Criterion]]) -> None:
    flight, crits = case
    batch, streamed, _ = fly(flight, crits)
    assert_same(batch, streamed)


def test_a_level_on_the_band_edge_lands_on_the_same_side_in_both() -> None:
    """Found by hypothesis: a flat signal whose pre-step level, summed tick by tick, came out a
    bit off ``numpy.mean``'s, so |v - target| fell either side of the band (settled at once in
    the batch, never settled in the stream). Both now round the level's sum once."""
    level = 1.2778898140690313
    n = 41
    flight = {"n": n, "t0_ns": 0, "truth": [(0.0, level)] * n, "esc": [(level, 0.0, 0.0)] * n,
              "points": [(k * TICK_NS, k * TICK_NS, level) for k in range(0, n, 4)], "max_delay_ns": 0,
              "chunk_ticks": 1}
    crit = Criterion(name="settling_time", signal="truth.b", metric="settling_time", window_s=(0.0, 1.0),
                     max=100.0, band=1.0, step_t_s=1.0, step_size=1.0)
    batch, streamed, _ = fly(flight, [crit])
    assert_same(batch, streamed)
    assert batch[0].value == streamed[0].value
