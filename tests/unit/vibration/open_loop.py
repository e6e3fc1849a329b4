"""An open-loop sensor run of the default rig without ports or flight code: the plant, the
XSENS and the analog chain wired as hil/flight/devices.py wires them, driven by a fixed throttle
script (take-off, climb, hover). Used to pin the sensor outputs with vibration off to the
values recorded before the vibration model existed (data/sensors_before_vibration.json).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

from emulators.analog.frontend import AnalogFrontEnd
from emulators.xsens.device import MtiDevice
from hil.flight.devices import spawn_rngs
from hil.plant.plant import Plant
from hil.config.rig import Rig, load_rig

GOLDEN = Path(__file__).with_name("data") / "sensors_before_vibration.json"
#: XSENS output: packet counter, SampleTimeFine, Acceleration and RateOfTurn at 400 Hz.
OUTPUT_CONFIGURATION = ((0x1020, 0xFFFF), (0x1060, 0xFFFF), (0x4020, 400), (0x8020, 400))
N_TICKS = 800
EVERY = 20  #: keep every 20th tick's values


#: The barometer stage the golden values were recorded with (field at 4.0 V on the pin; the
#: rig has since moved it to mid-scale, docs/analog-chain.md section 4).
RECORDED_CH0_OFFSET_V = 3.834625


def as_recorded(rig: Rig) -> Rig:
    """``rig`` with the analog chain the golden file was recorded with."""
    ch0 = dataclasses.replace(rig.analog.conditioning[0], offset_V=RECORDED_CH0_OFFSET_V)
    conditioning = (ch0, *rig.analog.conditioning[1:])
    return dataclasses.replace(rig, analog=dataclasses.replace(rig.analog, conditioning=conditioning))


def throttle_at(k: int) -> float:
    """Ramp to 0.80 over 0.5 s (lifts off), then 0.74 (about hover)."""
    return min(0.80, 0.8 * k / 200) if k < 400 else 0.74


def run(rig: Rig | None = None, seed: int = 7, n_ticks: int = N_TICKS) -> dict[str, Any]:
    """Per kept tick: ADC volts (4 channels) at the tick, the XSENS acceleration and rate of
    turn as sent (SampleSent), and the plant's true height."""
    rig = rig or load_rig()
    rngs = spawn_rngs(seed)
    plant = Plant(rig.plant, rngs["plant"], vibration_rng=rngs["vibration"])
    imu = MtiDevice(dataclasses.replace(rig.imu, output_configuration=OUTPUT_CONFIGURATION), rngs["imu"])
    analog = AnalogFrontEnd(rig.analog, rngs["analog"])
    tick = rig.tick_ns
    out: dict[str, Any] = {"t_ns": [], "volts": [], "acc": [], "rate": [], "h_m": []}
    for k in range(1, n_ticks + 1):
        t = k * tick
        th = throttle_at(k)
        plant.step(t, (th, th, th, th))
        s = plant.sensors()
        analog.update(t, s.p_static_Pa, s.f_acc_B_mps2, s.air_T_C)
        analog.set_vibration(s.t_ns, s.vib_f_acc_B)
        volts = [analog.volts(ch, t) for ch in range(4)]
        w, f = s.omega_S_radps, s.f_S_mps2
        if s.vib_f_S:  # as DeviceSet.emit_imu
            dv_f, dv_w = imu.vibration_S(s.vib_f_S, s.vib_omega_S, 0.0)
            w = tuple(a + b for a, b in zip(w, dv_w, strict=True))  # type: ignore[assignment]
            f = tuple(a + b for a, b in zip(f, dv_f, strict=True))  # type: ignore[assignment]
        imu.set_motion(s.q_NS, w, f)
        imu.advance(t)
        imu.take_output()
        sent = [e for e in imu.take_events() if type(e).__name__ == "SampleSent"]
        if k % EVERY == 0:
            out["t_ns"].append(t)
            out["volts"].append(volts)
            out["acc"].append(list(sent[-1].acc_mps2))
            out["rate"].append(list(sent[-1].rate_radps))
            out["h_m"].append(plant.state.h_m)
    return out


if __name__ == "__main__":  # regenerate the golden file (only from a tree without vibration)
    GOLDEN.parent.mkdir(exist_ok=True)
    GOLDEN.write_text(json.dumps(run(), indent=None) + "\n")
    print(f"wrote {GOLDEN}")
