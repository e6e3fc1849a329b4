"""Criteria metrics on synthetic traces with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hil.criteria import evaluate
from hil.scenario import Criterion
from hil.trace import Trace

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
