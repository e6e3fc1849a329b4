"""Rotors: layout, spin directions, thrust/torque ~ omega^2, motor lag, speed limit.

The integrator (``dynamics.py``) inlines these formulas on plain floats for speed; the
functions here are the readable reference used for set-up, snapshots and tests.

* Thrust along -z_B: ``T = k_T * sigma * g_e * f * omega^2`` (sigma: air density / ISA
  sea level, g_e: ground-effect gain, f: injected thrust factor, 1 = healthy).
* Drag torque on the body about z_B: ``+s * k_Q * sigma * f * omega^2`` with ``s = +1`` for a
  rotor turning counter-clockwise seen from above (the motor's reaction turns the body
  clockwise seen from above, which is positive yaw in FRD), ``-1`` for clockwise.
* Speed command: ``omega_cmd = throttle * omega_max * V / V_ref`` (the ESC's duty cycle
  scales the battery voltage; back-EMF makes speed ~ voltage).
* Lag: ``d omega/dt = (omega_cmd - omega) / tau`` with ``tau_up`` when speeding up and
  ``tau_down`` when slowing down (docs/protocols.md 6.1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from hil.plant.params_vehicle import FrameLayout, RotorParams

Vec3 = tuple[float, float, float]

#: Arm azimuths from the nose towards the right wing (deg), per rotor index.
_AZIMUTH_DEG: dict[FrameLayout, tuple[float, float, float, float]] = {
    FrameLayout.X: (45.0, 225.0, 315.0, 135.0),  # front-right, rear-left, front-left, rear-right
    FrameLayout.PLUS: (90.0, 270.0, 0.0, 180.0),  # right, left, front, back
}


@dataclass(frozen=True)
class RotorGeometry:
    """Hub positions (body FRD, from the body origin, m) and yaw-torque signs per rotor."""

    position_B_m: tuple[Vec3, Vec3, Vec3, Vec3]
    #: +1.0 for counter-clockwise seen from above (body yaw torque along +z_B), else -1.0.
    spin_sign: tuple[float, float, float, float]


def rotor_geometry(params: RotorParams) -> RotorGeometry:
    """Positions and spin signs of the four rotors for ``params.layout``."""
    az = _AZIMUTH_DEG[FrameLayout(params.layout)]
    pos = tuple(
        (
            params.arm_length_m * math.cos(math.radians(a)),
            params.arm_length_m * math.sin(math.radians(a)),
            params.rotor_z_B_m,
        )
        for a in az
    )
    signs = tuple(1.0 if ccw else -1.0 for ccw in params.spin_ccw_from_above)
    return RotorGeometry(pos, signs)  # type: ignore[arg-type]


def throttle_from_pulse_us(pulse_us: float, min_us: float = 1000.0, max_us: float = 2000.0) -> float:
    """ESC throttle in [0, 1] for a pulse width (us) on a calibrated [min_us, max_us] range."""
    if not max_us > min_us:
        raise ValueError("max_us must exceed min_us")
    d = (pulse_us - min_us) / (max_us - min_us)
    return 0.0 if not d > 0.0 else 1.0 if d > 1.0 else d


def omega_max_radps(params: RotorParams, battery_V: float) -> float:
    """Full-throttle rotor speed (rad/s) at a battery voltage (V)."""
    return params.omega_max_radps * max(battery_V, 0.0) / params.omega_max_ref_V


def thrust_N(params: RotorParams, omega_radps: float, density_ratio: float = 1.0, gain: float = 1.0) -> float:
    """Thrust (N) of one healthy rotor at ``omega_radps``."""
    return params.k_T_N_per_radps2 * density_ratio * gain * omega_radps * omega_radps


def drag_torque_Nm(params: RotorParams, omega_radps: float, density_ratio: float = 1.0) -> float:
    """Aerodynamic drag torque (N m) of one healthy rotor, magnitude."""
    return params.k_Q_Nm_per_radps2 * density_ratio * omega_radps * omega_radps


def lag_step(omega_radps: float, cmd_radps: float, dt_s: float, tau_up_s: float, tau_down_s: float) -> float:
    """Exact first-order response over ``dt_s`` towards a held command (rad/s)."""
    tau = tau_up_s if cmd_radps > omega_radps else tau_down_s
    return cmd_radps + (omega_radps - cmd_radps) * math.exp(-dt_s / tau)
