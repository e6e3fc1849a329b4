"""Parameters of the vehicle: airframe, rotors, battery, aerodynamics, sensor mounting,
rotor imbalance.

Frozen dataclasses whose defaults are the paper's vehicle; each sets
``__pydantic_config__`` for ``hil/config/files.py``. Where each number comes from ("Table
1", "docs/controllers.md", "protocols", "assumed"), the frames and the rotor numbering:
``hil/plant/params.py``, which gathers every parameter class. This module imports nothing
but the standard library and the environment's parameters (standard gravity, the shared
checks).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum, unique

from hil.plant.params_environment import G0_MPS2, _finite, _require

_RPM_TO_RADPS = 2.0 * math.pi / 60.0

Vec3 = tuple[float, float, float]


@unique
class FrameLayout(StrEnum):
    """Rotor arrangement. ``"x"``: arms at 45 degrees to the nose; ``"+"``: an arm on the nose."""

    X = "x"
    PLUS = "+"


@dataclass(frozen=True)
class BodyParams:
    """Rigid airframe without payload. Inertia is about the CG, in body FRD axes."""

    __pydantic_config__ = {"extra": "forbid"}

    mass_kg: float = 1.1  # Table 1
    #: Principal moments (J_xx, J_yy, J_zz). J_xx from the component table of docs/controllers.md 2.3
    #: (0.0153, plausible 0.012-0.020); J_yy = J_xx by symmetry; J_zz assumed from the same
    #: table with horizontal radii (motors 0.0188 + ESCs + arms + gear + hub = 0.024).
    inertia_B_kgm2: Vec3 = (0.0153, 0.0153, 0.024)
    #: Tensor elements (J_xy, J_xz, J_yz) = (-sum m x y, -sum m x z, -sum m y z); zero for a
    #: symmetric airframe.
    inertia_offdiag_B_kgm2: Vec3 = (0.0, 0.0, 0.0)
    #: CG of the empty vehicle relative to the body origin (hub centre).
    cg_B_m: Vec3 = (0.0, 0.0, 0.0)
    #: Depth of the landing-gear feet below the body origin: the body origin rests this far
    #: above the ground (assumed; 250 mm high overall per Table 1, rotors on top).
    gear_depth_m: float = 0.20

    def __post_init__(self) -> None:
        _require(self.mass_kg > 0.0, "mass_kg must be > 0")
        _require(all(j > 0.0 for j in self.inertia_B_kgm2), "inertia_B_kgm2 must be > 0")
        _require(_finite(self.inertia_offdiag_B_kgm2 + self.cg_B_m), "non-finite body value")
        _require(self.gear_depth_m >= 0.0, "gear_depth_m must be >= 0")


@dataclass(frozen=True)
class RotorParams:
    """Four rotors: geometry, thrust/torque ~ omega^2, first-order lag, battery-limited speed."""

    __pydantic_config__ = {"extra": "forbid"}

    layout: FrameLayout = FrameLayout.X  # X frame default (task brief)
    #: Hub-to-motor distance: 500 mm motor-to-motor diameter (Table 1) / 2.
    arm_length_m: float = 0.25
    #: Rotor plane relative to the body origin along z_B (negative = above), assumed.
    rotor_z_B_m: float = -0.05
    #: Spin seen from above, per rotor index (ArduPilot/PX4 quad numbering, see hil/plant/params.py).
    spin_ccw_from_above: tuple[bool, bool, bool, bool] = (True, True, False, False)
    #: Full-throttle rotor speed at ``omega_max_ref_V``: ~8000 rpm (Table 1).
    omega_max_radps: float = 8000.0 * _RPM_TO_RADPS
    #: Battery voltage at which ``omega_max_radps`` holds (omega_max scales with voltage).
    #: 12.15 V is a full 3S pack under hover load (12.6 V open circuit minus ~0.45 V sag),
    #: so the paper's hover throttle 0.724 (docs/controllers.md 3.1) is what it needs at take-off.
    omega_max_ref_V: float = 12.15
    #: Thrust of one rotor at ``omega_max_radps`` in ISA sea-level air: (1.1 kg + 1.0 kg
    #: lift) * g / 4 = 20.6 N / 4 (Table 1, docs/controllers.md 3.1: F = F_max d^2).
    thrust_max_N: float = (1.1 + 1.0) * G0_MPS2 / 4.0
    #: Drag torque / thrust (= k_Q / k_T) of the APC 12x4.5: static C_P / (2 pi C_T) x D
    #: gives 0.016-0.020 m; 0.016 is also the flight code's mixer constant. With the
    #: efficiency below the hover current is ~11 A: the ~10 min flight of Table 1.
    torque_per_thrust_m: float = 0.016
    #: Motor lag time constants for speeding up / slowing down (PX4 x500
    #: MulticopterMotorModel: 0.0125 s / 0.025 s, docs/protocols.md 6.1).
    tau_up_s: float = 0.0125
    tau_down_s: float = 0.025
    #: Spinning inertia of prop + motor bell (APC 12x4.5, ~19 g blade; assumed).
    rotor_inertia_kgm2: float = 9.5e-5
    #: APC 12x4.5 props: 12 in diameter (Table 1).
    radius_m: float = 0.1524
    #: Mechanical shaft power / battery power of motor + ESC (assumed).
    efficiency: float = 0.8

    def __post_init__(self) -> None:
        _require(self.arm_length_m > 0.0, "arm_length_m must be > 0")
        _require(self.omega_max_radps > 0.0 and self.omega_max_ref_V > 0.0, "omega_max must be > 0")
        _require(self.thrust_max_N > 0.0, "thrust_max_N must be > 0")
        _require(self.torque_per_thrust_m >= 0.0, "torque_per_thrust_m must be >= 0")
        _require(self.tau_up_s > 0.0 and self.tau_down_s > 0.0, "motor time constants must be > 0")
        _require(self.rotor_inertia_kgm2 >= 0.0, "rotor_inertia_kgm2 must be >= 0")
        _require(self.radius_m > 0.0, "radius_m must be > 0")
        _require(0.0 < self.efficiency <= 1.0, "efficiency must be in (0, 1]")
        _require(len(self.spin_ccw_from_above) == 4, "spin_ccw_from_above needs 4 entries")

    @property
    def k_T_N_per_radps2(self) -> float:
        """Thrust coefficient: T = k_T * omega^2 (sea-level ISA density)."""
        return self.thrust_max_N / (self.omega_max_radps * self.omega_max_radps)

    @property
    def k_Q_Nm_per_radps2(self) -> float:
        """Drag-torque coefficient: Q = k_Q * omega^2 (sea-level ISA density)."""
        return self.k_T_N_per_radps2 * self.torque_per_thrust_m


#: Resting open-circuit voltage of one LiPo cell vs state of charge: the widely published
#: hobby LiPo chart (4.20 V full, 3.84 V at 50 %, 3.27 V empty), assumed for the Table 1 pack.
LIPO_SOC_POINTS: tuple[float, ...] = (
    0.00, 0.05, 0.10, 0.15, 0.20, 0.25, 0.30, 0.35, 0.40, 0.45, 0.50,
    0.55, 0.60, 0.65, 0.70, 0.75, 0.80, 0.85, 0.90, 0.95, 1.00,
)  # fmt: skip
LIPO_CELL_OCV_V: tuple[float, ...] = (
    3.27, 3.61, 3.69, 3.71, 3.73, 3.75, 3.77, 3.79, 3.80, 3.82, 3.84,
    3.85, 3.87, 3.91, 3.95, 3.98, 4.02, 4.08, 4.11, 4.15, 4.20,
)  # fmt: skip


@dataclass(frozen=True)
class BatteryParams:
    """3S LiPo (Table 1): open-circuit voltage vs charge, ohmic sag with current."""

    __pydantic_config__ = {"extra": "forbid"}

    cells: int = 3  # 3S (Table 1)
    capacity_Ah: float = 2.1  # 2100 mAh (Table 1)
    #: Pack + leads, assumed (~12 mOhm per cell of a 20C 2100 mAh pack, plus wiring).
    internal_resistance_ohm: float = 0.04
    soc_initial: float = 1.0
    #: XSENS + ARM7 + XBee-PRO + receiver + sensors, assumed ~5.5 W at 11 V.
    avionics_current_A: float = 0.5
    soc_points: tuple[float, ...] = LIPO_SOC_POINTS
    cell_ocv_V: tuple[float, ...] = LIPO_CELL_OCV_V

    def __post_init__(self) -> None:
        _require(self.cells >= 1, "cells must be >= 1")
        _require(self.capacity_Ah > 0.0, "capacity_Ah must be > 0")
        _require(self.internal_resistance_ohm >= 0.0, "internal_resistance_ohm must be >= 0")
        _require(0.0 <= self.soc_initial <= 1.0, "soc_initial must be in [0, 1]")
        _require(self.avionics_current_A >= 0.0, "avionics_current_A must be >= 0")
        _require(
            len(self.soc_points) == len(self.cell_ocv_V) >= 2,
            "soc_points and cell_ocv_V need the same length (>= 2)",
        )
        _require(
            all(a < b for a, b in zip(self.soc_points, self.soc_points[1:], strict=False)),
            "soc_points must increase",
        )


@dataclass(frozen=True)
class AeroParams:
    """Body and rotor drag, flapping, ground effect on thrust, rotor-wash error at the static port.

    Body drag acts at the centre of pressure on the CG's air-relative velocity in body axes;
    rotor drag and flapping act at each hub on that hub's air-relative velocity (including
    body rotation and the local gust). All scale with air density (values for ISA sea level).
    """

    __pydantic_config__ = {"extra": "forbid"}

    #: Linear parasitic drag per body axis (assumed; ~0.35 N/(m/s) horizontal in hover with
    #: the rotor drag below, a 1 kg-class quad).
    linear_drag_B_N_per_mps: Vec3 = (0.10, 0.10, 0.20)
    #: Quadratic drag F = -c v|v| per body axis (vertical 0.05 as in docs/controllers.md 3.5).
    quadratic_drag_B_N_per_mps2: Vec3 = (0.03, 0.03, 0.05)
    #: Rotor drag (H-force) in the rotor plane, per rotor, at its hub: F = -k_d * omega * v_hub
    #: (RotorPy's ``k_d`` form; Martin & Salaun, ICRA 2010, "The true role of accelerometer
    #: feedback in quadrotor control"). 1.0e-4 is 0.06 N/(m/s) per rotor at hover speed, 0.24
    #: N/(m/s) for the vehicle: below the momentum drag rho A v_i = 0.35 N/(m/s) per rotor of
    #: a 12 in rotor at 2.7 N (an upper bound); RotorPy's Hummingbird has 1.19e-4 for 10 cm
    #: rotors (assumed; docs/aerodynamics.md).
    rotor_drag_N_per_mps_per_radps: float = 1.0e-4
    #: Rotor drag along the shaft (RotorPy's ``k_z``, "induced inflow"): a rotor moving up
    #: through the air loses thrust, F_z = -k_z * omega * v_hub,z. Blade-element momentum
    #: theory in hover (Leishman, Principles of Helicopter Aerodynamics, 2nd ed., ch. 2-3):
    #: dT/dV_c = -2 rho A v_i * sigma a / (16 lambda_i + sigma a) = -0.33 N/(m/s) per rotor
    #: for the APC 12x4.5 (solidity 0.10, lift slope 5.7, v_i = 3.9 m/s, lambda_i = 0.042),
    #: / 607 rad/s hover speed = 5.4e-4. It is also what turns vertical gusts that differ
    #: from rotor to rotor, and roll/pitch rates, into moments (docs/aerodynamics.md).
    rotor_drag_vertical_N_per_mps_per_radps: float = 5.4e-4
    #: Blade-flapping hub moment per rotor, M = k_f * omega * (e_z x v_hub) (RotorPy's
    #: ``k_flap`` form, with the physical sign: the disk tilts away from the relative wind,
    #: nose up when moving forward). Hub-spring model of Hoffmann et al. (AIAA GNC 2007,
    #: "Quadrotor helicopter flight dynamics and control: theory and experiment"),
    #: M = k_beta a1s: longitudinal flapping a1s = mu (8/3 theta_0.75 - 2 lambda_i) (Prouty)
    #: = 3.6e-3 rad per m/s for the APC 12x4.5 at hover; hub stiffness k_beta = I_beta
    #: Omega^2 3e/(2(1-e)) (Padfield, Helicopter Flight Dynamics, ch. 3) with I_beta = 7.7e-5
    #: kg m^2 and an equivalent hinge offset e = 0.02 (assumed: a flexible plastic prop;
    #: full-scale hingeless rotors have 0.1-0.15, which would give 2.8e-5): 0.87 N m/rad,
    #: 3.1e-3 N m per m/s per rotor at 607 rad/s -> 5.2e-6. The thrust tilt itself is in
    #: the H-force above. docs/aerodynamics.md has the derivation and the sensitivity.
    flapping_moment_Nm_per_mps_per_radps: float = 5.2e-6
    #: Where the body drag acts, relative to the body origin (body FRD, m): the landing gear
    #: and the battery hang below the hub, so the centre of pressure sits below it (assumed).
    centre_of_pressure_B_m: Vec3 = (0.0, 0.0, 0.03)
    #: Rotational damping per body axis (assumed negligible).
    angular_drag_B_Nm_per_radps: Vec3 = (0.0, 0.0, 0.0)
    #: Ground effect on every rotor: Sanchez-Cuevas, Heredia, Ollero, Int. J. Aerospace Eng.
    #: 2017 (doi 10.1155/2017/1823056) Eq. 4, with their fitted body coefficient K_b = 2.
    ground_effect: bool = True
    ground_effect_body_coeff: float = 2.0
    #: Cap on the thrust gain (the formula is singular very close to the ground).
    ground_effect_max_gain: float = 1.5
    #: Static-port pressure error as a fraction of the mean rotor disk loading (Pa/Pa):
    #: everywhere (prop wash) plus a part that decays with height (ground cushion, the
    #: "baro ground effect" flight stacks compensate; assumed).
    baro_prop_wash_gain: float = 0.0
    baro_ground_effect_gain: float = 0.3
    baro_ground_effect_height_m: float = 0.5

    def __post_init__(self) -> None:
        vals = self.linear_drag_B_N_per_mps + self.quadratic_drag_B_N_per_mps2
        _require(all(v >= 0.0 for v in vals + self.angular_drag_B_Nm_per_radps), "drag must be >= 0")
        _require(
            self.rotor_drag_N_per_mps_per_radps >= 0.0 and self.rotor_drag_vertical_N_per_mps_per_radps >= 0.0,
            "rotor drag must be >= 0",
        )
        _require(self.flapping_moment_Nm_per_mps_per_radps >= 0.0, "flapping moment must be >= 0")
        _require(_finite(self.centre_of_pressure_B_m), "centre_of_pressure_B_m must be finite")
        _require(self.ground_effect_body_coeff >= 0.0, "ground_effect_body_coeff must be >= 0")
        _require(self.ground_effect_max_gain >= 1.0, "ground_effect_max_gain must be >= 1")
        _require(self.baro_ground_effect_height_m > 0.0, "baro_ground_effect_height_m must be > 0")


@dataclass(frozen=True)
class SensorMountParams:
    """Where the sensors sit (body FRD, from the body origin) and how the IMU is turned.

    The paper gives no positions; these are assumed small offsets on the hub.
    """

    __pydantic_config__ = {"extra": "forbid"}

    imu_position_B_m: Vec3 = (0.0, 0.0, -0.03)
    #: The IMU's sensor frame S in its FRD convention (x out of the connector end, y right,
    #: z down through the base; the contract of emulators/xsens/frames.py, which turns S
    #: into the device's own x-forward/y-left/z-up frame for ENU/NWU outputs) relative to
    #: the body, as ZYX Euler (roll, pitch, yaw) in degrees: v_B = Rz(yaw) Ry(pitch) Rx(roll)
    #: v_S. Zero: mounted upright, facing forward, aligned with the body axes.
    imu_rotation_BS_rpy_deg: Vec3 = (0.0, 0.0, 0.0)
    #: ADXL335 board; its specific force is reported in body axes.
    accel_position_B_m: Vec3 = (0.03, 0.0, -0.02)
    #: MPX5100AP static port.
    baro_position_B_m: Vec3 = (-0.03, 0.0, -0.02)

    def __post_init__(self) -> None:
        vals = self.imu_position_B_m + self.accel_position_B_m + self.baro_position_B_m
        _require(_finite(vals + self.imu_rotation_BS_rpy_deg), "sensor mounting must be finite")


#: Rotating mass of one rotor: APC 12x4.5 prop (~19 g, the blade of ``rotor_inertia_kgm2``)
#: plus the bell of a ~900 kV outrunner (~26 g), assumed.
ROTOR_ROTATING_MASS_KG = 0.045


def iso1940_imbalance_kgm(grade_mm_per_s: float, rotor_mass_kg: float, omega_service_radps: float) -> float:
    """Permissible residual imbalance U = m e (kg m) of ISO 1940-1 (ISO 21940-11) balance grade
    ``G`` (mm/s) at the maximum service speed: e = G / Omega."""
    return rotor_mass_kg * grade_mm_per_s * 1e-3 / omega_service_radps


@dataclass(frozen=True)
class VibrationParams:
    """Per-rotor static mass imbalance (hil/plant/vibration.py, docs/vibration.md).

    Rotor ``i`` carries an imbalance U_i = m_u r_u (kg m) at its own phase: a force of
    magnitude U_i omega_i^2 rotating in the rotor plane with the rotor. It shakes the
    airframe at the rotor's frequency (97 Hz at hover, 133 Hz at full speed); the sensors
    see it through their own bandwidths. It is added to what the sensors measure, not to the
    rigid-body dynamics (the displacement is under 1 um).

    The default, 8.6e-7 kg m (0.86 g mm, 5.6 mg at the 152 mm blade tip), is ISO 1940-1
    balance grade G16 for the 45 g rotating mass at the 8000 rpm maximum service speed
    (e = G / Omega = 19 um): a hobby prop balanced statically (assumed). G6.3, the grade of
    fans and motor rotors, gives 3.4e-7 (``iso1940_imbalance_kgm``).
    """

    __pydantic_config__ = {"extra": "forbid"}

    #: False: no vibration at all (the sensors get exactly what they got before the model).
    enabled: bool = True
    #: U = m_u r_u per rotor (ESC channel order), kg m.
    imbalance_kgm: tuple[float, float, float, float] = (8.6e-7, 8.6e-7, 8.6e-7, 8.6e-7)
    #: Each rotor's U is multiplied by a factor drawn uniformly from [1 - spread, 1 + spread]
    #: (the vibration Generator; 0: exactly ``imbalance_kgm``). Props of one batch differ.
    imbalance_spread: float = 0.5
    #: Angle of each heavy spot at sim time 0 from body +x, in the rotor's direction of
    #: rotation, rad; None: drawn uniformly in [0, 2 pi) from the vibration Generator.
    phase_rad: tuple[float, float, float, float] | None = None

    def __post_init__(self) -> None:
        _require(len(self.imbalance_kgm) == 4, "imbalance_kgm needs 4 entries (one per rotor)")
        _require(
            all(math.isfinite(u) and u >= 0.0 for u in self.imbalance_kgm), "imbalance_kgm must be finite and >= 0"
        )
        _require(  # a unit slip (g mm for kg m) is 1e6 too large
            all(u <= 1e-3 for u in self.imbalance_kgm),
            "imbalance_kgm above 1e-3 kg m (1000 g mm, 370 N per rotor at hover speed): the unit is kg m, not g mm",
        )
        _require(0.0 <= self.imbalance_spread < 1.0, "imbalance_spread must be in [0, 1)")
        _require(
            self.phase_rad is None or (len(self.phase_rad) == 4 and _finite(self.phase_rad)),
            "phase_rad needs 4 finite angles (or leave it out to draw them)",
        )
