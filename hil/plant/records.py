"""The plant's output records: frozen snapshots handed to the bench, recorder and emulators."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

from hil.native.frozen import by_fields

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]
Four = tuple[float, float, float, float]


@dataclass(frozen=True, init=False)
class PlantState:
    """Truth snapshot. NED world, FRD body; position/velocity of the body origin."""

    t_ns: int
    p_N_m: Vec3
    v_N_mps: Vec3
    q_NB: Quat
    omega_B_radps: Vec3
    #: ZYX Euler (roll, pitch, yaw), rad.
    euler_rpy_rad: Vec3
    rotor_omega_radps: Four
    thrust_N: Four
    battery_V: float
    battery_soc: float
    battery_A: float
    on_ground: bool
    wind_N_mps: Vec3
    mass_kg: float
    #: Altitude of the body origin above its resting height on the field (= -p_N_m[2]).
    h_m: float

    def __init__(self, t_ns: int, p_N_m: Vec3, v_N_mps: Vec3, q_NB: Quat, omega_B_radps: Vec3, euler_rpy_rad: Vec3,
                 rotor_omega_radps: Four, thrust_N: Four, battery_V: float, battery_soc: float, battery_A: float,
                 on_ground: bool, wind_N_mps: Vec3, mass_kg: float, h_m: float) -> None:
        # written out: compiled, unlike the one @dataclass generates (tests/unit/test_compiled_records.py)
        object.__setattr__(self, "t_ns", t_ns)
        object.__setattr__(self, "p_N_m", p_N_m)
        object.__setattr__(self, "v_N_mps", v_N_mps)
        object.__setattr__(self, "q_NB", q_NB)
        object.__setattr__(self, "omega_B_radps", omega_B_radps)
        object.__setattr__(self, "euler_rpy_rad", euler_rpy_rad)
        object.__setattr__(self, "rotor_omega_radps", rotor_omega_radps)
        object.__setattr__(self, "thrust_N", thrust_N)
        object.__setattr__(self, "battery_V", battery_V)
        object.__setattr__(self, "battery_soc", battery_soc)
        object.__setattr__(self, "battery_A", battery_A)
        object.__setattr__(self, "on_ground", on_ground)
        object.__setattr__(self, "wind_N_mps", wind_N_mps)
        object.__setattr__(self, "mass_kg", mass_kg)
        object.__setattr__(self, "h_m", h_m)

    def __reduce__(self) -> tuple[type, tuple[object, ...]]:
        return by_fields(self)  # compiled records pickle by field (hil/native/frozen.py)


class VibrationTone(NamedTuple):
    """One rotor's vibration at one sensor, a sinusoid per axis (hil/plant/vibration.py):

        v(t) = Re{(re + j im) e^(j phi)} = re cos(phi) - im sin(phi),
        phi = phase_rad + omega_radps (t - t_ref)

    with ``t_ref`` the sim time of the record that carries it, and the frequency and phase
    held for extrapolation. Units and axes are those of the field that holds the tone.
    (A NamedTuple, not a dataclass: up to 12 are made every tick.)
    """

    omega_radps: float
    phase_rad: float
    re: Vec3
    im: Vec3


@dataclass(frozen=True, init=False)
class SensorTruth:
    """Physical inputs of the sensors, noise-free (the emulators add their errors).

    ``q_NS``/``omega_S_radps``/``f_S_mps2``: the IMU's orientation (S -> NED), rates and
    specific force at its location, in its sensor frame S (FRD convention: z down, so a
    level IMU at rest reads f_S = (0, 0, -g); see SensorMountParams). ``f_acc_B_mps2``: specific force
    at the ADXL335, body FRD axes. ``p_static_Pa``: pressure at the barometer port.

    The rotor-imbalance vibration is not in the fields above (rigid-body motion only): it
    comes as tones, one per spinning rotor, which each sensor passes through its own
    frequency response (emulators/vibration.py). ``vib_f_S``: specific force at the IMU,
    sensor frame S, m/s^2; ``vib_omega_S``: angular rate at the IMU, S, rad/s;
    ``vib_f_acc_B``: specific force at the ADXL335, body FRD, m/s^2. Empty: no vibration.
    """

    t_ns: int
    q_NS: Quat
    omega_S_radps: Vec3
    f_S_mps2: Vec3
    f_acc_B_mps2: Vec3
    p_static_Pa: float
    air_T_C: float
    vib_f_S: tuple[VibrationTone, ...] = ()
    vib_omega_S: tuple[VibrationTone, ...] = ()
    vib_f_acc_B: tuple[VibrationTone, ...] = ()

    def __init__(self, t_ns: int, q_NS: Quat, omega_S_radps: Vec3, f_S_mps2: Vec3, f_acc_B_mps2: Vec3,
                 p_static_Pa: float, air_T_C: float, vib_f_S: tuple[VibrationTone, ...] = (),
                 vib_omega_S: tuple[VibrationTone, ...] = (), vib_f_acc_B: tuple[VibrationTone, ...] = ()) -> None:
        # written out: compiled, unlike the one @dataclass generates (tests/unit/test_compiled_records.py)
        object.__setattr__(self, "t_ns", t_ns)
        object.__setattr__(self, "q_NS", q_NS)
        object.__setattr__(self, "omega_S_radps", omega_S_radps)
        object.__setattr__(self, "f_S_mps2", f_S_mps2)
        object.__setattr__(self, "f_acc_B_mps2", f_acc_B_mps2)
        object.__setattr__(self, "p_static_Pa", p_static_Pa)
        object.__setattr__(self, "air_T_C", air_T_C)
        object.__setattr__(self, "vib_f_S", vib_f_S)
        object.__setattr__(self, "vib_omega_S", vib_omega_S)
        object.__setattr__(self, "vib_f_acc_B", vib_f_acc_B)

    def __reduce__(self) -> tuple[type, tuple[object, ...]]:
        return by_fields(self)  # compiled records pickle by field (hil/native/frozen.py)
