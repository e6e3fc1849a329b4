"""Criteria metrics on synthetic traces with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hil.analysis.criteria import evaluate
from hil.config.scenario import Criterion
from hil.analysis.trace import Trace

TICK = 2_500_000


def _trace(fn, n: int = 4000) -> Trace:
    tr = Trace()
    tr.define("truth", {"roll_deg": 1, "h_m": 1})
    tr.define("esc", {"pulse_us": 4})
    for k in range(n):
        t = k * TICK
        roll, h, pulses = fn(t / 1e9)
        tr.row("truth", t, (roll, h))
        tr.row("esc", t, tuple(pulses))
    return tr


def _c(**kw) -> Criterion:
    kw.setdefault("name", "c")
    return Criterion(**kw)


def test_window_metrics_on_a_sine() -> None:
    tr = _trace(lambda t: (2.0 * math.sin(2 * math.pi * t), 0.0, (1500,) * 4))
    res = evaluate(
        [
            _c(signal="truth.roll_deg", metric="max_abs", window_s=(1, 9), max=2.01),
            _c(signal="truth.roll_deg", metric="rms", window_s=(1, 9), max=1.0),
            _c(signal="truth.roll_deg", metric="amplitude", window_s=(1, 9), min=1.99),
        ],
        tr,
    )
    assert [r.passed for r in res] == [True, False, True]
    assert res[1].value == pytest.approx(2 / math.sqrt(2), rel=1e-3)


def test_step_metrics() -> None:
    # second-order-like step from 0 to 5 at t=2 with overshoot 0.5 and settling ~ known
    def fn(t: float):
        if t < 2:
            return 0.0, 0.0, (1500,) * 4
        tau = t - 2
        h = 5 * (1 - math.exp(-1.5 * tau) * (math.cos(2 * tau) + 0.75 * math.sin(2 * tau)))
        return 0.0, h, (1500,) * 4

    tr = _trace(fn)
    over, settle, rise = evaluate(
        [
            _c(signal="truth.h_m", metric="overshoot", target=5, step_t_s=2, max=1.0),
            _c(signal="truth.h_m", metric="settling_time", target=5, band=0.25, step_t_s=2, max=10),
            _c(signal="truth.h_m", metric="rise_time", target=5, start=0, step_t_s=2, max=5),
        ],
        tr,
    )
    assert over.passed and 0.3 < over.value < 0.7
    assert settle.passed and 1.0 < settle.value < 4.0
    assert rise.passed and 0.3 < rise.value < 1.5


def test_control_activity_catches_chatter() -> None:
    smooth = _trace(lambda t: (0, 0, (1600 + 5 * math.sin(t),) * 4))
    chatter = _trace(lambda t: (0, 0, ((1000 if int(t * 400) % 2 else 2000),) * 4))
    crit = [
        _c(signal="esc.pulse_us", metric="rms_delta", max=10.0),
        _c(signal="esc.pulse_us", metric="fraction_saturated", lo=1001, hi=1999, max=0.05),
    ]
    assert all(r.passed for r in evaluate(crit, smooth))
    assert not any(r.passed for r in evaluate(crit, chatter))


def test_unknown_signal_and_empty_window_fail_with_reason() -> None:
    tr = _trace(lambda t: (0, 0, (1500,) * 4), n=10)
    bad, empty = evaluate(
        [
            _c(signal="truth.nope", metric="max", max=1),
            _c(signal="truth.roll_deg", metric="max", window_s=(100, 200), max=1),
        ],
        tr,
    )
    assert not bad.passed and "unknown signal" in bad.detail
    assert not empty.passed and "no data" in empty.detail


def test_irregular_series_held_on_the_tick_grid() -> None:
    tr = _trace(lambda t: (0, 0, (1500,) * 4), n=8)
    tr.point("tm.roll_ref_deg", 0, 1.0)
    tr.point("tm.roll_ref_deg", 4 * TICK, 3.0)
    _, v = tr.signal("tm.roll_ref_deg")
    np.testing.assert_allclose(v, [1, 1, 1, 1, 3, 3, 3, 3])
    _, col = tr.signal("esc.pulse_us[2]")
    assert col.shape == (8,)


def test_difference_signal_is_a_tracking_error() -> None:
    tr = _trace(lambda t: (5.0, 0, (1500,) * 4), n=8)
    tr.point("tm.roll_ref_deg", 0, 4.5)
    (res,) = evaluate([_c(signal="truth.roll_deg - tm.roll_ref_deg", metric="max_abs", max=0.6)], tr)
    assert res.passed and res.value == pytest.approx(0.5)


def _step_trace(level: float, step: float, reached: float) -> Trace:
    """Holds ``level`` until t = 2 s, then a damped rise to ``reached`` (overshoot ~0.5 m
    for a 5 m step)."""

    def fn(t: float):
        if t < 2:
            return 0.0, level, (1500,) * 4
        tau = t - 2
        h = level + (reached - level) * (1 - math.exp(-1.5 * tau) * (math.cos(2 * tau) + 0.75 * math.sin(2 * tau)))
        return 0.0, h, (1500,) * 4

    return _trace(fn, n=6000)


def test_step_metrics_against_the_pre_step_level() -> None:
    """A 5 m step commanded from a 1.16 m hold that ends 4.8 m higher: measured against
    6.0 m absolute the overshoot would be wrong by the hold's offset."""
    tr = _step_trace(1.16, 5.0, 5.96)
    over, settle_rel, over_final, settle_final, rise_final = evaluate(
        [
            _c(signal="truth.h_m", metric="overshoot", step_size=5.0, step_t_s=2, max=1.0),
            _c(signal="truth.h_m", metric="settling_time", step_size=5.0, step_t_s=2, band_fraction=0.05, max=100),
            _c(signal="truth.h_m", metric="overshoot", final_window_s=(12, 15), step_t_s=2, max=1.0),
            _c(signal="truth.h_m", metric="settling_time", final_window_s=(12, 15), step_t_s=2, band_fraction=0.05, max=100),
            _c(signal="truth.h_m", metric="rise_time", final_window_s=(12, 15), step_t_s=2, max=100),
        ],
        tr,
    )
    peak = max(tr.signal("truth.h_m")[1])
    assert over.value == pytest.approx(peak - 6.16)  # pre-step 1.16 + 5
    assert over_final.value == pytest.approx(peak - 5.96, abs=1e-6)
    # +-5 % of the step: 0.25 m around pre + 5 = 6.16, or 0.24 m around the level reached
    # (5.96, 0.2 m lower: the band around pre + 5 is entered on the first overshoot)
    assert 1.0 < settle_rel.value < 2.0 and 1.5 < settle_final.value < 3.0
    assert 0.3 < rise_final.value < 1.5
    # the same criteria on a hold that never stepped: never settles
    flat = _step_trace(1.16, 5.0, 1.16)
    (never,) = evaluate([_c(signal="truth.h_m", metric="settling_time", step_size=5.0, step_t_s=2, band_fraction=0.05, max=8)], flat)
    assert not never.passed and never.value == math.inf


