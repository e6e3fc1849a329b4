"""The flight code's own configuration: one TOML file, read with ``tomllib``, checked by hand.

Every table maps onto a frozen dataclass (flightcode/config_tables.py: units in the field
names, defaults = the paper's vehicle); docs/flightcode.md documents every key. Only
``[ports]`` is required; any other
table or key may be left out to take its default. Unknown tables or keys, wrong types and
out-of-range values are errors naming the file, the dotted key and the reason, e.g.::

    vehicle.toml: attitude.law: must be one of 'generalised', 'paper_literal' (got 'fast')

The bench never imports this module: it asks ``python -m flightcode --check-config``
(flightcode/check.py) whether the config a run would give the flight code is valid.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
import types
import typing
from pathlib import Path
from typing import Any, Literal

from flightcode.config_tables import FlightConfig
from flightcode.drivers.analog import parse_mount
from flightcode.drivers.buspirate_protocol import SPEED_CODES


class ConfigError(ValueError):
    """A config file problem: ``file``, dotted ``key`` and ``reason``."""

    def __init__(self, file: str, key: str, reason: str) -> None:
        super().__init__(f"{file}: {key}: {reason}" if key else f"{file}: {reason}")
        self.file = file
        self.key = key
        self.reason = reason


# -- generic structural check -----------------------------------------------------------------
def _type_name(tp: Any) -> str:
    if dataclasses.is_dataclass(tp):
        return "a table"
    return {int: "an integer", float: "a number", bool: "true or false", str: "a string"}.get(tp, str(tp))


def _convert(file: str, key: str, tp: Any, value: Any) -> Any:
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        options = [a for a in typing.get_args(tp) if a is not type(None)]
        return _convert(file, key, options[0], value)
    if origin is Literal:
        choices = typing.get_args(tp)
        if value not in choices or type(value) is not type(choices[0]):
            raise ConfigError(file, key, f"must be one of {', '.join(repr(c) for c in choices)} (got {value!r})")
        return value
    if origin is tuple:
        args = typing.get_args(tp)
        if not isinstance(value, list):
            raise ConfigError(file, key, f"must be an array of {len(args)} values (got {value!r})")
        if len(value) != len(args):
            raise ConfigError(file, key, f"must have exactly {len(args)} elements (got {len(value)})")
        return tuple(_convert(file, f"{key}[{i}]", a, v) for i, (a, v) in enumerate(zip(args, value)))
    if dataclasses.is_dataclass(tp):
        if not isinstance(value, dict):
            raise ConfigError(file, key, f"must be a table (got {value!r})")
        return _build(file, key, tp, value)
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(file, key, f"must be a number (got {value!r})")
        if not math.isfinite(value):
            raise ConfigError(file, key, f"must be finite (got {value!r})")
        return float(value)
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(file, key, f"must be an integer (got {value!r})")
        return value
    if tp is bool or tp is str:
        if not isinstance(value, tp):
            raise ConfigError(file, key, f"must be {_type_name(tp)} (got {value!r})")
        return value
    raise TypeError(f"config field {key} has unsupported type {tp!r}")  # our bug, not the user's


def _build(file: str, prefix: str, cls: Any, table: dict[str, Any]) -> Any:
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    for key in table:
        if key not in fields:
            known = ", ".join(sorted(fields))
            raise ConfigError(file, f"{prefix}.{key}" if prefix else key, f"unknown key (known here: {known})")
    kwargs = {}
    for name, f in fields.items():
        dotted = f"{prefix}.{name}" if prefix else name
        if name in table:
            kwargs[name] = _convert(file, dotted, hints[name], table[name])
        elif f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
            raise ConfigError(file, dotted, f"missing ({_type_name(hints[name])} is required)")
    return cls(**kwargs)


# -- semantic checks ----------------------------------------------------------------------------
def _check(file: str, cfg: FlightConfig) -> None:
    def need(ok: bool, key: str, reason: str) -> None:
        if not ok:
            raise ConfigError(file, key, reason)

    positive = {
        "imu.rate_hz": cfg.imu.rate_hz, "imu.reply_timeout_s": cfg.imu.reply_timeout_s,
        "adc.vref_V": cfg.adc.vref_V, "adc.read_timeout_s": cfg.adc.read_timeout_s,
        "adc.reply_timeout_s": cfg.adc.reply_timeout_s, "adc.resync_interval_s": cfg.adc.resync_interval_s,
        "adc.quiet_s": cfg.adc.quiet_s, "adc.baro.supply_V": cfg.adc.baro.supply_V,
        "adc.baro.k_per_kPa": cfg.adc.baro.k_per_kPa, "adc.baro.gain": cfg.adc.baro.gain,
        "adc.baro.zero_average_s": cfg.adc.baro.zero_average_s, "adc.accel.supply_V": cfg.adc.accel.supply_V,
        "adc.accel.sens_ratio_per_g": cfg.adc.accel.sens_ratio_per_g, "rc.half_range_us": cfg.rc.half_range_us,
        "rc.throttle_range_us": cfg.rc.throttle_range_us, "rc.max_angle_deg": cfg.rc.max_angle_deg,
        "rc.max_yaw_rate_dps": cfg.rc.max_yaw_rate_dps, "vehicle.arm_m": cfg.vehicle.arm_m,
        "vehicle.F_max_N": cfg.vehicle.F_max_N, "vehicle.kq_over_kt_m": cfg.vehicle.kq_over_kt_m,
        "vehicle.m_kg": cfg.vehicle.m_kg, "attitude.J_hat_kgm2": cfg.attitude.J_hat_kgm2,
        "attitude.u_limit_Nm": cfg.attitude.u_limit_Nm, "attitude.prefilter_omega_radps":
        cfg.attitude.prefilter_omega_radps, "attitude.omega1_radps": cfg.attitude.omega1_radps,
        "attitude.omega2_radps": cfg.attitude.omega2_radps, "yaw.u_limit_Nm": cfg.yaw.u_limit_Nm,
        "altitude.T1_s": cfg.altitude.T1_s, "altitude.q_int": cfg.altitude.q_int, "altitude.r": cfg.altitude.r,
        "altitude.alt_range_m": cfg.altitude.alt_range_m, "kf.r_baro_m2": cfg.kf.r_baro_m2,
        "kf.r_acc": cfg.kf.r_acc, "kf.r_rest_vz": cfg.kf.r_rest_vz, "failsafe.rc_loss_s": cfg.failsafe.rc_loss_s,
        "failsafe.descend_mps": cfg.failsafe.descend_mps, "failsafe.imu_timeout_s": cfg.failsafe.imu_timeout_s,
        "telemetry.divider": cfg.telemetry.divider, "log.stats_period_s": cfg.log.stats_period_s,
        "modes.gesture_hold_s": cfg.modes.gesture_hold_s, "modes.landed_s": cfg.modes.landed_s,
        "modes.landed_vz_mps": cfg.modes.landed_vz_mps, "kf.baro_gate_chi2": cfg.kf.baro_gate_chi2,
        "plausibility.baro_max_step_Pa": cfg.plausibility.baro_max_step_Pa,
        "plausibility.baro_flat_std_Pa": cfg.plausibility.baro_flat_std_Pa,
        "plausibility.accel_max_g": cfg.plausibility.accel_max_g,
        "plausibility.accel_xsens_tolerance_mps2": cfg.plausibility.accel_xsens_tolerance_mps2,
        "plausibility.accel_offset_tau_s": cfg.plausibility.accel_offset_tau_s,
        "plausibility.accel_offset_max_mps2": cfg.plausibility.accel_offset_max_mps2,
        "plausibility.baro_motion_block_s": cfg.plausibility.baro_motion_block_s,
        "plausibility.baro_motion_max_m": cfg.plausibility.baro_motion_max_m,
        "rc.capture.lock_frames": cfg.rc.capture.lock_frames, "rc.capture.stale_ms": cfg.rc.capture.stale_ms,
    }
    for key, value in positive.items():
        need(value > 0, key, f"must be > 0 (got {value})")
    flat_n = cfg.plausibility.baro_flat_readings
    need(flat_n == 0 or flat_n >= 2, "plausibility.baro_flat_readings",
         f"must be 0 (off) or >= 2 (got {flat_n})")
    pl = cfg.plausibility
    need(pl.baro_motion_window_s == 0 or pl.baro_motion_window_s >= 2 * pl.baro_motion_block_s,
         "plausibility.baro_motion_window_s",
         f"must be 0 (off) or at least two blocks of baro_motion_block_s (got {pl.baro_motion_window_s})")
    need(0.0 <= cfg.adc.baro.rail_margin_V < 0.25 * cfg.adc.vref_V, "adc.baro.rail_margin_V",
         f"must be >= 0 and < a quarter of vref_V (got {cfg.adc.baro.rail_margin_V})")
    non_negative = {
        "attitude.k0_per_s": cfg.attitude.k0_per_s, "attitude.tau_ff_s": cfg.attitude.tau_ff_s,
        "yaw.kp_Nm_per_radps": cfg.yaw.kp_Nm_per_radps, "yaw.ki_Nm_per_rad": cfg.yaw.ki_Nm_per_rad,
        "altitude.q_z": cfg.altitude.q_z, "altitude.q_vz": cfg.altitude.q_vz, "altitude.q_az": cfg.altitude.q_az,
        "altitude.takeoff_alt_m": cfg.altitude.takeoff_alt_m, "kf.q_a": cfg.kf.q_a, "kf.q_d": cfg.kf.q_d,
        "kf.q_b": cfg.kf.q_b, "kf.rest_after_s": cfg.kf.rest_after_s,
        "kf.ground_effect_alt_m": cfg.kf.ground_effect_alt_m, "telemetry.max_out_waiting": cfg.telemetry.max_out_waiting,
        "kf.baro_gate_timeout_s": cfg.kf.baro_gate_timeout_s,
    }
    for key, value in non_negative.items():
        need(value >= 0, key, f"must be >= 0 (got {value})")
    for name in ("imu", "adc", "rc", "esc", "telemetry"):
        port = getattr(cfg.ports, name)
        if port is not None:
            need(port.path != "", f"ports.{name}.path", "must not be empty")
            need(port.baud > 0, f"ports.{name}.baud", f"must be > 0 (got {port.baud})")
    if cfg.imu.identity == "mk4":
        need(400 % cfg.imu.rate_hz == 0, "imu.rate_hz", f"a mk4 outputs at divisors of 400 Hz (got {cfg.imu.rate_hz})")
    else:
        period = round(115_200 / cfg.imu.rate_hz)
        need(225 <= period <= 1152, "imu.rate_hz", f"legacy MTi rates are 100..512 Hz (got {cfg.imu.rate_hz})")
    need(cfg.imu.goto_config_attempts >= 1, "imu.goto_config_attempts", "must be >= 1")
    need(cfg.adc.spi_speed_hz in SPEED_CODES, "adc.spi_speed_hz",
         f"must be one of {', '.join(str(s) for s in sorted(SPEED_CODES))} (got {cfg.adc.spi_speed_hz})")
    need(cfg.adc.entry_attempts >= 1, "adc.entry_attempts", "must be >= 1")
    channels = (cfg.adc.baro_channel, *cfg.adc.accel_channels)
    need(all(0 <= c <= 3 for c in channels) and len(set(channels)) == 4, "adc.accel_channels",
         f"baro_channel and accel_channels must be four different MCP3204 channels 0..3 (got {channels})")
    try:
        parse_mount(cfg.adc.accel.mount_B)
    except ValueError as exc:
        raise ConfigError(file, "adc.accel.mount_B", str(exc)) from None
    rc_channels = (cfg.rc.channel_roll, cfg.rc.channel_pitch, cfg.rc.channel_throttle, cfg.rc.channel_yaw)
    need(all(1 <= c <= 16 for c in rc_channels) and len(set(rc_channels)) == 4, "rc.channel_roll",
         f"roll/pitch/throttle/yaw channels must be four different numbers 1..16 (got {rc_channels})")
    cap = cfg.rc.capture
    need(0 < cap.pulse_min_us < cap.pulse_max_us < cap.sync_min_us, "rc.capture.sync_min_us",
         "need 0 < pulse_min_us < pulse_max_us < sync_min_us")
    need(1 <= cap.min_channels <= cap.max_channels, "rc.capture.min_channels", "need 1 <= min_channels <= max_channels")
    need(cap.min_channels >= max(rc_channels), "rc.capture.min_channels",
         f"must be >= the highest stick channel {max(rc_channels)}")
    need(cap.stale_ms < 65.5, "rc.capture.stale_ms", "must be below the 65.5 ms capture-timer wrap")
    esc = cfg.esc
    need(0 < esc.min_us <= esc.idle_us < esc.max_us <= 4095, "esc.idle_us", "need 0 < min_us <= idle_us < max_us")
    need(0 <= esc.first_channel <= 20, "esc.first_channel", "must be 0..20 (Maestro channels)")
    need(cfg.vehicle.m_kg * 9.80665 < cfg.vehicle.F_max_N, "vehicle.F_max_N", "cannot lift m_kg")
    need(cfg.altitude.takeoff_alt_m < cfg.altitude.alt_range_m, "altitude.takeoff_alt_m", "must be below alt_range_m")
    need(0 <= cfg.telemetry.dest16 <= 0xFFFF, "telemetry.dest16", "must be a 16-bit address")
    need(not cfg.telemetry.enable or cfg.ports.telemetry is not None, "ports.telemetry",
         "missing (telemetry.enable is true)")
    need(cfg.kf.ground_effect_r_scale >= 1.0, "kf.ground_effect_r_scale",
         f"must be >= 1 (1 = no ground-effect allowance; got {cfg.kf.ground_effect_r_scale})")
    need(cfg.failsafe.imu_timeout_s > cfg.T_s, "failsafe.imu_timeout_s", "must be longer than one sample period")
    need(0.0 < cfg.modes.landed_collective_ratio < 1.0, "modes.landed_collective_ratio",
         f"must be between 0 and 1 (a fraction of the hover collective; got {cfg.modes.landed_collective_ratio})")


def parse(text: str, file: str = "<config>") -> FlightConfig:
    """Parse and check a config from TOML text; ConfigError on any problem."""
    try:
        table = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(file, "", f"not valid TOML: {exc}") from None
    try:
        cfg = _build(file, "", FlightConfig, table)
    except ValueError as exc:
        if isinstance(exc, ConfigError):
            raise
        raise ConfigError(file, "", str(exc)) from None
    _check(file, cfg)
    return cfg


def load(path: str | Path) -> FlightConfig:
    """Read and check the config file at ``path``; ConfigError on any problem."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(str(p), "", f"cannot read: {exc.strerror or exc}") from None
    return parse(text, str(p))
