"""fc_design.h: the controller design both flight codes fly, from one flight config.

The LQI altitude gains and the altitude Kalman filter's discrete model are made by the Python
flight code's own classes (``LqiAltitude``: python-control's ``lqr`` computation;
``AltitudeKF``: ZOH and Van Loan, what ``control.c2d`` and filterpy compute) on the config as
``flightcode.config.load`` reads it, and written as single-precision constants. Everything else
the firmware's estimation and control need (memory gains from their poles, the prefilters'
ZOH, the mixer's allocation, the noise variances and limits) is computed from the config at
start, so a scenario can change it at run time; the design inputs are written here so the loop
can refuse a config that would fly a design other than the one compiled in.
"""

from __future__ import annotations

from dataclasses import dataclass

from flightcode.config import FlightConfig
from flightcode.control.lqi_altitude import AltitudeModel, LqiAltitude
from flightcode.estimation.altitude_kf import AltitudeKF

from . import emit

FILENAME = "fc_design.h"

#: The config keys the generated design depends on: (dotted key, C member path in the
#: loop's config struct (named as in flightcode/config_tables.py), is an integer).
DESIGN_INPUTS: tuple[tuple[str, str, bool], ...] = (
    ("imu.rate_hz", "imu.rate_hz", True),
    ("vehicle.m_kg", "vehicle.m_kg", False),
    ("vehicle.F_max_N", "vehicle.F_max_N", False),
    ("altitude.T1_s", "altitude.T1_s", False),
    ("altitude.q_int", "altitude.q_int", False),
    ("altitude.q_z", "altitude.q_z", False),
    ("altitude.q_vz", "altitude.q_vz", False),
    ("altitude.q_az", "altitude.q_az", False),
    ("altitude.r", "altitude.r", False),
    ("kf.q_a", "kf.q_a", False),
    ("kf.q_d", "kf.q_d", False),
    ("kf.q_b", "kf.q_b", False),
)


@dataclass(frozen=True)
class Design:
    """The design the firmware compiles in, in the Python flight code's float64."""

    T_s: float
    lqi: LqiAltitude
    kf: AltitudeKF


def design(cfg: FlightConfig) -> Design:
    """The LQI and the filter exactly as flightcode/loop_parts.py builds them from ``cfg``."""
    v, alt, kf = cfg.vehicle, cfg.altitude, cfg.kf
    model = AltitudeModel(v.m_kg, v.F_max_N, alt.T1_s)
    lqi = LqiAltitude(model, q_int=alt.q_int, q_z=alt.q_z, q_vz=alt.q_vz, q_az=alt.q_az, r=alt.r, T_s=cfg.T_s)
    est = AltitudeKF(model, cfg.T_s, kf.q_a, kf.q_d, kf.q_b, kf.r_baro_m2, kf.r_acc, kf.r_rest_vz,
                     kf.baro_gate_chi2, kf.baro_gate_timeout_s)
    return Design(cfg.T_s, lqi, est)


def _input_value(cfg: FlightConfig, dotted: str) -> object:
    table, key = dotted.split(".")
    return getattr(getattr(cfg, table), key)


def render(cfg: FlightConfig, source: str) -> str:
    """The text of fc_design.h for ``cfg`` (read from ``source``, named in the banner)."""
    d = design(cfg)
    lines: list[str] = ["/* -- design inputs: the loop refuses a config whose values differ ------------------ */", ""]
    for dotted, _, is_int in DESIGN_INPUTS:
        value = _input_value(cfg, dotted)
        literal = str(int(value)) if is_int else emit.c_double(float(value))  # type: ignore[arg-type]
        lines.append(f"#define {emit.macro_name(dotted, 'FC_DESIGN')} {literal}")
    lines += [
        "",
        "/* X(dotted key, member path in the loop's config struct, value): for the start-up check */",
        "#define FC_DESIGN_INPUTS(X) \\",
    ]
    for i, (dotted, member, _) in enumerate(DESIGN_INPUTS):
        end = " \\" if i < len(DESIGN_INPUTS) - 1 else ""
        lines.append(f'    X("{dotted}", {member}, {emit.macro_name(dotted, "FC_DESIGN")}){end}')
    f1, f2 = d.lqi.F1.tolist(), d.lqi.F2
    poles = ", ".join(f"{p.real:.4g}{p.imag:+.4g}j" for p in d.lqi.poles)
    lines += [
        "",
        "/* The loop period the design is for, s (1 / imu.rate_hz). */",
        f"#define FC_DESIGN_T_S {emit.c_float(d.T_s)}",
        "",
        "/* -- LQI altitude gains (flightcode.control.lqi_altitude.LqiAltitude) ------------------- */",
        f"/* continuous closed-loop poles, rad/s: {poles} */",
        "static const lqi_altitude_gains_t FC_DESIGN_LQI_GAINS = {",
        f"    .f_z = {emit.c_float(f1[0])},",
        f"    .f_vz = {emit.c_float(f1[1])},",
        f"    .f_az = {emit.c_float(f1[2])},",
        f"    .f_r = {emit.c_float(f2)},",
        "};",
        "",
        "/* -- altitude Kalman filter model (flightcode.estimation.altitude_kf.AltitudeKF) ------- */",
        "static const altitude_kf_model_t FC_DESIGN_KF_MODEL = {",
        f"    .F = {emit.c_float_matrix(d.kf.F.tolist())},",
        f"    .B = {emit.c_float_array(d.kf.B[:, 0].tolist())},",
        f"    .Q = {emit.c_float_matrix(d.kf.Q.tolist())},",
        "};",
    ]
    purpose = ("The controller design both flight codes fly: the LQI altitude gains and the altitude\n"
               "Kalman filter's discrete model, made by flightcode's own design code from the flight\n"
               "config (firmware/gen/design.py).")
    return emit.header("FC_DESIGN_H", source, purpose,
                       ("control/lqi_altitude.h", "estimation/altitude_kf.h"), "\n".join(lines))
