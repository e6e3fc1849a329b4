"""The firmware's estimation and control modules, built for the host and driven through ctypes.

:func:`build` generates the design header from a flight config (firmware/gen), compiles the
modules with the test shim (shim.c) into one shared library (firmware/hostlib.py) and wraps it:
each class below owns one C state struct in a ctypes buffer and mirrors the Python flight
code's class of the same job, so a test can feed both the same inputs.
"""

from __future__ import annotations

import ctypes as C
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "firmware"))
import gen  # noqa: E402
import hostlib  # noqa: E402

SHIM = Path(__file__).resolve().parent / "shim.c"

F = C.c_float
FP = C.POINTER(C.c_float)
U32P = C.POINTER(C.c_uint32)
VP = C.c_void_p
B = C.c_bool

_SIGNATURES: dict[str, tuple[object, list[object]]] = {
    "shim_sizeof": (C.c_size_t, [C.c_int]),
    "shim_design_read": (None, [FP, FP, FP, FP, FP]),
    # altitude KF
    "shim_kf_init": (None, [VP, F, F, F, F, C.c_int64, C.c_int64]),
    "shim_kf_read": (None, [VP, FP, FP, U32P, U32P]),
    "shim_kf_write": (None, [VP, FP, FP, C.c_uint32]),
    "altitude_kf_reset": (None, [VP, F, F]),
    "altitude_kf_predict": (None, [VP, F]),
    "altitude_kf_update": (B, [VP, B, F, B, F, F]),
    "altitude_kf_update_at_rest": (None, [VP]),
    "altitude_kf_loosen_height": (None, [VP, F]),
    "altitude_kf_move_to": (None, [VP, F, F, F, F]),
    "altitude_kf_gate_max_rejects": (C.c_uint32, [C.c_int64, C.c_int64]),
    # plausibility
    "shim_plaus_init": (B, [VP, F, C.c_uint16, F, F, F, F, F, F]),
    "shim_plaus_read": (None, [VP, U32P, C.POINTER(B)]),
    "plausibility_baro_Pa": (B, [VP, B, F]),
    "plausibility_accel_in_range": (B, [VP, FP]),
    "plausibility_accel_agrees": (B, [VP, F, F]),
    "plausibility_accel_offset_holds": (B, [VP, F, F]),
    "plausibility_take_offset_worst": (F, [VP]),
    "plausibility_refused": (C.c_uint32, [VP]),
    "flat_line_init": (B, [VP, C.c_uint16, F]),
    "flat_line_add": (B, [VP, F]),
    "shim_flat_var": (F, [VP]),
    # barometer motion
    "shim_bm_init": (B, [VP, C.c_int64, C.c_int64, F]),
    "shim_bm_read": (None, [VP, U32P, FP, C.POINTER(C.c_uint16)]),
    "baro_motion_add": (B, [VP, C.c_int64, B, F, B, F, F, F, B]),
    "baro_motion_reading_rejected": (None, [VP]),
    "baro_motion_take_reanchor": (B, [VP, FP, FP]),
    "baro_motion_take_worst": (F, [VP]),
    "baro_motion_on_ground": (None, [VP]),
    # prefilter
    "shim_pf_init": (B, [VP, F, F]),
    "shim_pf_params": (None, [VP, FP, FP]),
    "shim_pf_update": (None, [VP, F, FP]),
    "shim_pf_reset": (None, [VP, F, FP]),
    # memory attitude
    "shim_mem_init": (B, [VP, B, F, F, F, F, F, F, F]),
    "shim_mem_update": (F, [VP, FP, F, F, B]),
    "shim_mem_read": (None, [VP, FP, U32P]),
    "memory_attitude_set_applied": (None, [VP, F]),
    "memory_attitude_reset": (None, [VP]),
    # yaw rate
    "shim_yaw_init": (B, [VP, F, F, F, F]),
    "shim_yaw_read": (None, [VP, FP, U32P]),
    "yaw_rate_update": (F, [VP, F, F, B]),
    "yaw_rate_set_applied": (None, [VP, F]),
    # LQI
    "shim_lqi_init": (B, [VP, F, F, F]),
    "shim_lqi_read": (None, [VP, FP, U32P]),
    "lqi_altitude_update": (F, [VP, F, F, F, F, B]),
    "lqi_altitude_hover_throttle": (F, [F, F]),
    # mixer
    "shim_mixer_init": (B, [VP, C.c_int, F, F, F, C.c_int, F]),
    "shim_mixer_mix": (None, [VP, F, FP, FP]),
    "shim_mixer_read": (None, [VP, FP, U32P]),
    # landing
    "landing_descent_init": (B, [VP, F]),
    "landing_descent_start": (None, [VP, F]),
    "landing_descent_stop": (None, [VP]),
    "landing_descent_step": (F, [VP, F]),
    "hover_throttle_init": (B, [VP, F, F, F, F]),
    "hover_throttle_steady": (B, [F, F, F, F]),
    "hover_throttle_update": (F, [VP, F, F]),
    "touchdown_accel_init": (None, [VP]),
    "touchdown_accel_update": (F, [VP, F, F]),
}