def test_std_and_rms_change() -> None:
    tr = _trace(lambda t: (2.0 * math.sin(2 * math.pi * t) * (1.1 if t >= 5 else 1.0) + 3.0, 0.0, (1500,) * 4))
    std, change = evaluate(
        [
            _c(signal="truth.roll_deg", metric="std", window_s=(1, 4), max=10),
            _c(signal="truth.roll_deg - truth.h_m", metric="rms_change_pct", window_s=(5, 9), baseline_window_s=(1, 4), max=15),
        ],
        tr,
    )
    assert std.value == pytest.approx(2 / math.sqrt(2), rel=1e-3)  # the offset does not count
    rms_before = math.sqrt(9 + 2.0)
    rms_after = math.sqrt(9 + 2.0 * 1.21)
    assert change.value == pytest.approx(100 * (rms_after / rms_before - 1), rel=1e-2)
    assert change.passed


def test_phase_lag_of_a_delayed_sine() -> None:
    """Truth lags the (50 Hz, irregular) reference by 25 ms at 2 Hz: 18 deg."""
    tr = _trace(lambda t: (10 * math.sin(2 * math.pi * 2.0 * (t - 0.025)), 0.0, (1500,) * 4))
    for k in range(0, 500):
        t = k * 0.02
        tr.point("tm.roll_ref_deg", int(round(t * 1e9)), 10 * math.sin(2 * math.pi * 2.0 * t))
    (lag,) = evaluate(
        [_c(signal="truth.roll_deg", metric="phase_lag_deg", reference="tm.roll_ref_deg", freq_hz=2.0, window_s=(1, 9), max=20)],
        tr,
    )
    assert lag.value == pytest.approx(18.0, abs=0.2)


def test_new_metrics_need_their_parameters() -> None:
    with pytest.raises(ValueError, match="reference and freq_hz"):
        _c(signal="truth.roll_deg", metric="phase_lag_deg", max=1)
    with pytest.raises(ValueError, match="baseline_window_s"):
        _c(signal="truth.roll_deg", metric="rms_change_pct", window_s=(1, 2), max=1)
    with pytest.raises(ValueError, match="one of target"):
        _c(signal="truth.h_m", metric="overshoot", step_t_s=1, target=5, step_size=5, max=1)


def test_estimate_minus_truth_is_taken_at_the_estimate_instants() -> None:
    """``tm.x - truth.y`` (irregular on the left) is evaluated at the telemetry samples."""
    tr = _trace(lambda t: (0.0, t, (1500,) * 4), n=400)
    for k in range(0, 50):
        t_ns = k * 20_000_000
        tr.point("tm.alt_est_m", t_ns, t_ns / 1e9 + 0.1)
    t, err = tr.signal("tm.alt_est_m - truth.h_m")
    assert len(t) == 50
    np.testing.assert_allclose(err, 0.1, atol=1e-9)
