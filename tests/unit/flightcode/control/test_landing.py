"""Landing descent setpoint and the learnt hover collective."""

from __future__ import annotations

import math

import pytest

from flightcode.control.landing import (
    STEADY_AZ_MPS2,
    STEADY_VZ_MPS,
    HoverThrottle,
    LandingDescent,
)


def test_descent_goes_on_below_the_estimated_ground() -> None:
    d = LandingDescent(0.5)
    assert not d.active
    d.start(1.0)
    assert d.active
    for _ in range(1600):  # 4 s at 400 Hz
        z = d.step(0.0025)
    assert z == pytest.approx(-1.0) and d.z_m == z  # no floor at 0 m: the ground is where the vehicle stops
    d.stop()
    assert not d.active
    d.start(0.3)
    assert d.step(0.1) == pytest.approx(0.25)
    with pytest.raises(ValueError):
        LandingDescent(0.0)
    with pytest.raises(ValueError):
        LandingDescent(math.nan)


def test_hover_collective_converges_to_what_holds_the_vehicle() -> None:
    h = HoverThrottle(0.724, tau_s=2.0)
    assert h.collective == 0.724 and h.learnt_s == 0.0
    for _ in range(int(10.0 / 0.0025)):  # 10 s (5 time constants) of steady flight with +300 g
        h.update(0.817, 0.0025)
    assert h.collective == pytest.approx(0.817, abs=0.001) and h.learnt_s == pytest.approx(10.0)
    for _ in range(int(2.0 / 0.0025)):  # one time constant back towards 0.724: 63 % of the way
        h.update(0.724, 0.0025)
    assert h.collective == pytest.approx(0.817 - 0.632 * (0.817 - 0.724), abs=0.002)


def test_hover_collective_ignores_garbage_and_stays_bounded() -> None:
    h = HoverThrottle(0.7, tau_s=0.1, lo=0.5, hi=0.9)
    h.update(math.nan, 0.0025)
    h.update(0.0, 0.0)  # no time, no weight
    assert h.collective == 0.7 and h.learnt_s == 0.0
    for _ in range(400):
        h.update(1.0, 0.0025)
    assert h.collective == 0.9
    for _ in range(400):
        h.update(0.0, 0.0025)
    assert h.collective == 0.5
    with pytest.raises(ValueError):
        HoverThrottle(1.2)
    with pytest.raises(ValueError):
        HoverThrottle(0.7, tau_s=0.0)


def test_steady_flight_is_clear_of_the_ground_and_unaccelerated() -> None:
    assert HoverThrottle.steady(2.0, 0.0, 0.0, 1.0)
    assert not HoverThrottle.steady(0.9, 0.0, 0.0, 1.0)  # in ground effect: a hover needs less
    assert not HoverThrottle.steady(2.0, 1.1 * STEADY_VZ_MPS, 0.0, 1.0)  # climbing
    assert not HoverThrottle.steady(2.0, 0.0, -1.1 * STEADY_AZ_MPS2, 1.0)  # accelerating