_SIZE_INDEX = {"kf": 0, "plaus": 1, "bm": 2, "pf": 3, "mem": 4, "yaw": 5, "lqi": 6, "mixer": 7, "descent": 8,
               "hover": 9, "touchdown": 10, "flat": 11}


def build(config: Path, out_dir: Path, src: Path = hostlib.SRC) -> Lib:
    """Generate the design header for ``config`` and build the modules under ``src``
    (firmware/src, or a mutant's copy of it: its warnings are not errors, as in the Makefile's
    build) with the shim into a library under ``out_dir``."""
    gen_dir = out_dir / "gen"
    gen.generate(config, gen_dir)
    extra = () if src == hostlib.SRC else ("-Wno-error",)
    path = hostlib.build_shared((*hostlib.estctl_sources(src), SHIM), out_dir, "estctl", include_dirs=(gen_dir, src),
                                extra_flags=extra)
    return Lib(path)


def _fa(n: int) -> C.Array:
    return (C.c_float * n)()


class Lib:
    """The loaded library with every function's signature set."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.dll = C.CDLL(str(path))
        for name, (res, args) in _SIGNATURES.items():
            fn = getattr(self.dll, name)
            fn.restype = res
            fn.argtypes = args

    def new(self, what: str) -> C.Array:
        """A zeroed buffer the size of one C state struct."""
        return C.create_string_buffer(self.dll.shim_sizeof(_SIZE_INDEX[what]))

    def design(self) -> dict[str, np.ndarray]:
        f, b, q, lqi, t = _fa(25), _fa(5), _fa(25), _fa(4), F()
        self.dll.shim_design_read(f, b, q, lqi, C.byref(t))
        return {"F": np.array(f).reshape(5, 5), "B": np.array(b), "Q": np.array(q).reshape(5, 5),
                "lqi": np.array(lqi), "T_s": np.float32(t.value)}


class CKalman:
    """altitude_kf_t, the Python AltitudeKF's calls."""

    def __init__(self, lib: Lib, r_baro_m2: float, r_acc: float, r_rest_vz: float, chi2: float, timeout_s: float,
                 T_s: float = 0.0025):
        self.d, self.s = lib.dll, lib.new("kf")
        self.d.shim_kf_init(self.s, r_baro_m2, r_acc, r_rest_vz, chi2, round(timeout_s * 1e9), round(T_s * 1e9))

    def reset(self, z0: float, z_var: float) -> None:
        self.d.altitude_kf_reset(self.s, z0, z_var)

    def predict(self, u: float) -> None:
        self.d.altitude_kf_predict(self.s, u)

    def update(self, z_baro: float | None, a_up: float | None, r_scale: float = 1.0) -> bool:
        return self.d.altitude_kf_update(self.s, z_baro is not None, 0.0 if z_baro is None else z_baro,
                                         a_up is not None, 0.0 if a_up is None else a_up, r_scale)

    def update_at_rest(self) -> None:
        self.d.altitude_kf_update_at_rest(self.s)

    def loosen_height(self, var: float) -> None:
        self.d.altitude_kf_loosen_height(self.s, var)

    def move_to(self, z: float, vz: float, z_var: float, vz_var: float) -> None:
        self.d.altitude_kf_move_to(self.s, z, vz, z_var, vz_var)

    def write(self, x: np.ndarray, P: np.ndarray, run: int) -> None:
        """Set the state (rounded to single precision): to start a step from the Python filter's."""
        self.d.shim_kf_write(self.s, (C.c_float * 5)(*np.ravel(x)), (C.c_float * 25)(*np.ravel(P)), run)

    def read(self) -> tuple[np.ndarray, np.ndarray, dict[str, int], int]:
        x, p, c, run = _fa(5), _fa(25), (C.c_uint32 * 5)(), C.c_uint32()
        self.d.shim_kf_read(self.s, x, p, c, C.byref(run))
        names = ("nonfinite_input", "nonfinite_baro", "nonfinite_acc", "baro_rejected", "baro_reanchored")
        return np.array(x), np.array(p).reshape(5, 5), dict(zip(names, c)), run.value


