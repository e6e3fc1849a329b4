"""Criteria metrics on synthetic traces with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hil.analysis.criteria import evaluate
from hil.config import SCENARIOS_DIR
from hil.config.scenario import load_scenario
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
            _c(signal="truth.h_m", metric="overshoot", target=5, step_t_s=2, min=-0.25, max=1.0),
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
    assert not empty.passed and empty.detail == "no sample of truth.roll_deg in [100, 200] s"


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
    over, settle_rel = evaluate(
        [
            _c(signal="truth.h_m", metric="overshoot", step_size=5.0, step_t_s=2, min=-0.25, max=1.0),
            _c(signal="truth.h_m", metric="settling_time", step_size=5.0, step_t_s=2, band_fraction=0.05, max=100),
        ],
        tr,
    )
    peak = max(tr.signal("truth.h_m")[1])
    assert over.value == pytest.approx(peak - 6.16)  # pre-step 1.16 + 5
    # +-5 % of the step: 0.25 m around pre + 5 = 6.16 (entered on the first overshoot)
    assert 1.0 < settle_rel.value < 2.0
    # the same criteria on a hold that never stepped: never settles
    flat = _step_trace(1.16, 5.0, 1.16)
    (never,) = evaluate([_c(signal="truth.h_m", metric="settling_time", step_size=5.0, step_t_s=2, band_fraction=0.05, max=8)], flat)
    assert not never.passed and never.value == math.inf


def _altitude_step_flight(climbed_m: float) -> Trace:
    """altitude-step's flight (rigs/scenarios/altitude-step.toml: hold 1.15 m, step at 15 s,
    32 s) that climbs ``climbed_m`` with a 5 m step's shape, the estimate on truth."""

    def fn(t: float):
        tau = max(t - 15.0, 0.0)
        h = 1.15 + climbed_m * (1 - math.exp(-1.5 * tau) * (math.cos(2 * tau) + 0.75 * math.sin(2 * tau)))
        return 0.0, h, (1500,) * 4

    tr = _trace(fn, n=32 * 400)
    for k in range(32 * 50):
        tr.point("tm.alt_est_m", k * 20_000_000, fn(k / 50)[1])
        tr.point("tm.accel_from_xsens", k * 20_000_000, 0.0)  # the altitude filter on the ADXL335
    return tr


def test_a_step_of_the_wrong_size_fails_altitude_step() -> None:
    """The shipped altitude-step criteria on synthetic flights: a "5 m step" that climbs
    2.0 m or 0.8 m fails overshoot (it undershoots), settling (never within +-0.25 m of
    pre-step + 5 m) and rise time (never at 90 % of 5 m); the commanded 5 m passes all."""
    criteria = load_scenario(SCENARIOS_DIR / "altitude-step.toml").criteria
    step = [c for c in criteria if c.metric in ("overshoot", "settling_time", "rise_time")]
    assert len(step) == 3
    good = evaluate(criteria, _altitude_step_flight(5.0))
    assert all(r.passed for r in good), good
    for climbed_m in (2.0, 0.8):
        bad = {r.metric: r for r in evaluate(step, _altitude_step_flight(climbed_m))}
        assert not any(r.passed for r in bad.values()), (climbed_m, bad)
        assert bad["overshoot"].value < -2.5  # the peak stays metres short of pre-step + 5 m


def test_overshoot_needs_a_bound_on_both_sides() -> None:
    with pytest.raises(ValueError, match="overshoot needs min and max"):
        _c(signal="truth.h_m", metric="overshoot", step_size=5.0, step_t_s=2, max=1.0)


def _nan_between(t0_s: float, t1_s: float) -> Trace:
    """truth.h_m = 2 m, and an altitude estimate at 50 Hz that is 2.01 m except NaN over [t0, t1)."""
    tr = _trace(lambda t: (0.0, 2.0, (1500,) * 4), n=32 * 400)
    for k in range(0, 32 * 50):
        t_s = k / 50
        tr.point("tm.alt_est_m", int(k * 20_000_000), math.nan if t0_s <= t_s < t1_s else 2.01)
    return tr


def test_a_nan_estimate_fails_rms_error() -> None:
    """An altitude estimate NaN from 11 s to 32 s fails "RMS error" (it passed on the 10-11 s
    left over); a criterion that states its tolerance passes within it."""
    rms = _c(name="RMS error", signal="tm.alt_est_m - truth.h_m", metric="rms", window_s=(10, 32), max=0.25)
    (bad,) = evaluate([rms], _nan_between(11.0, 32.1))
    assert not bad.passed and "non-finite" in bad.detail, bad
    (good,) = evaluate([rms], _nan_between(99.0, 99.0))
    assert good.passed and good.value == pytest.approx(0.01)
    tolerant = rms.model_copy(update={"nonfinite_fraction_max": 0.01})
    (few,) = evaluate([tolerant], _nan_between(20.0, 20.1))  # 5 of 1101 samples
    (many,) = evaluate([tolerant], _nan_between(20.0, 25.0))
    assert few.passed and not many.passed


def test_non_finite_samples_fail_every_kind_of_metric() -> None:
    """Pooled, step, phase and change metrics alike: a NaN in the window fails them."""
    def fn(t: float):
        return (math.nan if 5.0 <= t < 5.5 else math.sin(2 * math.pi * t), 1.0 + (t >= 2) * 5.0, (1500,) * 4)

    tr = _trace(fn)
    tr.point("tm.roll_ref_deg", 0, 0.0)
    for k in range(1, 400):
        tr.point("tm.roll_ref_deg", k * 25_000_000, math.sin(2 * math.pi * k * 0.025))
    crits = [
        _c(signal="truth.roll_deg", metric="max_abs", max=2.0),
        _c(signal="truth.roll_deg", metric="final", max=2.0),
        _c(signal="truth.roll_deg - truth.h_m", metric="overshoot", step_size=0.0, step_t_s=4, min=-100, max=100),
        _c(signal="truth.roll_deg", metric="phase_lag_deg", reference="tm.roll_ref_deg", freq_hz=1.0, max=90),
        _c(signal="truth.roll_deg", metric="rms_change_pct", window_s=(4, 9), baseline_window_s=(1, 3), max=50),
    ]
    assert not any(r.passed for r in evaluate(crits, tr))
    clean = [c.model_copy(update={"window_s": (6.0, 9.0)}) for c in crits[:2]]
    assert all(r.passed for r in evaluate(clean, tr))


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
        _c(signal="truth.h_m", metric="overshoot", step_t_s=1, target=5, step_size=5, min=-1, max=1)


def test_estimate_minus_truth_is_taken_at_the_estimate_instants() -> None:
    """``tm.x - truth.y`` (irregular on the left) is evaluated at the telemetry samples."""
    tr = _trace(lambda t: (0.0, t, (1500,) * 4), n=400)
    for k in range(0, 50):
        t_ns = k * 20_000_000
        tr.point("tm.alt_est_m", t_ns, t_ns / 1e9 + 0.1)
    t, err = tr.signal("tm.alt_est_m - truth.h_m")
    assert len(t) == 50
    np.testing.assert_allclose(err, 0.1, atol=1e-9)
