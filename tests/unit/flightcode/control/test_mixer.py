"""Mixer: layout signs (shared convention), golden throttles, saturation priority, applied torque."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flightcode.control.mixer import Frame, Mixer, MixResult

F_MAX = 5.15
ARM = 0.25
L = ARM / math.sqrt(2.0)
C = 0.016

# Independent geometry (the shared flight-code convention, FRD): (x, y, spin: +1 CCW).
X_LAYOUT = ((L, L, 1), (-L, -L, 1), (L, -L, -1), (-L, L, -1))
PLUS_LAYOUT = ((0.0, ARM, 1), (0.0, -ARM, 1), (ARM, 0.0, -1), (-ARM, 0.0, -1))


def _torque(layout, throttle) -> tuple[float, float, float, float]:
    """(sum F, tau_x, tau_y, tau_z) from throttles: thrust along -z_B at (x, y)."""
    f = [F_MAX * d * d for d in throttle]
    return (
        sum(f),
        sum(-y * fi for (x, y, s), fi in zip(layout, f)),
        sum(x * fi for (x, y, s), fi in zip(layout, f)),
        sum(C * s * fi for (x, y, s), fi in zip(layout, f)),
    )


def test_pure_collective() -> None:
    r = Mixer().mix(0.724, (0.0, 0.0, 0.0))
    assert isinstance(r, MixResult)
    assert r.throttle == pytest.approx((0.724,) * 4, abs=1e-15)
    assert r.applied_tau_Nm == (0.0, 0.0, 0.0) and not r.saturated
    assert r.applied_collective_throttle == pytest.approx(0.724, abs=1e-15)


def test_golden_roll_x_frame() -> None:
    # Hover F = 5.15 x 0.724^2 = 2.699506 N per motor, roll 0.1 N m -> +-0.1/(4 l) = 0.141421 N:
    # the left motors (1 rear-left, 2 front-left) speed up so the right wing goes down.
    r = Mixer().mix(0.724, (0.1, 0.0, 0.0))
    assert r.throttle == pytest.approx((0.704780, 0.742722, 0.742722, 0.704780), abs=1e-6)
    assert r.applied_tau_Nm == pytest.approx((0.1, 0.0, 0.0), abs=1e-12)
    assert not r.saturated


def test_signs_follow_the_layout_x() -> None:
    m = Mixer("x")
    pitch = m.mix(0.6, (0.0, 0.1, 0.0)).throttle  # nose up: front motors 0, 2 faster
    assert pitch[0] == pitch[2] > 0.6 > pitch[1] == pitch[3]
    yaw = m.mix(0.6, (0.0, 0.0, 0.05)).throttle  # nose right: CCW motors 0, 1 faster
    assert yaw[0] == yaw[1] > 0.6 > yaw[2] == yaw[3]
    # Exact differential thrust: tau_z / (4 kQ/kT) per motor.
    assert F_MAX * yaw[0] ** 2 - F_MAX * 0.36 == pytest.approx(0.05 / (4 * C), rel=1e-12)


def test_signs_follow_the_layout_plus() -> None:
    m = Mixer("plus")
    assert m.frame is Frame.PLUS and Mixer("+").frame is Frame.PLUS
    roll = m.mix(0.6, (0.1, 0.0, 0.0)).throttle  # right wing down: left motor 1 up, right 0 down
    assert roll[1] > 0.6 > roll[0] and roll[2] == roll[3] == pytest.approx(0.6)
    assert F_MAX * roll[1] ** 2 - F_MAX * 0.36 == pytest.approx(0.1 / (2 * ARM), rel=1e-12)
    pitch = m.mix(0.6, (0.0, 0.1, 0.0)).throttle  # nose up: front motor 2 up, back 3 down
    assert pitch[2] > 0.6 > pitch[3] and pitch[0] == pitch[1] == pytest.approx(0.6)
    r = m.mix(0.6, (0.05, -0.04, 0.02))
    assert r.applied_tau_Nm == pytest.approx((0.05, -0.04, 0.02), abs=1e-12)
    assert _torque(PLUS_LAYOUT, r.throttle)[1:] == pytest.approx((0.05, -0.04, 0.02), abs=1e-12)


def test_yaw_is_reduced_first_at_the_requested_collective() -> None:
    r = Mixer().mix(0.724, (0.1, -0.05, 0.5))
    assert r.saturated
    assert r.applied_tau_Nm[:2] == pytest.approx((0.1, -0.05), abs=1e-12)
    assert 0.0 < r.applied_tau_Nm[2] < 0.5
    assert r.applied_collective_throttle == pytest.approx(0.724, abs=1e-12)
    assert max(r.throttle) == pytest.approx(1.0) or min(r.throttle) == pytest.approx(0.0)


def test_collective_shifts_when_roll_does_not_fit() -> None:
    # Near full throttle the +0.8485 N per motor of a 0.6 N m roll does not fit: the collective
    # drops by exactly the overflow, roll is kept, yaw has no room left on motor 1.
    r = Mixer().mix(0.98, (0.6, 0.0, 0.05))
    assert r.saturated
    assert r.applied_tau_Nm == pytest.approx((0.6, 0.0, 0.0), abs=1e-9)
    f_c = F_MAX - 0.6 / (4 * L)
    assert r.applied_collective_throttle == pytest.approx(math.sqrt(f_c / F_MAX), abs=1e-12)
    assert r.throttle[1] == r.throttle[2] == pytest.approx(1.0)


def test_roll_pitch_scaled_when_their_spread_exceeds_the_range() -> None:
    r = Mixer().mix(0.5, (2.0, 2.0, 0.1))
    alpha = F_MAX / (2 * 2 * 2.0 / (4 * L))
    assert r.saturated
    assert r.applied_tau_Nm[0] == pytest.approx(2.0 * alpha, rel=1e-9)
    assert r.applied_tau_Nm[1] == pytest.approx(2.0 * alpha, rel=1e-9)
    assert r.throttle[2] == pytest.approx(1.0) and r.throttle[3] == pytest.approx(0.0)


def test_non_finite_inputs_are_zeroed_and_counted() -> None:
    m = Mixer()
    r = m.mix(0.5, (math.nan, 0.0, 0.0))
    assert r.throttle == pytest.approx((0.5,) * 4)
    assert m.mix(math.inf, (0.0, 0.0, 0.0)).throttle == (0.0,) * 4
    assert m.counters["nonfinite_torque"] == 1 and m.counters["nonfinite_collective"] == 1


def test_bad_frame_is_rejected() -> None:
    with pytest.raises(ValueError):
        Mixer("h")


@settings(deadline=None, max_examples=300)
@given(
    st.sampled_from(["x", "plus"]),
    st.floats(-0.2, 1.2),
    st.floats(-3.0, 3.0),
    st.floats(-3.0, 3.0),
    st.floats(-0.5, 0.5),
)
def test_mix_properties(frame: str, d_c: float, tx: float, ty: float, tz: float) -> None:
    m = Mixer(frame)
    layout = X_LAYOUT if frame == "x" else PLUS_LAYOUT
    r = m.mix(d_c, (tx, ty, tz))
    assert all(0.0 <= d <= 1.0 for d in r.throttle)
    total, *applied = _torque(layout, r.throttle)
    assert r.applied_tau_Nm == pytest.approx(tuple(applied), abs=1e-9)
    assert r.applied_collective_throttle == pytest.approx(math.sqrt(total / (4 * F_MAX)), abs=1e-9)
    ax, ay, az = r.applied_tau_Nm
    if not r.saturated:
        assert (ax, ay, az) == pytest.approx((tx, ty, tz), abs=1e-9)
        # Compared in thrust (d^2): sqrt near zero would magnify rounding of the eps tolerance.
        assert r.applied_collective_throttle**2 == pytest.approx(min(max(d_c, 0.0), 1.0) ** 2, abs=1e-9)
    # Roll/pitch keep their direction; they are kept whole whenever they can fit at all.
    assert ax * ty == pytest.approx(ay * tx, abs=1e-9)
    assert ax * tx >= -1e-12 and ay * ty >= -1e-12
    f_rp = [(-y * tx / sum(q[1] ** 2 for q in layout)) + (x * ty / sum(q[0] ** 2 for q in layout)) for x, y, _ in layout]
    if max(f_rp) - min(f_rp) <= F_MAX * (1 - 1e-9):
        assert (ax, ay) == pytest.approx((tx, ty), abs=1e-9)
    # Yaw is only ever reduced, never reversed or amplified.
    assert az * tz >= -1e-12 and abs(az) <= abs(tz) + 1e-9


D_H = 0.724  # the paper's quad: sqrt(1.1 g / 20.6)


def _pwm_linear(d_c: float, tau: tuple[float, float, float]) -> tuple[float, float, float, float]:
    """Reference PWM-era mixer, independently: d_i = d_c + dd_i with dd from the thrust split
    linearised at hover, dF = 2 F_max d_h dd (X frame)."""
    f_per_roll = [-1 / (4 * L), 1 / (4 * L), 1 / (4 * L), -1 / (4 * L)]  # thrust per N m, motors 0-3
    f_per_pitch = [1 / (4 * L), -1 / (4 * L), 1 / (4 * L), -1 / (4 * L)]
    f_per_yaw = [1 / (4 * C), 1 / (4 * C), -1 / (4 * C), -1 / (4 * C)]
    return tuple(d_c + (r * tau[0] + p * tau[1] + y * tau[2]) / (2 * F_MAX * D_H)
                 for r, p, y in zip(f_per_roll, f_per_pitch, f_per_yaw))  # type: ignore[return-value]


@settings(max_examples=80, deadline=None)
@given(d_c=st.floats(0.5, 0.9), axis=st.integers(0, 2), tau=st.floats(-0.2, 0.2))
def test_throttle_differential_on_one_axis_is_a_pwm_linear_mixer(d_c, axis, tau) -> None:
    """On one axis the motors move in pairs, (d + dd)^2 - (d - dd)^2 = 4 d dd: the torque of
    a throttle-linear mixer is exactly d_c / d_h times the request."""
    request = tuple(tau / 10 if k == axis == 2 else tau if k == axis else 0.0 for k in range(3))
    r = Mixer(differential="throttle", hover_throttle=D_H).mix(d_c, request)
    assert not r.saturated
    ref = _torque(X_LAYOUT, _pwm_linear(d_c, request))
    assert r.applied_tau_Nm == pytest.approx(ref[1:], abs=1e-9)
    assert r.applied_command_Nm == pytest.approx(request, abs=1e-9)


@settings(max_examples=80, deadline=None)
@given(d_c=st.floats(0.5, 0.9), tx=st.floats(-0.2, 0.2), ty=st.floats(-0.2, 0.2), tz=st.floats(-0.02, 0.02))
def test_throttle_differential_scales_the_request_by_the_collective(d_c, tx, ty, tz) -> None:
    """Axes combined: the applied torque is the request times d_c / d_h; a PWM mixer's dd^2
    cross terms (left out, flightcode/control/mixer.py) stay within 20 mN m here."""
    r = Mixer(differential="throttle", hover_throttle=D_H).mix(d_c, (tx, ty, tz))
    assert not r.saturated
    assert r.applied_tau_Nm == pytest.approx(tuple(t * d_c / D_H for t in (tx, ty, tz)), abs=1e-9)
    assert r.applied_command_Nm == pytest.approx((tx, ty, tz), abs=1e-9)
    ref = _torque(X_LAYOUT, _pwm_linear(d_c, (tx, ty, tz)))
    assert r.applied_tau_Nm == pytest.approx(ref[1:], abs=2e-2)


def test_throttle_differential_at_hover_is_the_thrust_mixer() -> None:
    a = Mixer(differential="throttle", hover_throttle=D_H).mix(D_H, (0.1, -0.05, 0.01))
    b = Mixer().mix(D_H, (0.1, -0.05, 0.01))
    assert a.throttle == pytest.approx(b.throttle, abs=1e-12)
    assert b.applied_command_Nm == b.applied_tau_Nm


def test_payload_raises_the_torque_gain_with_the_collective() -> None:
    """+300 g: hover at d = sqrt(1.4 g / 20.6) = 0.817, gain 0.817 / 0.724 = 1.128 (docs/controllers.md 2.7)."""
    d_payload = math.sqrt(1.4 * 9.80665 / 20.6)
    r = Mixer(differential="throttle", hover_throttle=D_H).mix(d_payload, (0.1, 0.0, 0.0))
    assert r.applied_tau_Nm[0] / 0.1 == pytest.approx(1.128, abs=0.002)
    assert Mixer().mix(d_payload, (0.1, 0.0, 0.0)).applied_tau_Nm[0] == pytest.approx(0.1)


def test_throttle_differential_saturation_reports_the_command_units() -> None:
    r = Mixer(differential="throttle", hover_throttle=D_H).mix(0.98, (0.6, 0.0, 0.0))
    assert r.saturated
    assert r.applied_command_Nm[0] == pytest.approx(r.applied_tau_Nm[0] / (0.98 / D_H))


@pytest.mark.parametrize("kw", [{"differential": "pwm"}, {"hover_throttle": 0.0}, {"hover_throttle": 1.0}])
def test_bad_differential_settings_are_rejected(kw) -> None:
    with pytest.raises(ValueError):
        Mixer(**kw)


def test_differential_by_enum_or_value() -> None:
    from flightcode.control.mixer import Differential

    assert Mixer(differential="throttle", hover_throttle=D_H).differential is Differential.THROTTLE
    assert Mixer(differential=Differential.THROTTLE, hover_throttle=D_H).mix(0.8, (0.1, 0, 0)).applied_tau_Nm[0] == (
        pytest.approx(0.1 * 0.8 / D_H))
    assert Mixer().differential is Differential.THRUST