class CPlausibility:
    COUNTERS = ("baro_out_of_range", "baro_flat", "baro_step", "accel_out_of_range", "accel_disagrees_xsens",
                "accel_offset_moved")

    def __init__(self, lib: Lib, max_step: float, flat_n: int, flat_std: float, accel_g: float, tol: float,
                 offset_tau_s: float = 1.0, offset_max: float = 0.25, T_s: float = 0.0025):
        self.d, self.s = lib.dll, lib.new("plaus")
        self.ok = self.d.shim_plaus_init(self.s, max_step, flat_n, flat_std, accel_g, tol, offset_tau_s, offset_max,
                                         T_s)

    def baro_Pa(self, p: float | None) -> float | None:
        ok = self.d.plausibility_baro_Pa(self.s, p is not None, 0.0 if p is None else p)
        return float(np.float32(p)) if ok else None

    def accel_in_range(self, f: tuple[float, float, float]) -> bool:
        return self.d.plausibility_accel_in_range(self.s, (C.c_float * 3)(*f))

    def accel_agrees(self, a: float, a_x: float) -> bool:
        return self.d.plausibility_accel_agrees(self.s, a, a_x)

    def accel_offset_holds(self, a: float, a_x: float) -> bool:
        return self.d.plausibility_accel_offset_holds(self.s, a, a_x)

    def take_offset_worst(self) -> float:
        return self.d.plausibility_take_offset_worst(self.s)

    def read(self) -> tuple[dict[str, int], bool, int]:
        c, flat = (C.c_uint32 * 6)(), B()
        self.d.shim_plaus_read(self.s, c, C.byref(flat))
        return dict(zip(self.COUNTERS, c)), flat.value, self.d.plausibility_refused(self.s)


class CFlatLine:
    def __init__(self, lib: Lib, n: int, min_std: float):
        self.d, self.s = lib.dll, lib.new("flat")
        self.ok = self.d.flat_line_init(self.s, n, min_std)

    def add(self, x: float) -> bool:
        return self.d.flat_line_add(self.s, x)

    @property
    def var(self) -> float:
        return self.d.shim_flat_var(self.s)


class CBaroMotion:
    def __init__(self, lib: Lib, window_s: float, block_s: float, max_m: float):
        self.d, self.s = lib.dll, lib.new("bm")
        self.ok = self.d.shim_bm_init(self.s, round(window_s * 1e9), round(block_s * 1e9), max_m)

    def add(self, dt_ns: int, z_baro: float | None, a_up: float | None, z_hat: float, vz_hat: float,
            judging: bool) -> bool:
        return self.d.baro_motion_add(self.s, dt_ns, z_baro is not None, 0.0 if z_baro is None else z_baro,
                                      a_up is not None, 0.0 if a_up is None else a_up, z_hat, vz_hat, judging)

    def reading_rejected(self) -> None:
        self.d.baro_motion_reading_rejected(self.s)

    def take_reanchor(self) -> tuple[float, float] | None:
        z, v = F(), F()
        return (z.value, v.value) if self.d.baro_motion_take_reanchor(self.s, C.byref(z), C.byref(v)) else None

    def take_worst(self) -> float:
        return self.d.baro_motion_take_worst(self.s)

    def on_ground(self) -> None:
        self.d.baro_motion_on_ground(self.s)

    def read(self) -> tuple[dict[str, int], float, int]:
        c, w, n = (C.c_uint32 * 3)(), F(), C.c_uint16()
        self.d.shim_bm_read(self.s, c, C.byref(w), C.byref(n))
        return dict(zip(("windows", "disagreements", "taken_back"), c)), w.value, n.value


class CPrefilter:
    def __init__(self, lib: Lib, omega: float, T_s: float):
        self.d, self.s = lib.dll, lib.new("pf")
        self.ok = self.d.shim_pf_init(self.s, omega, T_s)

    def params(self) -> tuple[np.ndarray, np.ndarray]:
        a, b = _fa(9), _fa(3)
        self.d.shim_pf_params(self.s, a, b)
        return np.array(a).reshape(3, 3), np.array(b)

    def update(self, cmd: float) -> tuple[float, float, float, float]:
        out = _fa(4)
        self.d.shim_pf_update(self.s, cmd, out)
        return tuple(out)  # type: ignore[return-value]

    def reset(self, value: float) -> tuple[float, float, float, float]:
        out = _fa(4)
        self.d.shim_pf_reset(self.s, value, out)
        return tuple(out)  # type: ignore[return-value]


class CMemory:
    def __init__(self, lib: Lib, literal: bool, T_s: float, omega1: float, omega2: float, k0: float, J: float,
                 tau: float, lim: float):
        self.d, self.s = lib.dll, lib.new("mem")
        self.ok = self.d.shim_mem_init(self.s, literal, T_s, omega1, omega2, k0, J, tau, lim)

    def update(self, ref: tuple[float, float, float, float], angle: float, rate: float, active: bool) -> float:
        return self.d.shim_mem_update(self.s, (C.c_float * 4)(*ref), angle, rate, active)

    def set_applied(self, torque: float) -> None:
        self.d.memory_attitude_set_applied(self.s, torque)

    def reset(self) -> None:
        self.d.memory_attitude_reset(self.s)

    def read(self) -> tuple[np.ndarray, dict[str, int]]:
        out, c = _fa(6), (C.c_uint32 * 2)()
        self.d.shim_mem_read(self.s, out, c)
        return np.array(out), dict(zip(("nonfinite_input", "nonfinite_applied"), c))


