"""The payloads of the bench's own MCAP messages (docs/recording.md): plant truth, a tick's ADC
conversions, the ESC outputs, Foxglove's frame transform and pose (ENU/FLU), and any record
made JSON-ready.

Plant states are ``hil.plant.records.PlantState`` (NED, FRD body); times are sim ns.
"""

from __future__ import annotations

import dataclasses
import enum
import math
from typing import Any

import numpy as np

from hil.plant import quat

RAD2DEG = 180.0 / math.pi


def jsonable(value: Any) -> Any:
    """A JSON-ready copy of a record: dataclasses as dicts, enums by name, bytes as hex,
    non-finite floats as None, numpy scalars as Python numbers."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: jsonable(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, enum.Enum):
        return value.name
    if isinstance(value, (tuple, list)):
        return [jsonable(v) for v in value]
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, bytes):
        return value.hex()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, np.generic):
        return value.item()
    return value



def truth_payload(t_ns: int, st: Any) -> dict[str, Any]:
    r, p, y = st.euler_rpy_rad
    return {
        "t_ns": t_ns,
        "p_N_m": list(st.p_N_m),
        "v_N_mps": list(st.v_N_mps),
        "q_NB": list(st.q_NB),
        "euler_deg": {"roll": r * RAD2DEG, "pitch": p * RAD2DEG, "yaw": y * RAD2DEG},
        "omega_B_radps": list(st.omega_B_radps),
        "rotor_omega_radps": list(st.rotor_omega_radps),
        "thrust_N": list(st.thrust_N),
        "h_m": st.h_m,
        "battery_V": st.battery_V,
        "battery_A": st.battery_A,
        "battery_soc": st.battery_soc,
        "on_ground": bool(st.on_ground),
        "wind_N_mps": list(st.wind_N_mps),
        "mass_kg": st.mass_kg,
    }


def adc_payload(conversions: list[Any]) -> dict[str, Any]:
    """``hil.AdcConversions`` of a tick's ``Mcp3204Conversion`` events (in the order answered)."""
    t0 = conversions[0].t_ns
    out: dict[str, Any] = {
        "t_ns": t0,
        "channel": [c.channel for c in conversions],
        "code": [c.code for c in conversions],
        "volts": [c.volts for c in conversions],
        "single_ended": [c.single_ended for c in conversions],
        "vref_V": [c.vref_V for c in conversions],
    }
    if any(c.t_ns != t0 for c in conversions):
        out["dt_ns"] = [c.t_ns - t0 for c in conversions]
    return out


def esc_output(t_ns: int, throttle: tuple[float, ...], armed: tuple[float, ...]) -> dict[str, Any]:
    return {"t_ns": t_ns, "throttle": list(throttle), "armed": [bool(a) for a in armed]}


def _enu_pose(st: Any) -> tuple[dict[str, float], dict[str, float]]:
    # NED/FRD -> ENU/FLU for Foxglove's 3D panel: x_E = y_N, y_E = x_N, z_E = -z_N;
    # q_ENU_FLU = q_ENU_NED * q_NB * q_FRD_FLU.
    x, y, z = st.p_N_m
    qw, qx, qy, qz = ned_frd_to_enu_flu(st.q_NB)
    return {"x": y, "y": x, "z": -z}, {"x": qx, "y": qy, "z": qz, "w": qw}


def tf_payload(stamp: tuple[int, int], st: Any) -> dict[str, Any]:
    translation, rotation = _enu_pose(st)
    return {
        "timestamp": {"sec": stamp[0], "nsec": stamp[1]},
        "parent_frame_id": "world",
        "child_frame_id": "base_link",
        "translation": translation,
        "rotation": rotation,
    }


def pose_payload(stamp: tuple[int, int], st: Any) -> dict[str, Any]:
    translation, rotation = _enu_pose(st)
    return {
        "timestamp": {"sec": stamp[0], "nsec": stamp[1]},
        "frame_id": "world",
        "pose": {"position": translation, "orientation": rotation},
    }


_H = math.sqrt(0.5)
#: rotation taking NED vectors to ENU (180 deg about the axis (1,1,0)/sqrt2)
Q_ENU_NED: quat.Quat = (0.0, _H, _H, 0.0)
#: FLU body vectors to FRD (180 deg about x)
Q_FRD_FLU: quat.Quat = (0.0, 1.0, 0.0, 0.0)


def ned_frd_to_enu_flu(q_NB: quat.Quat) -> quat.Quat:
    return quat.mul(quat.mul(Q_ENU_NED, q_NB), Q_FRD_FLU)
