"""Third-order prefilter: exact step response, no overshoot, consistent derivatives."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flightcode.control.reference import Prefilter3, RefState

T = 0.0025


def _step(omega: float, amplitude: float, n: int) -> np.ndarray:
    f = Prefilter3(omega, T)
    f.reset(0.0)
    return np.array([[r.angle_rad, r.rate_radps, r.acc_radps2, r.jerk_radps3] for r in (f.update(amplitude) for _ in range(n))])


def test_step_matches_the_analytic_response_of_a_triple_pole() -> None:
    omega = 8.0
    out = _step(omega, 1.0, 800)
    t = T * np.arange(1, 801)
    wt = omega * t
    e = np.exp(-wt)
    # y = 1 - e^{-wt}(1 + wt + (wt)^2/2) and its derivatives (ZOH is exact at the samples).
    y = 1.0 - e * (1.0 + wt + wt**2 / 2.0)
    yd = omega * e * wt**2 / 2.0
    ydd = omega**2 * e * (wt - wt**2 / 2.0)
    yddd = omega**3 * e * (1.0 - 2.0 * wt + wt**2 / 2.0)
    np.testing.assert_allclose(out[:, 0], y, atol=1e-12)
    np.testing.assert_allclose(out[:, 1], yd, atol=1e-10)
    np.testing.assert_allclose(out[:, 2], ydd, atol=1e-9)
    np.testing.assert_allclose(out[:, 3], yddd, atol=1e-8)


def test_step_has_no_overshoot_and_settles() -> None:
    out = _step(8.0, math.radians(30.0), 1200)
    y = out[:, 0]
    assert np.all(np.diff(y) >= -1e-15), "monotone"
    assert y.max() <= math.radians(30.0) + 1e-12
    # 1 % settling of a triple pole: omega t = 8.41 -> 1.05 s at 8 rad/s.
    k_settle = int(np.argmax(y >= 0.99 * math.radians(30.0)))
    assert 1.0 < (k_settle + 1) * T < 1.1


def test_derivatives_are_consistent_with_finite_differences() -> None:
    out = _step(8.0, 5.0, 1000)  # altitude: a 5 m step
    # Central differences are second order in T; skip the jerk discontinuity at the step.
    for col in range(3):
        fd = (out[2:, col] - out[:-2, col]) / (2 * T)
        scale = np.abs(out[1:-1, col + 1]).max()
        np.testing.assert_allclose(fd[2:], out[3:-1, col + 1], atol=2e-3 * scale)


def test_reset_settles_at_value_and_holds() -> None:
    f = Prefilter3(8.0, T)
    assert f.reset(0.3) == RefState(0.3, 0.0, 0.0, 0.0)
    for _ in range(10):
        r = f.update(0.3)
    assert r.angle_rad == pytest.approx(0.3, abs=1e-15)
    assert abs(r.rate_radps) < 1e-13 and abs(r.acc_radps2) < 1e-12 and abs(r.jerk_radps3) < 1e-10


def test_non_finite_command_holds_the_last_command() -> None:
    a, b = Prefilter3(8.0, T), Prefilter3(8.0, T)
    for _ in range(5):
        a.update(0.2)
        b.update(0.2)
    ra, rb = a.update(float("nan")), b.update(0.2)
    assert ra == rb


def test_rejects_bad_construction() -> None:
    with pytest.raises(ValueError):
        Prefilter3(0.0, T)
    with pytest.raises(ValueError):
        Prefilter3(8.0, -1.0)


@settings(deadline=None, max_examples=40)
@given(st.lists(st.floats(-1.0, 1.0), min_size=1, max_size=200), st.floats(1.0, 30.0))
def test_output_stays_inside_the_command_range(cmds: list[float], omega: float) -> None:
    # The sampled step response is monotone, so the impulse response is non-negative and the
    # output is a weighted average of past commands: no overshoot for any command sequence.
    f = Prefilter3(omega, T)
    f.reset(cmds[0])
    lo, hi = min(cmds), max(cmds)
    for c in cmds:
        y = f.update(c).angle_rad
        assert lo - 1e-12 <= y <= hi + 1e-12