class CYaw:
    def __init__(self, lib: Lib, kp: float, ki: float, lim: float, T_s: float):
        self.d, self.s = lib.dll, lib.new("yaw")
        self.ok = self.d.shim_yaw_init(self.s, kp, ki, lim, T_s)

    def update(self, ref: float, meas: float, active: bool) -> float:
        return self.d.yaw_rate_update(self.s, ref, meas, active)

    def set_applied(self, torque: float) -> None:
        self.d.yaw_rate_set_applied(self.s, torque)

    def read(self) -> tuple[float, float, dict[str, int]]:
        out, c = _fa(2), (C.c_uint32 * 2)()
        self.d.shim_yaw_read(self.s, out, c)
        return out[0], out[1], dict(zip(("nonfinite_input", "nonfinite_applied"), c))


class CLqi:
    def __init__(self, lib: Lib, T_s: float, m_kg: float, F_max_N: float):
        self.d, self.s = lib.dll, lib.new("lqi")
        self.ok = self.d.shim_lqi_init(self.s, T_s, m_kg, F_max_N)

    def update(self, z_ref: float, z: float, vz: float, az: float, active: bool) -> float:
        return self.d.lqi_altitude_update(self.s, z_ref, z, vz, az, active)

    def read(self) -> tuple[float, float, float, int]:
        out, n = _fa(3), C.c_uint32()
        self.d.shim_lqi_read(self.s, out, C.byref(n))
        return out[0], out[1], out[2], n.value


@dataclass(frozen=True)
class CMix:
    throttle: tuple[float, ...]
    applied_tau_Nm: tuple[float, ...]
    saturated: bool
    applied_collective_throttle: float
    applied_command_Nm: tuple[float, ...]


class CMixer:
    def __init__(self, lib: Lib, frame: str, arm_m: float, F_max_motor_N: float, kq: float, differential: str,
                 hover: float):
        self.d, self.s = lib.dll, lib.new("mixer")
        self.ok = self.d.shim_mixer_init(self.s, {"x": 0, "plus": 1}[frame], arm_m, F_max_motor_N, kq,
                                         {"thrust": 0, "throttle": 1}[differential], hover)

    def mix(self, collective: float, tau: tuple[float, float, float]) -> CMix:
        out = _fa(12)
        self.d.shim_mixer_mix(self.s, collective, (C.c_float * 3)(*tau), out)
        o = list(out)
        return CMix(tuple(o[0:4]), tuple(o[4:7]), o[7] != 0.0, o[8], tuple(o[9:12]))

    def read(self) -> tuple[np.ndarray, dict[str, int]]:
        m, c = _fa(12), (C.c_uint32 * 2)()
        self.d.shim_mixer_read(self.s, m, c)
        return np.array(m).reshape(3, 4), dict(zip(("nonfinite_collective", "nonfinite_torque"), c))


class CDescent:
    def __init__(self, lib: Lib, rate: float):
        self.d, self.s = lib.dll, lib.new("descent")
        self.ok = self.d.landing_descent_init(self.s, rate)

    def start(self, z: float) -> None:
        self.d.landing_descent_start(self.s, z)

    def stop(self) -> None:
        self.d.landing_descent_stop(self.s)

    def step(self, dt: float) -> float:
        return self.d.landing_descent_step(self.s, dt)


class CHover:
    def __init__(self, lib: Lib, initial: float, tau_s: float = 2.0, lo: float = 0.0, hi: float = 1.0):
        self.d, self.s = lib.dll, lib.new("hover")
        self.ok = self.d.hover_throttle_init(self.s, initial, tau_s, lo, hi)

    def update(self, collective: float, dt: float) -> float:
        return self.d.hover_throttle_update(self.s, collective, dt)

    @property
    def learnt_s(self) -> float:
        return np.frombuffer(self.s, dtype=np.float32, count=6)[5].item()

    def steady(self, z: float, vz: float, az: float, clear: float) -> bool:
        return self.d.hover_throttle_steady(z, vz, az, clear)


class CTouchdown:
    def __init__(self, lib: Lib):
        self.d, self.s = lib.dll, lib.new("touchdown")
        self.d.touchdown_accel_init(self.s)

    def update(self, a: float, dt: float) -> float:
        return self.d.touchdown_accel_update(self.s, a, dt)
