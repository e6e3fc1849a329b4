"""Loading [[faults]]: every kind validates, and whatever the rig cannot do is refused at load
with the file, the entry's index, the key and the reason."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path
from typing import Any

import pytest

from hil.config import ConfigError
from hil.faults import (
    CATALOGUE,
    Layer,
    Timing,
    catalogue_table,
    load_faults,
    print_catalogue,
)
from hil.config.rig import Rig
from hil.config.scenario import Scenario

SRC = "rigs/scenarios/test.toml"

#: One valid entry per kind (parameters the default rig accepts).
VALID: dict[str, dict[str, Any]] = {
    "plant.wind": {"wind_N_mps": [3.0, 0.0, 0.0], "duration_s": 2.0},
    "plant.gust": {"peak_N_mps": [0.0, 5.0, 0.0], "duration_s": 1.0},
    "plant.payload": {"extra_mass_kg": 0.3},
    "plant.motor_failure": {"rotor": 2},
    "plant.thrust_loss": {"rotor": 0, "thrust_factor": 0.7},
    "plant.battery_sag": {"extra_ohm": 0.2},
    "imu.bias": {"gyro_bias_S_radps": [0.01, 0.0, 0.0]},
    "imu.drift": {"acc_drift_S_mps2_per_s": [0.0, 0.01, 0.0]},
    "imu.scale": {"gyro_scale": 1.05},
    "imu.noise": {"noise_factor": 5.0},
    "imu.freeze": {},
    "imu.saturation": {"gyro_range_radps": 1.0},
    "baro.bias": {"bias_Pa": 50.0},
    "baro.drift": {"drift_Pa_per_s": 2.0},
    "baro.scale": {"scale": 1.01},
    "baro.noise": {"noise_factor": 3.0},
    "baro.freeze": {},
    "baro.port_blocked": {},
    "baro.ground_effect": {},
    "accel.bias": {"bias_B_mps2": [0.5, 0.0, 0.0]},
    "accel.drift": {"drift_B_mps2_per_s": [0.0, 0.0, 0.1]},
    "accel.scale": {"scale": 1.1},
    "accel.noise": {"noise_factor": 4.0},
    "accel.freeze": {},
    "accel.saturation": {},
    "adc.channel_stuck": {"channel": 0, "stuck_V": 2.0},
    "adc.channel_open": {"channel": 1},
    "adc.vref_drift": {"drift_V_per_s": -0.05},
    "adc.dout_pulled_up": {},
    "wire.silence": {"port": "imu"},
    "wire.byte_loss": {"port": "rc", "loss_probability": 0.01},
    "wire.bit_flips": {"port": "telemetry", "direction": "both", "bit_error_rate": 1e-4},
    "wire.bad_checksum": {"port": "imu", "probability": 0.5},
    "wire.truncate": {"port": "imu"},
    "wire.duplicate": {"port": "rc", "probability": 0.1},
    "wire.delay": {"port": "imu", "delay_s": 0.01, "jitter_s": 0.005},
    "wire.baud_mismatch": {"port": "imu", "rate_error": 0.06},
    "imu.silence": {"duration_s": 0.5},
    "imu.reset": {},
    "imu.counter_jump": {"delta": 7},
    "rc.signal_loss": {"duration_s": 1.0},
    "rc.glitch": {"channel": 3},
    "rc.channel_count": {"n_channels": 6},
    "rc.channel_stuck": {"channel": 1, "pulse_us": 1700},
    "rc.sbus_flags": {"frame_lost": False},  # SBUS rigs only
    "esc.refuse_arm": {"esc": 1},
    "esc.desync": {"esc": 2, "rate_hz": 5.0},
    "esc.stuck": {"esc": 3, "throttle": 0.4},
    "telemetry.dropout": {"duration_s": 2.0},
    "telemetry.loss": {"loss_probability": 0.3},
    "process.kill": {},
    "process.restart": {"duration_s": 0.5},
}


def entry(kind: str, t_s: float = 1.0, **kw: Any) -> dict[str, Any]:
    return {"kind": kind, "t_s": t_s, **VALID[kind], **kw}


def refusal(rig: Rig, raw: dict[str, Any], **kw: Any) -> str:
    with pytest.raises(ConfigError) as info:
        load_faults([entry("plant.wind"), raw], rig, source=SRC, **kw)
    return str(info.value)


def sbus_rig(rig: Rig) -> Rig:
    return dataclasses.replace(rig, rc=dataclasses.replace(rig.rc, frontend="sbus"))


def test_every_kind_has_a_valid_example_that_loads(rig: Rig) -> None:
    assert set(VALID) == set(CATALOGUE)
    capture = [k for k in VALID if k != "rc.sbus_flags"]
    faults = load_faults([entry(k, t_s=0.5 + i) for i, k in enumerate(capture)], rig, source=SRC)
    assert [f.kind for f in faults] == capture
    assert [f.index for f in faults] == list(range(len(capture)))
    (sbus,) = load_faults([entry("rc.sbus_flags")], sbus_rig(rig), source=SRC)
    assert sbus.target == "rc SBUS flags" and sbus.params.failsafe and not sbus.params.frame_lost
    wind = faults[0]
    assert (wind.t_s, wind.duration_s, wind.t_ns, wind.end_ns) == (0.5, 2.0, 500_000_000, 2_500_000_000)
    assert wind.params.wind_N_mps == (3.0, 0.0, 0.0) and wind.source == SRC
    by_kind = {f.kind: f for f in faults}
    assert by_kind["wire.bit_flips"].target == "port telemetry both"
    assert by_kind["plant.motor_failure"].target == "rotor 2"
    assert by_kind["adc.channel_stuck"].target == "adc CH0"


def test_scenario_faults_table_loads_through_the_scenario_model(rig: Rig) -> None:
    sc = Scenario.model_validate({"scenario": {"name": "x", "duration_s": 5.0}, "faults": [entry("imu.bias")]})
    (f,) = load_faults(sc.faults, rig, source=SRC, run_duration_s=sc.scenario.duration_s)
    assert f.params.gyro_bias_S_radps == (0.01, 0.0, 0.0)


@pytest.mark.parametrize(
    ("raw", "key", "reason"),
    [
        # unknown kinds, envelope
        ({"kind": "imu.silenc", "t_s": 1.0}, "kind", "unknown fault kind 'imu.silenc' (did you mean imu.silence"),
        ({"t_s": 1.0}, "kind", "missing"),
        ({"kind": "imu.freeze"}, "t_s", "missing"),
        ({"kind": "imu.freeze", "t_s": -1.0}, "t_s", "must be a number >= 0"),
        ({"kind": "imu.freeze", "t_s": "soon"}, "t_s", "must be a number >= 0"),
        ({"kind": "imu.freeze", "t_s": 1.0, "duration_s": 0.0}, "duration_s", "must be a number > 0"),
        ({"kind": "imu.reset", "t_s": 1.0, "duration_s": 1.0}, "duration_s", "takes no duration"),
        ({"kind": "plant.gust", "t_s": 1.0, "peak_N_mps": [1, 0, 0]}, "duration_s", "missing"),
        ({"kind": "process.restart", "t_s": 1.0}, "duration_s", "missing"),
        # parameters: unknown, missing, invalid
        ({"kind": "imu.freeze", "t_s": 1.0, "port": "imu"}, "port", "unknown parameter of imu.freeze"),
        ({"kind": "baro.bias", "t_s": 1.0, "bias": 3.0}, "bias", "unknown parameter of baro.bias (its parameters: bias_Pa)"),
        ({"kind": "baro.bias", "t_s": 1.0}, "bias_Pa", "Field required"),
        ({"kind": "plant.thrust_loss", "t_s": 1.0, "rotor": 4, "thrust_factor": 0.5}, "rotor", "less than or equal to 3"),
        ({"kind": "wire.silence", "t_s": 1.0, "port": "imu", "direction": "up"}, "direction", "'tx', 'rx' or 'both'"),
        ({"kind": "wire.baud_mismatch", "t_s": 1.0, "port": "imu"}, "(parameters)", "exactly one of device_baud_bps"),
        # the rig cannot do it
        ({"kind": "wire.silence", "t_s": 1.0, "port": "gps"}, "port", "no port 'gps' on this rig"),
        ({"kind": "wire.silence", "t_s": 1.0, "port": "rc", "direction": "rx"}, "direction", "sends nothing on 'rc'"),
        ({"kind": "wire.bad_checksum", "t_s": 1.0, "port": "adc"}, "port", "Bus Pirate binary SPI on 'adc' (tx) has no checksum"),
        ({"kind": "wire.bad_checksum", "t_s": 1.0, "port": "esc", "direction": "rx"}, "port", "CRC disabled"),
        ({"kind": "wire.delay", "t_s": 1.0, "port": "imu", "direction": "rx", "delay_s": 0.1}, "direction", "only hold back"),
        ({"kind": "wire.delay", "t_s": 1.0, "port": "imu"}, "delay_s", "would change nothing"),
        ({"kind": "wire.baud_mismatch", "t_s": 1.0, "port": "esc", "direction": "rx", "rate_error": 0.1}, "port",
         "USB command port"),
        ({"kind": "wire.baud_mismatch", "t_s": 1.0, "port": "imu", "device_baud_bps": 921600}, "device_baud_bps",
         "equals the port's own"),
        ({"kind": "rc.channel_stuck", "t_s": 1.0, "channel": 9}, "channel", "sends 8 channels (1..8)"),
        ({"kind": "rc.glitch", "t_s": 1.0, "channel": 0}, "channel", "greater than or equal to 1"),
        ({"kind": "rc.glitch", "t_s": 1.0, "width_us": 700}, "width_us", "does not fit"),
        ({"kind": "rc.channel_count", "t_s": 1.0, "n_channels": 8}, "n_channels", "already sends 8 channels"),
        ({"kind": "imu.bias", "t_s": 1.0}, "gyro_bias_S_radps", "all zero"),
        ({"kind": "imu.saturation", "t_s": 1.0, "gyro_range_radps": 100.0}, "gyro_range_radps", "not below the device's range"),
        ({"kind": "imu.scale", "t_s": 1.0}, "gyro_scale", "both scales are 1"),
        ({"kind": "adc.channel_stuck", "t_s": 1.0, "channel": 0, "stuck_V": 7.0}, "stuck_V", "above the MCP3204's supply"),
        ({"kind": "adc.vref_drift", "t_s": 1.0}, "step_V", "all zero"),
        ({"kind": "esc.desync", "t_s": 1.0, "esc": 4}, "esc", "less than or equal to 3"),
        ({"kind": "rc.sbus_flags", "t_s": 1.0}, "kind", "this rig's RC front-end is 'capture', not SBUS"),
    ],
)
def test_refused_at_load_with_file_index_key_and_reason(rig: Rig, raw: dict[str, Any], key: str, reason: str) -> None:
    msg = refusal(rig, raw)
    kind = raw.get("kind")
    head = f"{SRC}: [[faults]] #1" + (f" ({kind})" if kind in CATALOGUE else "")
    line = next(ln for ln in msg.splitlines() if ln.startswith(f"{head} {key}:"))
    assert reason in line, msg


def test_rig_dependent_refusals(rig: Rig) -> None:
    sbus = sbus_rig(rig)
    msg = refusal(sbus, {"kind": "wire.bad_checksum", "t_s": 1.0, "port": "rc"})
    assert "SBUS on 'rc' (tx) has no checksum" in msg
    load_faults([{"kind": "wire.bad_checksum", "t_s": 1.0, "port": "rc"}], rig, source=SRC)  # capture CRC-8: fine
    load_faults([{"kind": "wire.bad_checksum", "t_s": 1.0, "port": "rc", "mode": "last_byte"}], sbus, source=SRC)

    transparent = dataclasses.replace(
        rig, telemetry=dataclasses.replace(rig.telemetry, vehicle=dataclasses.replace(rig.telemetry.vehicle, ap=0))
    )
    assert "XBee transparent mode (AP=0) on 'telemetry'" in refusal(
        transparent, {"kind": "wire.bad_checksum", "t_s": 1.0, "port": "telemetry"}
    )
    crc = dataclasses.replace(rig, esc=dataclasses.replace(rig.esc, maestro=dataclasses.replace(rig.esc.maestro, crc_enabled=True)))
    load_faults([{"kind": "wire.bad_checksum", "t_s": 1.0, "port": "esc", "direction": "rx"}], crc, source=SRC)

    no_baro = dataclasses.replace(
        rig, analog=dataclasses.replace(rig.analog, channel_map=("none", "accel_x", "accel_y", "accel_z"))
    )
    assert "no ADC channel of this rig is wired to the barometer" in refusal(no_baro, entry("baro.noise"))
    assert "CH0 is not connected" in refusal(no_baro, {"kind": "adc.channel_open", "t_s": 1.0, "channel": 0})

    quiet = dataclasses.replace(rig, imu=dataclasses.replace(rig.imu, gyro_noise_radps_per_rthz=0.0))
    assert "noise density is 0" in refusal(quiet, entry("imu.noise", signals="gyro"))
    load_faults([entry("imu.noise", signals="acc")], quiet, source=SRC)


def test_fault_after_the_end_of_the_run_is_refused(rig: Rig) -> None:
    msg = refusal(rig, entry("imu.freeze", t_s=30.0), run_duration_s=30.0)
    assert "t_s: 30 s is not before the end of the run (30 s)" in msg


def test_every_problem_of_every_entry_is_reported_together(rig: Rig) -> None:
    with pytest.raises(ConfigError) as info:
        load_faults(
            [
                {"kind": "baro.bias", "t_s": -2, "bias_Pa": "x", "extra": 1},
                entry("imu.freeze"),
                {"kind": "wire.silence", "t_s": 1.0, "port": "nope"},
                "not a table",
            ],
            rig,
            source=SRC,
        )
    lines = str(info.value).splitlines()
    assert [ln.split(":")[1].strip() for ln in lines] == [
        "[[faults]] #0 (baro.bias) t_s", "[[faults]] #0 (baro.bias) bias_Pa",
        "[[faults]] #0 (baro.bias) extra", "[[faults]] #2 (wire.silence) port", "[[faults]] #3",
    ]


def test_catalogue_describes_every_kind(rig: Rig) -> None:
    rows = catalogue_table()
    assert [r["kind"] for r in rows] == list(CATALOGUE)
    for r in rows:
        cls = CATALOGUE[r["kind"]]
        assert r["layer"] in {x.value for x in Layer} and r["timing"] in {x.value for x in Timing}
        assert r["description"] and cls.__doc__, r["kind"]
        assert re.fullmatch(r"[a-z]+\.[a-z_]+", r["kind"])
        assert r["kind"].split(".")[0] in {"plant", "imu", "baro", "accel", "adc", "wire", "rc", "esc", "telemetry",
                                           "process"}
        for p in r["params"]:
            assert p["description"], (r["kind"], p["name"])
    by = {r["kind"]: r for r in rows}
    bias = {p["name"]: p for p in by["baro.bias"]["params"]}["bias_Pa"]
    assert (bias["unit"], bias["required"], bias["type"]) == ("Pa", True, "float")
    wind = {p["name"]: p for p in by["plant.wind"]["params"]}["wind_N_mps"]
    assert wind["unit"] == "m/s"
    drift = {p["name"]: p for p in by["imu.drift"]["params"]}["gyro_drift_S_radps_per_s"]
    assert drift["unit"] == "rad/s^2" and drift["default"] == (0.0, 0.0, 0.0)


def test_print_catalogue_lists_every_kind() -> None:
    from rich.console import Console

    console = Console(record=True, width=250)
    print_catalogue(console)
    text = console.export_text()
    assert all(kind in text for kind in CATALOGUE)
    assert "[[faults]]" in text and "bias_Pa [Pa] required" in text


def test_docs_list_every_kind() -> None:
    doc = (Path(__file__).resolve().parents[3] / "docs" / "faults.md").read_text()
    missing = [k for k in CATALOGUE if f"`{k}`" not in doc]
    assert not missing
