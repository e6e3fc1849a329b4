"""PI yaw-rate controller: signs, integral action, conditional integration, applied-torque unwind."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flightcode.control.yaw_rate import YawRateController

T = 0.0025


def test_proportional_sign_and_first_output() -> None:
    c = YawRateController(0.15, 0.15, 0.15, T)
    # Nose-right rate wanted, none measured: positive (nose-right) torque, kp e + i_0.
    assert c.update(0.5, 0.0, True) == pytest.approx(0.075)
    assert c.integrator_Nm == pytest.approx(0.15 * T * 0.5)
    assert c.update(0.0, 0.5, True) < 0.0


def test_integral_removes_a_constant_disturbance() -> None:
    # Plant J_zz r' = u + d with a constant disturbance torque; the PI must hold r = r*.
    j, d = 0.026, -0.03
    c = YawRateController(T_s=T)
    r = 0.0
    for _ in range(int(20 / T)):
        u = c.update(0.3, r, True)
        r += T * (u + d) / j
    assert r == pytest.approx(0.3, abs=1e-3)
    assert c.integrator_Nm == pytest.approx(-d, abs=1e-3)


def test_conditional_integration_freezes_while_saturated_in_the_error_direction() -> None:
    c = YawRateController(0.15, 0.15, 0.15, T)
    outs = [c.update(3.0, 0.0, True) for _ in range(200)]  # kp e = 0.45 > limit
    assert outs[-1] == 0.15
    assert c.integrator_Nm == 0.0
    assert c.update(0.0, 3.0, True) == -0.15  # saturated low with a negative error: frozen too
    assert c.integrator_Nm == 0.0
    # Charge the integral in the linear range until the output saturates, then reverse.
    for _ in range(2000):
        c.update(0.2, 0.0, True)
    i_sat = c.integrator_Nm
    assert i_sat == pytest.approx(0.15 - 0.15 * 0.2, abs=0.15 * T * 0.2 + 1e-12)
    assert c.update(0.25, 0.0, True) == 0.15 and c.integrator_Nm == i_sat
    c.update(0.0, 0.1, True)  # error against the integral: it integrates down
    assert c.integrator_Nm == pytest.approx(i_sat - 0.15 * T * 0.1)


def test_set_applied_unwinds_but_never_flips_the_integral() -> None:
    c = YawRateController(0.15, 0.15, 0.15, T)
    for _ in range(2000):
        u = c.update(0.2, 0.0, True)
    i_before = c.integrator_Nm
    assert i_before > 0.0 and u > 0.0
    c.set_applied(u - 0.01)  # mixer cut 10 mN m of yaw
    assert c.integrator_Nm == pytest.approx(i_before - 0.01)
    c.set_applied(-1.0)  # a large cut cannot push the integral negative
    assert c.integrator_Nm == 0.0


def test_set_applied_that_helps_the_integral_does_not_change_it() -> None:
    c = YawRateController(0.15, 0.15, 0.15, T)
    for _ in range(100):
        u = c.update(0.2, 0.0, True)
    i = c.integrator_Nm
    c.set_applied(u + 0.05)
    assert c.integrator_Nm == i


def test_inactive_resets_and_returns_zero() -> None:
    c = YawRateController()
    for _ in range(50):
        c.update(1.0, 0.0, True)
    assert c.update(1.0, 0.0, False) == 0.0
    assert c.integrator_Nm == 0.0


def test_non_finite_input_holds_output() -> None:
    c = YawRateController()
    u = c.update(0.1, 0.0, True)
    assert c.update(math.nan, 0.0, True) == u
    assert c.counters["nonfinite_input"] == 1


def test_rejects_bad_gains() -> None:
    with pytest.raises(ValueError):
        YawRateController(u_limit_Nm=0.0)
    with pytest.raises(ValueError):
        YawRateController(kp_Nm_per_radps=-1.0)


@settings(deadline=None, max_examples=50)
@given(st.lists(st.tuples(st.floats(-10, 10), st.floats(-10, 10), st.booleans(), st.floats(-1, 1)), min_size=1, max_size=80))
def test_output_and_integral_stay_within_the_limit(seq: list[tuple[float, float, bool, float]]) -> None:
    c = YawRateController()
    for ref, meas, active, applied in seq:
        u = c.update(ref, meas, active)
        assert abs(u) <= c.u_limit_Nm and abs(c.integrator_Nm) <= c.u_limit_Nm
        c.set_applied(applied)
        assert abs(c.integrator_Nm) <= c.u_limit_Nm
