"""The firmware's ADC plausibility checks and flat-line test against flightcode's.

Inputs are float32 values (what the firmware's analog chain gives), so both judge the same
numbers. Verdicts must be identical; the only allowed difference is a flat-line verdict on a
window whose variance (float64, of the float32 readings) is within 1e-3 Pa^2 of the threshold
(the float32 running sums carry ~1e-5 Pa^2 of rounding; none of the sequences below comes that
close, so they are in fact identical).
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flightcode.estimation.plausibility import AdcPlausibility, FlatLine, PlausibilityParams
from tests.unit.firmware import cfw

VAR_BAND_PA2 = 1e-3


def f32(v: float) -> float:
    return float(np.float32(v))


def near_threshold(window: deque[float], min_std: float) -> bool:
    return len(window) == window.maxlen and abs(float(np.var(np.array(window))) - min_std**2) < VAR_BAND_PA2


def run_flat(lib: cfw.Lib, n: int, min_std: float, xs: list[float]) -> None:
    py, c = FlatLine(n, min_std), cfw.CFlatLine(lib, n, min_std)
    assert c.ok
    window: deque[float] = deque(maxlen=n)
    for k, x in enumerate(xs):
        window.append(x)
        vp, vc = py.add(x), c.add(x)
        if vp != vc:
            assert near_threshold(window, min_std), f"reading {k}: Python {vp}, C {vc}, C variance {c.var}"


def pressure_trace(rng: np.random.Generator, n: int) -> list[float]:
    """A live MPX5100AP through the x16 stage (5.3 Pa a reading) with climbs, then stuck
    stretches (the pin's 0.5-0.65 Pa of noise around a held value)."""
    level = 101_325.0 + np.cumsum(rng.normal(0.0, 0.6, n))
    p = level + rng.normal(0.0, 5.3, n)
    for start in rng.integers(0, n - 400, 6):
        p[start:start + 300] = p[start] + rng.normal(0.0, rng.uniform(0.3, 1.2), 300)
    return [f32(v) for v in p]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_flat_line_verdicts_over_a_long_trace(lib: cfw.Lib, seed: int) -> None:
    run_flat(lib, 40, 1.5, pressure_trace(np.random.default_rng(seed), 40_000))


@settings(max_examples=150)
@given(n=st.integers(2, 128), min_std=st.floats(0.01, 20.0),
       xs=st.lists(st.floats(90_000.0, 110_000.0, width=32) | st.sampled_from([101_325.0, 101_325.5]),
                   min_size=1, max_size=400))
def test_flat_line_verdicts_property(lib: cfw.Lib, n: int, min_std: float, xs: list[float]) -> None:
    run_flat(lib, n, min_std, xs)


def test_flat_line_window_limits(lib: cfw.Lib) -> None:
    assert not cfw.CFlatLine(lib, 1, 1.0).ok
    assert cfw.CFlatLine(lib, 128, 1.0).ok
    assert not cfw.CFlatLine(lib, 129, 1.0).ok  # FLAT_LINE_MAX_READINGS
    assert not cfw.CPlausibility(lib, 60.0, 129, 1.5, 5.0, 3.0).ok


@pytest.mark.parametrize("flat_n", [40, 0])
def test_adc_plausibility_over_a_corrupted_stream(lib: cfw.Lib, flat_n: int) -> None:
    params = PlausibilityParams(baro_flat_readings=flat_n)
    py = AdcPlausibility(params)
    c = cfw.CPlausibility(lib, params.baro_max_step_Pa, flat_n, params.baro_flat_std_Pa, params.accel_max_g,
                          params.accel_xsens_tolerance_mps2)
    assert c.ok
    rng = np.random.default_rng(5)
    trace = pressure_trace(rng, 30_000)
    g = 9.80665
    for k, p in enumerate(trace):
        r = rng.random()
        if r < 0.02:
            p_in: float | None = None  # no ADC reply
        elif r < 0.03:
            p_in = f32(p + rng.choice([-1, 1]) * rng.choice([64.0, 256.0, 1024.0, 70_000.0]))  # a flipped bit
        elif r < 0.031:
            p_in = math.nan
        else:
            p_in = p
        assert py.baro_Pa(p_in) == c.baro_Pa(p_in), f"reading {k}: {p_in}"
        f = tuple(f32(v) for v in rng.normal(0.0, 1.5 * g, 3))
        if rng.random() < 0.01:
            f = (f[0], f32(rng.choice([-1, 1]) * 60.0), math.inf if rng.random() < 0.2 else f[2])
        assert py.accel_in_range(f) == c.accel_in_range(f), f"reading {k}: {f}"
        ax = f32(rng.normal(0.0, 2.0))
        a = f32(ax + rng.normal(0.0, 2.0) + (0.6 if 10_000 <= k < 20_000 else 0.0))  # an offset that moves
        agrees = py.accel_agrees(a, ax)
        assert agrees == c.accel_agrees(a, ax)
        if agrees:  # as the loop asks
            assert py.accel_offset_holds(a, ax) == c.accel_offset_holds(a, ax), f"reading {k}"
    counters, flat, refused = c.read()
    assert counters == {k: py.counters[k] for k in cfw.CPlausibility.COUNTERS}
    assert flat == py.baro_flat and refused == py.refused
    assert all(counters[k] > 0 for k in cfw.CPlausibility.COUNTERS if k != "baro_flat" or flat_n)


def test_an_accelerometer_offset_that_moves_is_seen_and_taken_back_with_hysteresis(lib: cfw.Lib) -> None:
    params = PlausibilityParams()
    py = AdcPlausibility(params)
    c = cfw.CPlausibility(lib, params.baro_max_step_Pa, 40, params.baro_flat_std_Pa, params.accel_max_g,
                          params.accel_xsens_tolerance_mps2, params.accel_offset_tau_s, params.accel_offset_max_mps2)
    offsets = [0.0] * 400 + [0.6] * 2000 + [0.2] * 2000 + [0.1] * 2000  # 1 s, 5 s, 5 s, 5 s at 400 Hz
    verdicts = []
    for k, off in enumerate(offsets):
        a_x = f32(0.3 * math.sin(k / 50.0))  # the vehicle's own motion: both see it
        v = py.accel_offset_holds(f32(a_x + off), a_x)
        assert v == c.accel_offset_holds(f32(a_x + off), a_x), f"sample {k}"
        verdicts.append(v)
    first_out = verdicts.index(False)
    # 0.6 through a 1 s low-pass passes 0.25 after ln(0.6 / 0.35) = 0.54 s
    assert first_out == pytest.approx(400 + 0.54 * 400, abs=4)
    assert not any(verdicts[first_out:2400])
    assert not any(verdicts[2400:4400])  # 0.2 is inside the limit but not inside half of it: still out
    assert all(verdicts[4400 + 800:])  # 0.1 is: back within 2 s
    assert c.read()[0]["accel_offset_moved"] == py.counters["accel_offset_moved"] == verdicts.count(False)
    assert c.take_offset_worst() == pytest.approx(py.take_offset_worst(), abs=1e-5) and py.take_offset_worst() == 0.0
    assert c.take_offset_worst() == 0.0


def test_limits_are_the_params(lib: cfw.Lib) -> None:
    c = cfw.CPlausibility(lib, 10.0, 0, 1.5, 2.0, 0.5)
    assert c.baro_Pa(100_000.0) is not None
    assert c.baro_Pa(100_010.5) is None  # a step of 10.5 > 10 Pa
    assert c.baro_Pa(100_000.0) is None  # and back: the refused reading was the reference
    assert c.baro_Pa(100_009.0) is not None
    assert c.baro_Pa(14_999.0) is None and c.baro_Pa(15_000.0) is not None  # range, then no step reference
    assert c.baro_Pa(115_000.0) is None  # a step from 15 kPa
    assert c.accel_in_range((19.6, -19.6, 0.0)) and not c.accel_in_range((19.62, 0.0, 0.0))  # 2 g
    assert c.accel_agrees(1.0, 1.5) and not c.accel_agrees(1.0, 1.51)


@pytest.mark.parametrize("outlier_Pa", [31_312.75, 114_000.0, 101_325.0 + 4096.0])
@pytest.mark.parametrize("at", [0, 17, 39])
def test_an_outlier_leaving_the_window_leaves_no_false_flat_line(lib: cfw.Lib, outlier_Pa: float, at: int) -> None:
    """A bit error tens of kPa off enters the window (the range test passes it, the step test
    refuses it after the flat-line test saw it) and leaves it 40 readings later: in float32 the
    running sum of squares kept only the rounding of its square (-33 Pa^2 of "variance", a flat
    line, on a live 5 Pa sensor, before the sums were made afresh when it leaves). Wherever the
    ring's turn falls, the window's variance stays numpy's."""
    rng = np.random.default_rng(at)
    xs = [f32(v) for v in 101_325.0 + rng.normal(0.0, 5.3, 200)]
    xs[40 + at] = outlier_Pa
    c = cfw.CFlatLine(lib, 40, 1.5)
    for k, x in enumerate(xs):
        assert not c.add(x), f"reading {k}: a live sensor called flat"
        if k >= 39:
            expected = float(np.var(np.array(xs[k - 39:k + 1], dtype=np.float64)))
            assert c.var == pytest.approx(expected, rel=1e-3), f"reading {k}"
